// Bad input through the command-line tools: every case gets a one-line error naming the file and
// the problem, a non-zero exit code, and leaves no output file behind.
#include "pcp/io/io.hpp"
#include "pcp/nn/gemm.hpp"
#include "pcp/cloud/shapes.hpp"
#include "pcp/render/render.hpp"
#include "test_meshes.hpp"

#include "pcp/settings.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <cstdio>
#include <string>
#include <vector>

#include <sys/wait.h>
#include <unistd.h>

namespace fs = std::filesystem;

namespace {

struct RunResult {
    int exit_code = -1;
    std::string err;
};

/// Runs a shell command line, capturing stderr.
RunResult run(const std::string& command) {
    const fs::path err_file = fs::path(PCP_TEST_TMP_DIR) / ("cli_err_" + std::to_string(::getpid()) + ".txt");
    const int status = std::system((command + " > /dev/null 2> '" + err_file.string() + "'").c_str());
    RunResult r;
    r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    std::ifstream in(err_file);
    r.err.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    fs::remove(err_file);
    return r;
}

std::string bin(const std::string& app) { return std::string(PCP_BIN_DIR) + "/" + app; }

fs::path case_dir(const std::string& name) {
    const fs::path dir = fs::path(PCP_TEST_TMP_DIR) / "cli" / name;
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}

void write_text(const fs::path& path, const std::string& text) { std::ofstream(path, std::ios::binary) << text; }

std::string xyz_lines(const pcp::Points& p) {
    std::string s;
    for (Eigen::Index i = 0; i < p.rows(); ++i)
        s += std::to_string(p(i, 0)) + " " + std::to_string(p(i, 1)) + " " + std::to_string(p(i, 2)) + "\n";
    return s;
}

/// Runs pcp_reconstruct INPUT -o OUT and checks the error contract.
void expect_failure(const fs::path& input, const fs::path& output, const std::string& problem, bool output_is_input = false) {
    const RunResult r = run(bin("pcp_reconstruct") + " '" + input.string() + "' -o '" + output.string() + "' --threads 1");
    INFO("stderr: " << r.err);
    CHECK(r.exit_code == 1);
    CHECK(r.err.find("pcp_reconstruct: ") == 0);
    CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);  // one line
    CHECK(r.err.find(problem) != std::string::npos);
    if (!output_is_input) CHECK(!fs::exists(output));
}

}  // namespace

