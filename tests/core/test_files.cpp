// Tests for pcp/files.hpp: atomic writes and output-path checks.
#include "pcp/core/error.hpp"
#include "pcp/core/files.hpp"

#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <iterator>

namespace fs = std::filesystem;

namespace {
fs::path tmp_dir(const std::string& name) {
    fs::path dir = fs::path(PCP_TEST_TMP_DIR) / name;
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}
std::string slurp(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}
}  // namespace

TEST_CASE("files: atomic write creates the file and leaves no temporary", "[files]") {
    const fs::path dir = tmp_dir("atomic_ok");
    const std::string path = (dir / "out.bin").string();
    pcp::write_file_atomically(path, [](std::ostream& out) { out << "hello"; });
    CHECK(slurp(path) == "hello");
    CHECK(std::distance(fs::directory_iterator(dir), fs::directory_iterator()) == 1);
}

TEST_CASE("files: a failing writer leaves the old file untouched and no temporary", "[files]") {
    const fs::path dir = tmp_dir("atomic_fail");
    const std::string path = (dir / "out.bin").string();
    pcp::write_file_atomically(path, [](std::ostream& out) { out << "old"; });
    CHECK_THROWS_AS(pcp::write_file_atomically(path, [](std::ostream& out) {
                        out << "half";
                        throw pcp::Error("writer failed");
                    }),
                    pcp::Error);
    CHECK(slurp(path) == "old");
    CHECK(std::distance(fs::directory_iterator(dir), fs::directory_iterator()) == 1);
}

TEST_CASE("files: output path checks name the problem", "[files]") {
    const fs::path dir = tmp_dir("check_output");
    const std::string input = (dir / "in.ply").string();
    std::ofstream(input) << "x";
    CHECK_THROWS_WITH(pcp::check_output_path((dir / "missing" / "out.ply").string()),
                      Catch::Contains("does not exist"));
    CHECK_THROWS_WITH(pcp::check_output_path(input, {input}), Catch::Contains("is the input file"));
    CHECK_THROWS_WITH(pcp::check_output_path(dir.string()), Catch::Contains("is a directory"));
    CHECK_NOTHROW(pcp::check_output_path((dir / "out.ply").string(), {input}));
    CHECK(pcp::file_extension("a/b/C.PLY") == ".ply");
}
