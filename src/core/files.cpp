// Output-path checks and atomic writes (temp file in the same directory + fsync + rename).
#include "pcp/core/files.hpp"

#include "pcp/core/error.hpp"

#include <atomic>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>

#include <fcntl.h>
#include <unistd.h>

namespace fs = std::filesystem;

namespace pcp {

std::string file_extension(const std::string& path) {
    std::string ext = fs::path(path).extension().string();
    for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return ext;
}

namespace {

fs::path parent_dir(const std::string& path) {
    fs::path parent = fs::path(path).parent_path();
    return parent.empty() ? fs::path(".") : parent;
}

bool same_file(const fs::path& a, const fs::path& b) {
    std::error_code ec;
    if (fs::exists(a, ec) && fs::exists(b, ec)) return fs::equivalent(a, b, ec);
    return fs::weakly_canonical(a, ec) == fs::weakly_canonical(b, ec);
}

}  // namespace

void check_output_path(const std::string& output, const std::vector<std::string>& inputs) {
    PCP_CHECK(!output.empty(), "output path is empty");
    const fs::path dir = parent_dir(output);
    std::error_code ec;
    PCP_CHECK(fs::is_directory(dir, ec),
              output << ": output directory '" << dir.string() << "' does not exist");
    PCP_CHECK(::access(dir.c_str(), W_OK) == 0,
              output << ": output directory '" << dir.string() << "' is not writable");
    PCP_CHECK(!fs::is_directory(output, ec), output << ": output path is a directory");
    for (const std::string& input : inputs)
        PCP_CHECK(!same_file(output, input),
                  output << ": output path is the input file; choose another output name");
}

void write_file_atomically(const std::string& path,
                           const std::function<void(std::ostream&)>& write) {
    check_output_path(path);
    static std::atomic<unsigned> counter{0};
    const fs::path target(path);
    const fs::path tmp = parent_dir(path) / ("." + target.filename().string() + ".tmp-" +
                                             std::to_string(::getpid()) + "-" +
                                             std::to_string(counter++));
    try {
        {
            std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
            PCP_CHECK(out, path << ": cannot create temporary file '" << tmp.string()
                                << "': " << std::strerror(errno));
            errno = 0;
            write(out);
            out.flush();
            PCP_CHECK(out, path << ": write failed: "
                                << (errno != 0 ? std::strerror(errno) : "the stream reported an error (disk full?)"));
            out.close();
            PCP_CHECK(!out.fail(), path << ": write failed on close: " << (errno != 0 ? std::strerror(errno) : "disk full?"));
        }
        const int fd = ::open(tmp.c_str(), O_RDONLY);
        PCP_CHECK(fd >= 0, path << ": cannot reopen temporary file for sync");
        const int sync_rc = ::fsync(fd);
        ::close(fd);
        PCP_CHECK(sync_rc == 0, path << ": fsync failed: " << std::strerror(errno));
        std::error_code ec;
        fs::rename(tmp, target, ec);
        PCP_CHECK(!ec, path << ": cannot rename temporary file into place: " << ec.message());
    } catch (...) {
        std::error_code ignored;
        fs::remove(tmp, ignored);
        throw;
    }
}

}  // namespace pcp