TEST_CASE("cli: unreadable, empty and malformed files are named with the problem", "[cli]") {
    const fs::path dir = case_dir("files");
    const fs::path out = dir / "out.ply";
    expect_failure(dir / "missing.ply", out, "missing.ply");

    write_text(dir / "empty.xyz", "");
    expect_failure(dir / "empty.xyz", out, "empty.xyz");

    // Binary PLY announcing 100 vertices with only 10 present: truncated body.
    const pcp::PointCloud good = pcp::sample_sphere(100, 1.0, Eigen::Vector3d::Zero(), 1);
    pcp::write_point_cloud((dir / "full.ply").string(), good);
    std::ifstream in(dir / "full.ply", std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    write_text(dir / "truncated.ply", bytes.substr(0, bytes.size() - 90 * 3 * 8));
    expect_failure(dir / "truncated.ply", out, "truncated.ply");

    // Ascii PLY whose header counts exceed the data.
    write_text(dir / "short.ply", "ply\nformat ascii 1.0\nelement vertex 100\nproperty float x\nproperty float y\n"
                                  "property float z\nend_header\n" + xyz_lines(good.points.topRows(60)));
    expect_failure(dir / "short.ply", out, "short.ply");

    write_text(dir / "words.xyz", xyz_lines(good.points.topRows(60)) + "1.0 2.0 abc\n");
    expect_failure(dir / "words.xyz", out, "words.xyz");

    write_text(dir / "nan.xyz", xyz_lines(good.points.topRows(60)) + "1.0 nan 2.0\n");
    expect_failure(dir / "nan.xyz", out, "nan.xyz");
    write_text(dir / "inf.xyz", xyz_lines(good.points.topRows(60)) + "1.0 inf 2.0\n");
    expect_failure(dir / "inf.xyz", out, "inf.xyz");

    write_text(dir / "cloud.foo", xyz_lines(good.points));
    expect_failure(dir / "cloud.foo", out, "cloud.foo");
}

TEST_CASE("cli: too few and degenerate clouds say why", "[cli][heavy]") {
    const fs::path dir = case_dir("degenerate");
    const fs::path out = dir / "out.ply";
    const pcp::PointCloud good = pcp::sample_sphere(200, 1.0, Eigen::Vector3d::Zero(), 2);
    write_text(dir / "few.xyz", xyz_lines(good.points.topRows(20)));
    expect_failure(dir / "few.xyz", out, "at least 51");

    pcp::Points same = pcp::Points::Constant(100, 3, 1.5);
    write_text(dir / "same.xyz", xyz_lines(same));
    expect_failure(dir / "same.xyz", out, "identical");

    pcp::Points line(100, 3), plane(100, 3);
    for (Eigen::Index i = 0; i < 100; ++i) {
        line.row(i) << 0.1 * i, 0.2 * i, 1.0;
        plane.row(i) << good.points(i, 0), good.points(i, 1), 0.5 * good.points(i, 0) + 2.0;
    }
    write_text(dir / "line.xyz", xyz_lines(line));
    expect_failure(dir / "line.xyz", out, "line");
    write_text(dir / "plane.xyz", xyz_lines(plane));
    expect_failure(dir / "plane.xyz", out, "plane");

    // Duplicates are fine: the run succeeds.
    pcp::Points dup = good.points;
    dup.topRows(100).rowwise() = dup.row(0);
    write_text(dir / "dup.xyz", xyz_lines(dup));
    const fs::path dup_out = dir / "dup_mesh.ply";
    const RunResult r = run(bin("pcp_reconstruct") + " '" + (dir / "dup.xyz").string() + "' -o '" + dup_out.string() +
                            "' --preset fast --prior-epochs 3 --steps 100 --batch 500 --width 32 --resolution 24 --threads 1 -q");
    INFO("stderr: " << r.err);
    CHECK(r.exit_code == 0);
    CHECK(r.err.empty());
    CHECK(fs::exists(dup_out));
}

TEST_CASE("cli: bad output paths are refused before any work", "[cli]") {
    const fs::path dir = case_dir("outputs");
    const pcp::PointCloud good = pcp::sample_sphere(200, 1.0, Eigen::Vector3d::Zero(), 3);
    const fs::path input = dir / "in.ply";
    pcp::write_point_cloud(input.string(), good);
    const auto input_size = fs::file_size(input);

    expect_failure(input, dir / "no_such_dir" / "out.ply", "does not exist");
    expect_failure(input, dir / "out.stl", "unknown mesh extension");

    // Output path equal to the input: refused, and the input is untouched.
    expect_failure(input, dir / "." / "in.ply", "is the input", true);
    CHECK(fs::exists(input));
    CHECK(fs::file_size(input) == input_size);

    // A directory that cannot be written: immutable for root, or read-only for a normal user.
    const fs::path locked = dir / "locked";
    fs::create_directories(locked);
    const bool root = ::geteuid() == 0;
    if (root) {
        REQUIRE(std::system(("chattr +i '" + locked.string() + "' 2>/dev/null").c_str()) == 0);
    } else {
        fs::permissions(locked, fs::perms::owner_read | fs::perms::owner_exec);
    }
    const RunResult r = run(bin("pcp_reconstruct") + " '" + input.string() + "' -o '" + (locked / "out.ply").string() + "'");
    if (root) std::system(("chattr -i '" + locked.string() + "'").c_str());
    else fs::permissions(locked, fs::perms::owner_all);
    INFO("stderr: " << r.err);
    CHECK(r.exit_code == 1);
    CHECK(r.err.find("not writable") != std::string::npos);
    CHECK(!fs::exists(locked / "out.ply"));
}

TEST_CASE("cli: usage errors exit 2, --help exits 0 and lists defaults", "[cli]") {
    for (const char* app : {"pcp_train", "pcp_reconstruct", "pcp_eval", "pcp_render"}) {
        const RunResult help = run(bin(app) + " --help");
        CHECK(help.exit_code == 0);
        const RunResult bad = run(bin(app) + " --no-such-flag");
        CHECK(bad.exit_code == 2);
        CHECK(bad.err.find("usage error") != std::string::npos);
    }
    CHECK(run(bin("pcp_reconstruct") + " --threads -3").exit_code == 2);
    CHECK(run(bin("pcp_eval") + " only_one.ply").exit_code == 2);
    CHECK(run(bin("pcp_eval") + " a.ply b.ply --protocol famous").exit_code == 2);
    CHECK(run(bin("pcp_train") + " --grid 0 x.ply").exit_code == 2);
    const RunResult coarse = run(bin("pcp_reconstruct") + " --sign-repair-resolution 300 x.ply");
    CHECK(coarse.exit_code == 2);
    CHECK(coarse.err.find("--sign-repair-resolution must be in [2, 256]") != std::string::npos);
}

/// The standard output of a shell command line.
std::string output_of(const std::string& command) {
    std::string out;
    if (FILE* pipe = ::popen((command + " 2>/dev/null").c_str(), "r")) {
        char buf[4096];
        for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, pipe)) > 0;) out.append(buf, n);
        ::pclose(pipe);
    }
    return out;
}

TEST_CASE("cli: pcp_reconstruct --help lists at most 45 options, every setting is taken as --NAME or --set, "
          "--list-settings prints them, retired switches are unknown", "[cli]") {
    const std::string help = output_of(bin("pcp_reconstruct") + " --help");
    std::istringstream lines(help);
    int options = 0;
    for (std::string line; std::getline(lines, line);)
        if (line.rfind("  -", 0) == 0 || line.rfind("      --", 0) == 0) ++options;  // an option's row, not its help's
    INFO(help);
    CHECK(options >= 30);
    CHECK(options <= 45);
    const std::string listed = output_of(bin("pcp_reconstruct") + " --list-settings --preset fast");
    for (const pcp::Setting& s : pcp::reconstruct_settings()) {
        INFO(s.name);
        CHECK(listed.find("  " + s.name + " ") != std::string::npos);
    }
    CHECK(listed.find("  resolution               96 ") != std::string::npos);  // the preset's value
    CHECK(output_of(bin("pcp_reconstruct") + " --list-settings --winding-near 3").find("  winding-near             3 ") !=
          std::string::npos);
    CHECK(output_of(bin("pcp_reconstruct") + " --list-settings --set winding-near=4 --set spreads=0.5,1").find("  spreads                  0.5,1 ") !=
          std::string::npos);
    const RunResult unknown = run(bin("pcp_reconstruct") + " --set no-such=1 x.ply");
    CHECK(unknown.exit_code == 2);
    CHECK(unknown.err.find("unknown setting 'no-such'") != std::string::npos);
    const RunResult set_bad = run(bin("pcp_reconstruct") + " --set winding-near=-3 x.ply");
    CHECK(set_bad.exit_code == 2);
    CHECK(set_bad.err.find("--winding-near must be in [0, 100] (got '-3')") != std::string::npos);
    for (const char* retired : {"--stop-rule on", "--sign-guide on", "--bridge-cut on", "--sign-repair-parity 3"}) {
        INFO(retired);
        CHECK(help.find(std::string(retired).substr(0, std::string(retired).find(' '))) == std::string::npos);
        const RunResult r = run(bin("pcp_reconstruct") + " " + retired + " x.ply");
        CHECK(r.exit_code == 2);
    }
}

TEST_CASE("cli: --ablation takes the paper's ablation names, others exit 2 with the list", "[cli]") {
    const RunResult bad = run(bin("pcp_reconstruct") + " --ablation no-dq");
    INFO("stderr: " << bad.err);
    CHECK(bad.exit_code == 2);
    CHECK(bad.err.find("--ablation must be none, no-shift, direct, free-code, pointnet-code, no-prior or tune-prior (got 'no-dq')") !=
          std::string::npos);
    CHECK(bad.err.find("pointnet-code") != std::string::npos);
}

TEST_CASE("cli: pcp_reconstruct's self-prior region options: bad values exit 2 naming the flag", "[cli]") {
    for (const char* grid : {"0", "65", "-1"}) {
        const RunResult r = run(bin("pcp_reconstruct") + " --prior-grid " + grid + " x.ply");
        INFO("--prior-grid " << grid << " stderr: " << r.err);
        CHECK(r.exit_code == 2);
        CHECK(r.err.find("--prior-grid must be in [1, 64]") != std::string::npos);
    }
    const RunResult norm = run(bin("pcp_reconstruct") + " --prior-normalization scaled x.ply");
    INFO("stderr: " << norm.err);
    CHECK(norm.exit_code == 2);
    CHECK(norm.err.find("--prior-normalization must be none, center, scale or both (got 'scaled')") !=
          std::string::npos);
    const RunResult steps = run(bin("pcp_reconstruct") + " --prior-steps -5 x.ply");
    CHECK(steps.exit_code == 2);
    CHECK(steps.err.find("--prior-steps must be >= 0") != std::string::npos);
    // Valid values pass the option checks: the run then fails on the missing input (exit 1).
    const RunResult good = run(bin("pcp_reconstruct") + " --prior-grid 1 --prior-normalization center --prior-steps 10 "
                                                        "/nonexistent/x.ply -o '" + (case_dir("prior_regions") / "o.ply").string() + "'");
    INFO("stderr: " << good.err);
    CHECK(good.exit_code == 1);
    CHECK(good.err.find("/nonexistent/x.ply") != std::string::npos);
}

TEST_CASE("cli: prior source, tuning and batch options: bad values exit 2 naming the flag", "[cli]") {
    const std::vector<std::pair<std::string, std::string>> cases = {
        {" --prior-source both x.ply", "--prior-source must be auto, builtin or self (got 'both')"},
        {" --prior-source builtin --prior p.pcpm x.ply", "--prior-source and --prior exclude each other"},
        {" --self-prior --prior p.pcpm x.ply", "--self-prior and --prior exclude each other"},
        {" --prior-tune-steps -1 x.ply", "--prior-tune-steps must be >= 0"},
        {" --batch-parts -1 x.ply", "--batch-parts must be >= 0 (got '-1')"},
        {" --depth 0 x.ply", "--depth must be >= 1 (got '0')"}};
    for (const auto& c : cases) {
        const RunResult r = run(bin("pcp_reconstruct") + c.first);
        INFO(c.first << " stderr: " << r.err);
        CHECK(r.exit_code == 2);
        CHECK(r.err.find(c.second) != std::string::npos);
    }
    const RunResult shapes = run(bin("pcp_train") + " --save-shapes /tmp/x");
    INFO("stderr: " << shapes.err);
    CHECK(shapes.exit_code == 2);
    CHECK(shapes.err.find("--save-shapes needs --shapes N") != std::string::npos);
    const RunResult negative = run(bin("pcp_train") + " --shapes -3 -o p.pcpm");
    CHECK(negative.exit_code == 2);
    CHECK(negative.err.find("--shapes must be in [0, 100000]") != std::string::npos);
}

TEST_CASE("cli: pcp_train --shapes writes the same prior twice, and --save-shapes writes the clouds", "[cli]") {
    const fs::path dir = case_dir("train_shapes");
    const std::string quick = " --preset fast --shapes 3 --steps 20 --threads 2 -q -o ";
    const RunResult a = run(bin("pcp_train") + quick + "'" + (dir / "a.pcpm").string() + "'");
    INFO("stderr: " << a.err);
    REQUIRE(a.exit_code == 0);
    const RunResult b = run(bin("pcp_train") + quick + "'" + (dir / "b.pcpm").string() + "'");
    REQUIRE(b.exit_code == 0);
    std::ifstream fa(dir / "a.pcpm", std::ios::binary), fb(dir / "b.pcpm", std::ios::binary);
    const std::string ba((std::istreambuf_iterator<char>(fa)), {}), bb((std::istreambuf_iterator<char>(fb)), {});
    CHECK(!ba.empty());
    CHECK(ba == bb);  // deterministic, as scripts/make_builtin_prior.sh relies on
    const RunResult save = run(bin("pcp_train") + " --shapes 2 --save-shapes '" + (dir / "clouds").string() + "' -q");
    INFO("stderr: " << save.err);
    REQUIRE(save.exit_code == 0);
    CHECK(fs::exists(dir / "clouds" / "shape_000.ply"));
    CHECK(fs::exists(dir / "clouds" / "shape_001.ply"));
}

TEST_CASE("cli: pcp_reconstruct's sign-repair and denoise options: bad values exit 2 naming the flag", "[cli]") {
    const RunResult word = run(bin("pcp_reconstruct") + " --sign-repair yes x.ply");
    INFO("stderr: " << word.err);
    CHECK(word.exit_code == 2);
    CHECK(word.err.find("--sign-repair must be on or off (got 'yes')") != std::string::npos);
    for (const char* res : {"1", "257"}) {
        const RunResult r = run(bin("pcp_reconstruct") + " --sign-repair-resolution " + res + " x.ply");
        INFO("--sign-repair-resolution " << res << " stderr: " << r.err);
        CHECK(r.exit_code == 2);
        CHECK(r.err.find("--sign-repair-resolution must be in [2, 256]") != std::string::npos);
    }
    for (const char* passes : {"-1", "101", "3x", "automatic"}) {
        const RunResult r = run(bin("pcp_reconstruct") + " --denoise " + passes + " x.ply");
        INFO("--denoise " << passes << " stderr: " << r.err);
        CHECK(r.exit_code == 2);
        CHECK(r.err.find("--denoise must be auto or a number of passes in [0, 100] (got '" + std::string(passes) + "')") !=
              std::string::npos);
    }
    const RunResult neighbours = run(bin("pcp_reconstruct") + " --denoise 1 --denoise-neighbors 2 x.ply");
    CHECK(neighbours.exit_code == 2);
    CHECK(neighbours.err.find("--denoise-neighbors must be in [3, 256]") != std::string::npos);
    for (const char* width : {"-1", "-0.5"}) {
        const RunResult r = run(bin("pcp_reconstruct") + " --denoise 1 --denoise-mode-width " + width + " x.ply");
        INFO("--denoise-mode-width " << width << " stderr: " << r.err);
        CHECK(r.exit_code == 2);
        CHECK(r.err.find("--denoise-mode-width must be >= 0") != std::string::npos);
    }
    const RunResult far = run(bin("pcp_reconstruct") + " --grid-far-factor -2 x.ply");
    CHECK(far.exit_code == 2);
    CHECK(far.err.find("--grid-far-factor must be >= 0") != std::string::npos);
    for (const char* levels : {"0", "5"}) {
        const RunResult r = run(bin("pcp_reconstruct") + " --grid-far-levels " + levels + " x.ply");
        INFO("--grid-far-levels " << levels << " stderr: " << r.err);
        CHECK(r.exit_code == 2);
        CHECK(r.err.find("--grid-far-levels must be in [1, 4]") != std::string::npos);
    }
    // Not a number: refused by the option parser (exit 2, the value named).
    const RunResult nan_width = run(bin("pcp_reconstruct") + " --denoise 1 --denoise-mode-width nan x.ply");
    CHECK(nan_width.exit_code == 2);
    CHECK(nan_width.err.find("nan") != std::string::npos);
    const RunResult good = run(bin("pcp_reconstruct") + " --sign-repair off --sign-repair-resolution 32 --denoise auto --denoise-neighbors 30 /nonexistent/x.ply -o '" +
                               (case_dir("sign_repair") / "o.ply").string() + "'");
    INFO("stderr: " << good.err);
    CHECK(good.exit_code == 1);
    CHECK(good.err.find("/nonexistent/x.ply") != std::string::npos);
}

TEST_CASE("cli: pcp_reconstruct's surface-fit, fine-repair and fair options: bad values exit 2 naming the flag", "[cli]") {
    const RunResult word = run(bin("pcp_reconstruct") + " --surface-fit maybe x.ply");
    INFO("stderr: " << word.err);
    CHECK(word.exit_code == 2);
    CHECK(word.err.find("--surface-fit must be on or off (got 'maybe')") != std::string::npos);
    const RunResult fine = run(bin("pcp_reconstruct") + " --fine-repair 1 x.ply");
    INFO("stderr: " << fine.err);
    CHECK(fine.exit_code == 2);
    CHECK(fine.err.find("--fine-repair must be on or off (got '1')") != std::string::npos);
    const RunResult fair = run(bin("pcp_reconstruct") + " --fair yes x.ply");
    INFO("stderr: " << fair.err);
    CHECK(fair.exit_code == 2);
    CHECK(fair.err.find("--fair must be on or off (got 'yes')") != std::string::npos);
    for (const char* n : {"-1", "101"}) {
        const RunResult r = run(bin("pcp_reconstruct") + " --surface-fit-iterations " + n + " x.ply");
        INFO("--surface-fit-iterations " << n << " stderr: " << r.err);
        CHECK(r.exit_code == 2);
        CHECK(r.err.find("--surface-fit-iterations must be in [0, 100]") != std::string::npos);
    }
    const RunResult good = run(bin("pcp_reconstruct") + " --surface-fit off --surface-fit-iterations 3 --fine-repair off --fair off --keep-checkpoint /nonexistent/x.ply -o '" +
                               (case_dir("surface_fit") / "o.ply").string() + "'");
    INFO("stderr: " << good.err);
    CHECK(good.exit_code == 1);
    CHECK(good.err.find("/nonexistent/x.ply") != std::string::npos);
}

TEST_CASE("cli: pcp_reconstruct's cavity-fill, tunnel-fill, through-carve, shell-centre, recentre, smooth, winding-sign, winding-normals and label-votes options: bad values exit 2 naming the flag", "[cli]") {
    const struct {
        const char* args;
        const char* message;
    } cases[] = {
        {"--cavity-fill yes", "--cavity-fill must be on or off (got 'yes')"},
        {"--tunnel-fill maybe", "--tunnel-fill must be on or off (got 'maybe')"},
        {"--through-carve 1", "--through-carve must be on or off (got '1')"},
        {"--shell-centre 2", "--shell-centre must be on or off (got '2')"},
        {"--recentre yes", "--recentre must be auto, on or off (got 'yes')"},
        {"--smooth maybe", "--smooth must be auto, on or off (got 'maybe')"},
        {"--winding-sign 1", "--winding-sign must be on or off (got '1')"},
        {"--winding-near -3", "--winding-near must be in [0, 100]"},
        {"--winding-normals mesh", "--winding-normals must be labels or field (got 'mesh')"},
        {"--label-votes -1", "--label-votes must be >= 0"},
    };
    for (const auto& c : cases) {
        const RunResult r = run(bin("pcp_reconstruct") + " " + c.args + " x.ply");
        INFO(c.args << " stderr: " << r.err);
        CHECK(r.exit_code == 2);
        CHECK(r.err.find(c.message) != std::string::npos);
    }
    // Good values pass the option checks: the run then stops at the missing input, naming it.
    const RunResult good = run(bin("pcp_reconstruct") + " --cavity-fill off --tunnel-fill off --through-carve off --shell-centre off --recentre on --smooth on --winding-sign on --winding-near 1 --winding-normals field --label-votes 4 /nonexistent/x.ply -o '" +
                               (case_dir("cavity_fill") / "o.ply").string() + "'");
    INFO("stderr: " << good.err);
    CHECK(good.exit_code == 1);
    CHECK(good.err.find("/nonexistent/x.ply") != std::string::npos);
    CHECK_FALSE(std::filesystem::exists(case_dir("cavity_fill") / "o.ply"));
}

TEST_CASE("cli: bad --spreads and --uniform-fraction exit 2 naming the flag", "[cli]") {
    for (const std::string& program : {std::string("pcp_reconstruct"), std::string("pcp_train")}) {
        const RunResult spreads = run(bin(program) + " --spreads 0.5,-1 x.ply");
        INFO(program << " stderr: " << spreads.err);
        CHECK(spreads.exit_code == 2);
        CHECK(spreads.err.find("--spreads") != std::string::npos);
        CHECK(spreads.err.find("-1'") != std::string::npos);
        const RunResult uniform = run(bin(program) + " --uniform-fraction -0.5 x.ply");
        CHECK(uniform.exit_code == 2);
        CHECK(uniform.err.find("--uniform-fraction") != std::string::npos);
    }
}

TEST_CASE("cli: pcp_eval --sdf-samples reports the sign agreement, bad sample files exit 1 naming the file", "[cli]") {
    const fs::path dir = case_dir("eval_sdf");
    const pcp::Mesh sphere = pcp::test::uv_sphere(1.0, 16, 32);
    pcp::write_mesh((dir / "sphere.ply").string(), sphere);
    pcp::PointCloud samples;
    samples.points.resize(4, 3);
    samples.points << 0.2, 0, 0, 0.5, 0.5, 0, 1.5, 0, 0, 0, 0, 3;
    Eigen::VectorXd sdf(4);
    sdf << -0.8, -0.29, 0.5, 2.0;  // negative inside
    samples.properties["sdf"] = sdf;
    pcp::write_point_cloud((dir / "sdf.ply").string(), samples);

    const fs::path out = dir / "out.tsv";
    const std::string eval = bin("pcp_eval") + " '" + (dir / "sphere.ply").string() + "' '" + (dir / "sphere.ply").string() +
                             "' --tsv --no-floor --samples 2000 --sdf-samples '";
    REQUIRE(std::system((eval + (dir / "sdf.ply").string() + "' > '" + out.string() + "'").c_str()) == 0);
    std::ifstream in(out);
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    INFO(text);
    CHECK(text.find("sign_agreement\t1\t-\n") != std::string::npos);

    // The same samples with the opposite convention forced: nothing agrees.
    REQUIRE(std::system((eval + (dir / "sdf.ply").string() + "' --sdf-convention positive-inside > '" + out.string() + "'").c_str()) == 0);
    std::ifstream in_flipped(out);
    const std::string flipped((std::istreambuf_iterator<char>(in_flipped)), std::istreambuf_iterator<char>());
    INFO(flipped);
    CHECK(flipped.find("sign_agreement\t0\t-\n") != std::string::npos);

    pcp::PointCloud no_sdf;
    no_sdf.points = samples.points;
    pcp::write_point_cloud((dir / "plain.ply").string(), no_sdf);
    const RunResult missing = run(eval + (dir / "plain.ply").string() + "'");
    INFO("stderr: " << missing.err);
    CHECK(missing.exit_code == 1);
    CHECK(missing.err.find("plain.ply") != std::string::npos);
    CHECK(missing.err.find("no property 'sdf'") != std::string::npos);

    const RunResult bad_convention = run(eval + (dir / "sdf.ply").string() + "' --sdf-convention inside");
    CHECK(bad_convention.exit_code == 2);
    CHECK(bad_convention.err.find("--sdf-convention") != std::string::npos);
}

TEST_CASE("cli: --precision: bad values exit 2 naming the flag, and the run's summary names the precision", "[cli][heavy]") {
    for (const char* program : {"pcp_reconstruct", "pcp_train"}) {
        const RunResult bad = run(bin(program) + " --precision fp16 x.ply");
        INFO(program << " stderr: " << bad.err);
        CHECK(bad.exit_code == 2);
        CHECK(bad.err.find("--precision: unknown precision 'fp16': expected auto, fp32 or bf16") != std::string::npos);
    }
    const RunResult grid = run(bin("pcp_reconstruct") + " --grid-precision half x.ply");
    CHECK(grid.exit_code == 2);
    CHECK(grid.err.find("--grid-precision must be fp32 or training (got 'half')") != std::string::npos);
    const fs::path dir = case_dir("precision");
    std::vector<std::string> wanted{"fp32"};
    if (pcp::nn::bf16_available()) {
        wanted.push_back("bf16");
    } else {  // asked for explicitly where it cannot run: a usage error that says why
        const RunResult r = run(bin("pcp_reconstruct") + " --precision bf16 -o '" + (dir / "bf16.ply").string() + "'");
        CHECK(r.exit_code == 2);
        CHECK(r.err.find("bf16 is not available") != std::string::npos);
    }
    for (const std::string& p : wanted) {
        const fs::path out = dir / (p + ".ply");
        const RunResult r = run(bin("pcp_reconstruct") + " --preset fast --builtin-points 3000 --prior-steps 20 --steps 20 "
                                                         "--resolution 24 --precision " + p + " -o '" + out.string() + "'");
        INFO("stderr: " << r.err);
        CHECK(r.exit_code == 0);
        CHECK(r.err.find("| precision " + p) != std::string::npos);
        CHECK(r.err.find(std::string(", gemm ") + pcp::nn::gemm_backend_name(pcp::nn::gemm_backend())) !=
              std::string::npos);
        CHECK(fs::exists(out));
    }
}

TEST_CASE("cli: pcp_eval --diagnose prints the error budget, a missing --input exits 1 naming it", "[cli]") {
    const fs::path dir = case_dir("eval_diagnose");
    const pcp::Mesh sphere = pcp::test::uv_sphere(1.0, 16, 32);
    pcp::Mesh two = sphere;  // the sphere plus a detached copy far from the input: two components
    two.vertices.resize(2 * sphere.vertices.rows(), 3);
    two.vertices << sphere.vertices, (sphere.vertices * 0.2).rowwise() + Eigen::RowVector3d(3, 0, 0);
    two.faces.resize(2 * sphere.faces.rows(), 3);
    two.faces << sphere.faces, (sphere.faces.array() + static_cast<std::int32_t>(sphere.vertices.rows())).matrix();
    pcp::write_mesh((dir / "a.ply").string(), two);
    pcp::write_mesh((dir / "b.ply").string(), sphere);
    pcp::PointCloud input;
    input.points = pcp::sample_sphere(3000, 1.0, Eigen::Vector3d::Zero(), 5).points;
    pcp::write_point_cloud((dir / "c.ply").string(), input);

    const std::string eval = bin("pcp_eval") + " '" + (dir / "a.ply").string() + "' '" + (dir / "b.ply").string() +
                             "' --samples 2000 --diagnose --input '";
    const fs::path out = dir / "out.txt";
    REQUIRE(std::system((eval + (dir / "c.ply").string() + "' > '" + out.string() + "'").c_str()) == 0);
    std::ifstream in(out);
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    INFO(text);
    CHECK(text.find("pred: 2 components") != std::string::npos);
    CHECK(text.find("1 floating") != std::string::npos);

    REQUIRE(std::system((eval + (dir / "c.ply").string() + "' --tsv > '" + out.string() + "'").c_str()) == 0);
    std::ifstream in_tsv(out);
    const std::string tsv((std::istreambuf_iterator<char>(in_tsv)), std::istreambuf_iterator<char>());
    INFO(tsv);
    CHECK(tsv.find("pred_components\t2\n") != std::string::npos);
    CHECK(tsv.find("floating_components\t1\n") != std::string::npos);
    CHECK(tsv.find("pred_component.1.floating\t1\n") != std::string::npos);

    const RunResult missing = run(eval + (dir / "nowhere.ply").string() + "'");
    INFO("stderr: " << missing.err);
    CHECK(missing.exit_code == 1);
    CHECK(missing.err.find("nowhere.ply") != std::string::npos);
    CHECK(std::count(missing.err.begin(), missing.err.end(), '\n') == 1);

    const RunResult no_diagnose = run(bin("pcp_eval") + " '" + (dir / "a.ply").string() + "' '" + (dir / "b.ply").string() +
                                      "' --input '" + (dir / "c.ply").string() + "'");
    CHECK(no_diagnose.exit_code == 2);
    CHECK(no_diagnose.err.find("--diagnose") != std::string::npos);
}

TEST_CASE("cli: pcp_render draws meshes and clouds into one PNG, names bad inputs, never overwrites an input", "[cli]") {
    const fs::path dir = case_dir("render");
    const fs::path mesh = dir / "sphere.ply", cloud = dir / "cloud.xyz", ply_cloud = dir / "cloud.ply", out = dir / "view.png";
    pcp::write_mesh(mesh.string(), pcp::test::uv_sphere(1.0, 12, 24));
    write_text(cloud, xyz_lines(pcp::sample_sphere(300, 1.0, Eigen::Vector3d::Zero(), 4).points));
    pcp::write_point_cloud(ply_cloud.string(), pcp::sample_sphere(300, 1.0, Eigen::Vector3d::Zero(), 5));
    const std::string render = bin("pcp_render") + " '" + mesh.string() + "' '" + cloud.string() + "' ";

    // A .ply mesh, an .xyz cloud and a .ply cloud (no face element) side by side.
    const RunResult ok = run(render + "'" + ply_cloud.string() + "' --size 64 --labels mesh,cloud,plycloud -o '" + out.string() + "'");
    INFO("stderr: " << ok.err);
    CHECK(ok.exit_code == 0);
    REQUIRE(fs::exists(out));
    std::ifstream in(out, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    REQUIRE(bytes.size() > 24);
    CHECK(bytes.substr(1, 3) == "PNG");
    // IHDR: width 3 x 64, height 3 views x 64 (big-endian at bytes 16 and 20).
    CHECK(static_cast<unsigned char>(bytes[19]) == 192);
    CHECK(static_cast<unsigned char>(bytes[23]) == 192);

    // A missing input: exit 1, one line naming it, no picture.
    const fs::path out2 = dir / "none.png";
    const RunResult missing = run(bin("pcp_render") + " '" + mesh.string() + "' '" + (dir / "missing.ply").string() + "' -o '" +
                                  out2.string() + "'");
    INFO("stderr: " << missing.err);
    CHECK(missing.exit_code == 1);
    CHECK(missing.err.find("pcp_render: ") == 0);
    CHECK(std::count(missing.err.begin(), missing.err.end(), '\n') == 1);
    CHECK(missing.err.find("missing.ply") != std::string::npos);
    CHECK(!fs::exists(out2));

    // An empty cloud is named too.
    write_text(dir / "empty.xyz", "");
    const RunResult empty = run(render + "'" + (dir / "empty.xyz").string() + "' -o '" + out2.string() + "'");
    CHECK(empty.exit_code == 1);
    CHECK(empty.err.find("empty.xyz") != std::string::npos);
    CHECK(!fs::exists(out2));

    // -o equal to an input is refused and the input stays as it was.
    const fs::path fake_png = dir / "input.png";
    write_text(fake_png, "not a mesh");
    const auto mesh_size = fs::file_size(mesh);
    const RunResult same = run(render + "-o '" + (dir / "." / "sphere.ply").string() + "'");
    CHECK(same.exit_code == 2);  // not a .png: a usage error before anything is read
    CHECK(fs::file_size(mesh) == mesh_size);
    const RunResult same_png = run(bin("pcp_render") + " '" + mesh.string() + "' '" + fake_png.string() + "' -o '" +
                                   (dir / "." / "input.png").string() + "'");
    INFO("stderr: " << same_png.err);
    CHECK(same_png.exit_code == 1);
    CHECK(same_png.err.find("is the input") != std::string::npos);
    CHECK(fs::file_size(fake_png) == 10);

    // Usage errors: label count, views.
    CHECK(run(render + "--labels a -o '" + out2.string() + "'").exit_code == 2);
    const RunResult views = run(render + "--views sideways -o '" + out2.string() + "'");
    CHECK(views.exit_code == 2);
    CHECK(views.err.find("--views: 'sideways'") != std::string::npos);
    CHECK(run(render + "--views front,30:20 --size 32 -o '" + out2.string() + "'").exit_code == 0);
    CHECK(fs::exists(out2));
}

TEST_CASE("cli: --normals and --normals-from: bad paths and values are refused before any work", "[cli]") {
    const fs::path dir = case_dir("normals_flags");
    const pcp::PointCloud good = pcp::sample_sphere(200, 1.0, Eigen::Vector3d::Zero(), 3);
    const fs::path input = dir / "in.ply";
    pcp::write_point_cloud(input.string(), good);
    const std::string base = bin("pcp_reconstruct") + " '" + input.string() + "' -o '" + (dir / "out.ply").string() + "'";
    RunResult r = run(base + " --normals '" + (dir / "n.obj").string() + "'");
    CHECK(r.exit_code == 1);
    CHECK(r.err.find("n.obj") != std::string::npos);
    r = run(base + " --normals '" + (dir / "out.ply").string() + "'");
    CHECK(r.exit_code == 1);
    CHECK(r.err.find("output mesh") != std::string::npos);
    r = run(base + " --normals '" + input.string() + "'");
    CHECK(r.exit_code == 1);
    CHECK(r.err.find("is the input") != std::string::npos);
    r = run(base + " --normals '" + (dir / "n.ply").string() + "' --normals-from gradient");
    CHECK(r.exit_code == 2);
    CHECK(r.err.find("--normals-from") != std::string::npos);
    CHECK(!fs::exists(dir / "out.ply"));
    CHECK(!fs::exists(dir / "n.ply"));
}

TEST_CASE("cli: pcp_eval --normals scores oriented points against a GT mesh, points without normals exit 1 naming the file", "[cli]") {
    const fs::path dir = case_dir("eval_normals");
    pcp::write_mesh((dir / "gt.ply").string(), pcp::test::uv_sphere(1.0, 16, 32));
    pcp::PointCloud oriented = pcp::sample_sphere(500, 1.0, Eigen::Vector3d::Zero(), 5);  // outward normals
    pcp::write_point_cloud((dir / "n.ply").string(), oriented);
    const fs::path out = dir / "out.tsv";
    REQUIRE(std::system((bin("pcp_eval") + " --normals '" + (dir / "n.ply").string() + "' '" + (dir / "gt.ply").string() +
                         "' --tsv > '" + out.string() + "'").c_str()) == 0);
    std::ifstream in(out);
    const std::string tsv((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    INFO(tsv);
    CHECK(tsv.find("points\t500\n") != std::string::npos);
    CHECK(tsv.find("correct_side\t1\n") != std::string::npos);
    oriented.properties.clear();
    pcp::write_point_cloud((dir / "bare.ply").string(), oriented);
    const RunResult bare = run(bin("pcp_eval") + " --normals '" + (dir / "bare.ply").string() + "' '" + (dir / "gt.ply").string() + "'");
    CHECK(bare.exit_code == 1);
    CHECK(bare.err.find("bare.ply") != std::string::npos);
    CHECK(bare.err.find("normals") != std::string::npos);
    const RunResult both = run(bin("pcp_eval") + " --normals --diagnose '" + (dir / "n.ply").string() + "' '" + (dir / "gt.ply").string() + "'");
    CHECK(both.exit_code == 2);
}

TEST_CASE("cli: pcp_demo2d writes the figure's pictures, usage errors exit 2, an unusable directory exits 1 naming it", "[cli]") {
    const fs::path dir = case_dir("demo2d");
    const std::string demo = bin("pcp_demo2d");
    const RunResult ok = run(demo + " -o '" + (dir / "out").string() + "' --prior-steps 100 --fit-steps 100 --size 64 --quiet");
    INFO("stderr: " << ok.err);
    CHECK(ok.exit_code == 0);
    for (const char* name : {"figure.png", "prior.png", "queries.png", "predicted.png", "zero_set.png"})
        CHECK(fs::exists(dir / "out" / name));
    CHECK(pcp::read_png((dir / "out" / "figure.png").string()).width == 4 * 64);

    CHECK(run(demo).exit_code == 2);  // no -o
    CHECK(run(demo + " -o '" + dir.string() + "' --size 8").exit_code == 2);
    CHECK(run(demo + " -o '" + dir.string() + "' --fit-steps 0").exit_code == 2);
    write_text(dir / "a_file", "x");
    const RunResult blocked = run(demo + " -o '" + (dir / "a_file" / "sub").string() + "' --prior-steps 10 --fit-steps 10");
    INFO("stderr: " << blocked.err);
    CHECK(blocked.exit_code == 1);
    CHECK(blocked.err.find("pcp_demo2d: ") == 0);
    CHECK(blocked.err.find("a_file") != std::string::npos);
    CHECK(std::count(blocked.err.begin(), blocked.err.end(), '\n') == 1);
}

TEST_CASE("cli: pcp_reconstruct with several inputs fits them together and writes one mesh each into --output-dir", "[cli]") {
    const fs::path dir = case_dir("many");
    fs::create_directories(dir / "a");
    fs::create_directories(dir / "b");
    write_text(dir / "a" / "input.xyz", xyz_lines(pcp::sample_sphere(1500, 1.0, Eigen::Vector3d::Zero(), 6).points));
    write_text(dir / "b" / "input.xyz", xyz_lines(pcp::sample_torus(1500, 0.35, 0.12, 7).points));
    const std::string a = "'" + (dir / "a" / "input.xyz").string() + "' ", b = "'" + (dir / "b" / "input.xyz").string() + "' ";
    const std::string quick = " --preset fast --steps 40 --prior-steps 20 --prior-grid 2 --resolution 24 --threads 1";
    const fs::path out = dir / "out";

    // Same file names in two directories: DIR/<directory>_<name>.ply. The inputs from a list file
    // here (relative to it; comments and blank lines skipped), on the command line below.
    write_text(dir / "list.txt", "# two clouds\na/input.xyz\n\nb/input.xyz\n");
    const RunResult ok = run(bin("pcp_reconstruct") + " --list '" + (dir / "list.txt").string() + "' --output-dir '" +
                             out.string() + "'" + quick);
    INFO("stderr: " << ok.err);
    CHECK(ok.exit_code == 0);
    CHECK(fs::exists(out / "a_input.ply"));
    CHECK(fs::exists(out / "b_input.ply"));
    CHECK(!fs::exists(out / "pcp_many.ckpt"));  // removed unless --keep-checkpoint
    CHECK(ok.err.find("a_input.ply") != std::string::npos);

    // --keep-checkpoint keeps the joint networks; --resume then re-meshes from them without
    // training: the same meshes, byte for byte.
    const fs::path kept = dir / "kept";
    const std::string keep_run = bin("pcp_reconstruct") + " " + a + b + "--output-dir '" + kept.string() + "'" + quick + " --keep-checkpoint";
    REQUIRE(run(keep_run).exit_code == 0);
    CHECK(fs::exists(kept / "a_input.ply"));
    CHECK(fs::exists(kept / "b_input.ply"));
    CHECK(fs::exists(kept / "pcp_many.ckpt"));
    CHECK(fs::exists(kept / "pcp_many.ckpt.prior"));
    const auto read_all = [](const fs::path& f) {
        std::ifstream in(f, std::ios::binary);
        return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    };
    const std::string first_a = read_all(kept / "a_input.ply"), first_b = read_all(kept / "b_input.ply");
    fs::remove(kept / "a_input.ply");
    fs::remove(kept / "b_input.ply");
    const RunResult resumed = run(keep_run + " --resume");
    INFO("stderr: " << resumed.err);
    CHECK(resumed.exit_code == 0);
    CHECK(read_all(kept / "a_input.ply") == first_a);
    CHECK(read_all(kept / "b_input.ply") == first_b);

    // Usage errors before any work: no --output-dir, -o with it, --normals, an ablation.
    const RunResult no_dir = run(bin("pcp_reconstruct") + " " + a + b + quick);
    CHECK(no_dir.exit_code == 2);
    CHECK(no_dir.err.find("--output-dir") != std::string::npos);
    CHECK(run(bin("pcp_reconstruct") + " " + a + b + "-o x.ply --output-dir '" + out.string() + "'" + quick).exit_code == 2);
    CHECK(run(bin("pcp_reconstruct") + " " + a + b + "--normals n.ply --output-dir '" + out.string() + "'" + quick).exit_code == 2);
    CHECK(run(bin("pcp_reconstruct") + " " + a + b + "--ablation no-shift --output-dir '" + out.string() + "'" + quick).exit_code == 2);

    // A missing input: exit 1, one line naming it, nothing written.
    const fs::path out3 = dir / "out3";
    const RunResult missing = run(bin("pcp_reconstruct") + " " + a + "'" + (dir / "missing.xyz").string() + "' --output-dir '" +
                                  out3.string() + "'" + quick);
    INFO("stderr: " << missing.err);
    CHECK(missing.exit_code == 1);
    CHECK(missing.err.find("missing.xyz") != std::string::npos);
    CHECK(std::count(missing.err.begin(), missing.err.end(), '\n') == 1);
    CHECK(!fs::exists(out3 / "a_input.ply"));
}

TEST_CASE("cli: --scene is the scene preset, with another --preset it is a usage error", "[cli]") {
    const fs::path dir = case_dir("scene");
    const RunResult both = run(bin("pcp_reconstruct") + " --scene --preset fast -o '" + (dir / "m.ply").string() + "'");
    CHECK(both.exit_code == 2);
    CHECK(both.err.find("--scene") != std::string::npos);
    const RunResult help = run(bin("pcp_reconstruct") + " --help");
    CHECK(help.exit_code == 0);
}
