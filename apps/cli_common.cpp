// Implementation of the apps' shared command-line plumbing (see cli_common.hpp).
#include "cli_common.hpp"

#include "pcp/core/error.hpp"
#include "pcp/core/files.hpp"
#include "pcp/io/io.hpp"
#include "pcp/cloud/normalize.hpp"
#include "pcp/nn/gemm.hpp"

#include <Eigen/Core>

#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>

#include <omp.h>
#include <sys/resource.h>
#include <unistd.h>

namespace pcp::cli {

namespace {
std::atomic<bool> g_interrupted{false};
extern "C" void on_signal(int) { g_interrupted.store(true); }
}  // namespace

bool interrupted() { return g_interrupted.load(); }

void add_common_options(cxxopts::Options& options) {
    const CommonFlags defaults;
    options.add_options("Common")
        ("h,help", "Print this help")
        ("threads", "Worker threads (0 = all cores)",
         cxxopts::value<int>()->default_value(std::to_string(defaults.threads)))
        ("seed", "Random seed", cxxopts::value<std::uint64_t>()->default_value(std::to_string(defaults.seed)))
        ("q,quiet", "Print nothing but errors")
        ("v,verbose", "Print more detail");
}

bool parse_command_line(cxxopts::Options& options, int argc, char** argv,
                        cxxopts::ParseResult& result, CommonFlags& common) {
    try {
        result = options.parse(argc, argv);
        if (result.count("help")) {
            std::cout << options.help() << std::endl;
            return false;
        }
        common.threads = result["threads"].as<int>();
        common.seed = result["seed"].as<std::uint64_t>();
        common.quiet = result.count("quiet") > 0;
        common.verbose = result.count("verbose") > 0;
    } catch (const cxxopts::exceptions::exception& e) {
        throw UsageError(e.what());
    }
    if (common.threads < 0) throw UsageError("--threads must be >= 0");
    if (common.quiet && common.verbose) throw UsageError("--quiet and --verbose exclude each other");
    if (common.threads > 0) {
        omp_set_num_threads(common.threads);
        Eigen::setNbThreads(common.threads);
    }
    return true;
}

void add_precision_option(cxxopts::Options& options, const std::string& group) {
    options.add_options(group)
        ("precision", "auto | fp32 | bf16: arithmetic of the networks' large matrix products; bf16 (fp32 "
                      "accumulation and weights) needs oneDNN and a CPU with AVX512-BF16 or AMX; auto = bf16 "
                      "where available, else fp32",
         cxxopts::value<std::string>()->default_value("auto"));
}

std::string apply_precision(const cxxopts::ParseResult& args) {
    const std::string want = args["precision"].as<std::string>();
    nn::Precision p = nn::Precision::Fp32;
    try {
        p = nn::parse_precision(want);
    } catch (const pcp::Error& e) {
        throw UsageError(std::string("--precision: ") + e.what());
    }
    nn::set_gemm_precision(p);
    std::string chosen = "fp32";
    if (p == nn::Precision::Bf16)
        chosen = "bf16 (oneDNN)";
    else if (want == "auto")
        chosen = "fp32 (bf16 unavailable: " + nn::bf16_unavailable_reason() + ")";
    // The fp32 products (all of them in fp32; the small ones and the grid's in bf16) run on this
    // back end; say why it is not OpenBLAS where this build has it.
    const nn::GemmBackend backend = nn::gemm_backend();
    chosen += std::string(", gemm ") + nn::gemm_backend_name(backend);
    const std::string declined = nn::blas_default_declined_reason();
    if (backend == nn::GemmBackend::Eigen && !declined.empty()) chosen += " (" + declined + ")";
    return chosen;
}

int run_main(const char* program, const std::function<int()>& body) {
    // Past a file-size limit (ulimit -f) a write fails with EFBIG instead of the process being
    // killed by SIGXFSZ: the writer then reports it, removes its temporary file and exits non-zero.
    std::signal(SIGXFSZ, SIG_IGN);
    try {
        return body();
    } catch (const UsageError& e) {
        std::cerr << program << ": usage error: " << e.what() << " (see --help)" << std::endl;
        return 2;
    } catch (const Cancelled& e) {
        std::cerr << program << ": cancelled: " << e.what() << std::endl;
        return 130;
    } catch (const pcp::Error& e) {
        std::cerr << program << ": error: " << e.what() << std::endl;
        return 1;
    } catch (const std::bad_alloc&) {
        std::cerr << program << ": error: out of memory" << std::endl;
        return 1;
    } catch (const std::exception& e) {
        std::cerr << program << ": error: " << e.what() << std::endl;
        return 1;
    }
}

namespace {
std::atomic<bool> g_progress_line_open{false};  ///< an in-place progress line is on the terminal
}  // namespace

void end_progress_line() {
    if (g_progress_line_open.exchange(false)) std::cerr << std::endl;
}

void Log::info(const std::string& line) const {
    if (flags && flags->quiet) return;
    end_progress_line();
    std::cerr << line << std::endl;
}

void Log::detail(const std::string& line) const {
    if (!flags || !flags->verbose) return;
    end_progress_line();
    std::cerr << line << std::endl;
}

double StageMemory::of(const std::string& stage) const {
    for (const auto& [name, mib] : peak_mib)
        if (name == stage) return mib;
    return -1;
}

void print_stage_table(const Log& log, const std::vector<std::tuple<std::string, double, double>>& rows) {
    std::ostringstream out;
    out << "| stage | seconds | peak MiB |\n|---|---|---|";
    for (const auto& [stage, seconds, mib] : rows) {
        char buf[160];
        if (mib >= 0) std::snprintf(buf, sizeof buf, "\n| %s | %.1f | %.0f |", stage.c_str(), seconds, mib);
        else std::snprintf(buf, sizeof buf, "\n| %s | %.1f | - |", stage.c_str(), seconds);
        out << buf;
    }
    log.info(out.str());
}

void print_parameter_table(const Log& log, const std::vector<std::pair<std::string, std::string>>& rows) {
    std::size_t w = 9;
    for (const auto& r : rows) w = std::max(w, r.first.size());
    std::ostringstream out;
    out << "| " << std::string("Parameter") << std::string(w - 9, ' ') << " | Value\n";
    out << "|" << std::string(w + 2, '-') << "|------\n";
    for (const auto& r : rows) out << "| " << r.first << std::string(w - r.first.size(), ' ') << " | " << r.second << "\n";
    std::string s = out.str();
    s.pop_back();
    log.info(s);
}

std::string format_duration(double seconds) {
    if (seconds < 0 || !(seconds < 1e9)) return "?";
    const long s = static_cast<long>(seconds + 0.5);
    char buf[64];
    if (s >= 3600) std::snprintf(buf, sizeof buf, "%ldh%02ldm", s / 3600, (s % 3600) / 60);
    else if (s >= 60) std::snprintf(buf, sizeof buf, "%ldm%02lds", s / 60, s % 60);
    else std::snprintf(buf, sizeof buf, "%.1fs", seconds);
    return buf;
}

ProgressCallback make_progress_printer(const Log& log, std::int64_t every, std::shared_ptr<StageMemory> memory) {
    std::signal(SIGINT, on_signal);
    std::signal(SIGTERM, on_signal);
    struct State {
        std::string stage;
        std::int64_t last_printed = -1;
        std::chrono::steady_clock::time_point last_drawn{};
    };
    auto state = std::make_shared<State>();
    const bool quiet = log.flags && log.flags->quiet;
    const bool terminal = !quiet && ::isatty(::fileno(stderr)) != 0;
    return [every, state, memory, quiet, terminal](const Progress& p) {
        if (p.stage != state->stage) {
            end_progress_line();
            state->stage = p.stage;
            state->last_printed = -1;
            if (memory) memory->peak_mib.emplace_back(p.stage, peak_rss_mib());
        }
        if (memory && !memory->peak_mib.empty()) memory->peak_mib.back().second = peak_rss_mib();
        const bool last = p.total > 0 && p.step >= p.total;
        const auto now = std::chrono::steady_clock::now();
        const bool due = terminal ? (p.step == 0 || last || now - state->last_drawn >= std::chrono::milliseconds(100))
                                  : (p.step == 0 || last || p.step - state->last_printed >= every);
        if (quiet || !due) return !g_interrupted.load();
        state->last_printed = p.step;
        state->last_drawn = now;
        const double rate = p.elapsed_s > 0 ? static_cast<double>(p.step - p.step_offset) / p.elapsed_s : 0.0;
        std::ostringstream line;
        char buf[160];
        line << p.stage;
        if (p.total > 0) {
            const double fraction = std::clamp(static_cast<double>(p.step) / static_cast<double>(p.total), 0.0, 1.0);
            std::snprintf(buf, sizeof buf, " %3d%%", static_cast<int>(100 * fraction));
            line << buf;
            if (terminal) {
                constexpr int kBar = 20;
                const int filled = static_cast<int>(fraction * kBar + 0.5);
                line << " [" << std::string(static_cast<std::size_t>(filled), '#') << std::string(static_cast<std::size_t>(kBar - filled), ' ') << "]";
            }
            line << " " << p.step << "/" << p.total;
        } else {
            line << " " << p.step;
        }
        if (p.step > p.step_offset && rate > 0) {
            std::snprintf(buf, sizeof buf, " | %.1f it/s", rate);
            line << buf;
            if (p.total > 0) line << (last ? " | done in " + format_duration(p.elapsed_s) : " | ETA " + format_duration(static_cast<double>(p.total - p.step) / rate));
        }
        if (p.has_loss && p.step > 0) {
            std::snprintf(buf, sizeof buf, " | loss %.6g", p.loss);
            line << buf;
        }
        if (terminal) {
            std::cerr << "\r\033[K" << line.str() << std::flush;
            g_progress_line_open = true;
            if (last) end_progress_line();
        } else {
            std::cerr << line.str() << std::endl;
        }
        return !g_interrupted.load();
    };
}

double peak_rss_mib() {
    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);
    return static_cast<double>(usage.ru_maxrss) / 1024.0;  // ru_maxrss is KiB on Linux
}

double available_mib() {
    double avail = -1;
    {
        std::ifstream in("/proc/meminfo");
        std::string key, unit;
        double kib = 0;
        while (in >> key >> kib >> unit)
            if (key == "MemAvailable:") {
                avail = kib / 1024.0;
                break;
            }
    }
    // A container's own limit (cgroup v2), which /proc/meminfo does not show.
    std::ifstream max_in("/sys/fs/cgroup/memory.max"), cur_in("/sys/fs/cgroup/memory.current");
    double max_bytes = 0, cur_bytes = 0;
    if ((max_in >> max_bytes) && (cur_in >> cur_bytes) && max_bytes > cur_bytes) {
        const double cgroup = (max_bytes - cur_bytes) / 1048576.0;
        avail = avail < 0 ? cgroup : std::min(avail, cgroup);
    }
    // PCP_MEMORY_LIMIT_MIB: a lower limit of the user's (and of the tests).
    if (const char* env = std::getenv("PCP_MEMORY_LIMIT_MIB")) {
        char* end = nullptr;
        const double limit = std::strtod(env, &end);
        if (end != env && *end == '\0' && limit > 0) avail = avail < 0 ? limit : std::min(avail, limit);
    }
    return avail;
}

void check_memory_for(const std::string& what, double need_mib, const std::string& advice) {
    const double avail = available_mib();
    if (avail > 0 && need_mib > avail) {
        std::ostringstream msg;
        msg << what << " needs about " << static_cast<long>(std::ceil(need_mib)) << " MiB of memory, " << static_cast<long>(avail)
            << " MiB are available" << (advice.empty() ? "" : "; ") << advice;
        throw pcp::Error(msg.str());
    }
}

PointCloud load_checked_cloud(const std::string& path, Eigen::Index min_points) {
    // Reading holds the whole file and then its values in double: refused up front where that
    // cannot fit, rather than left to the OOM killer.
    std::error_code ec;
    const auto bytes = std::filesystem::file_size(path, ec);
    if (!ec) check_memory_for(path + ": reading this file", 5.0 * static_cast<double>(bytes) / 1048576.0, "");
    PointCloud cloud = read_point_cloud(path);
    check_point_cloud(cloud.points, path, min_points);
    return cloud;
}

std::vector<std::string> collect_inputs(const std::vector<std::string>& args, const std::string& list_file) {
    namespace fs = std::filesystem;
    static const char* const kCloudExtensions[] = {".ply", ".xyz", ".txt", ".pts", ".npy"};
    std::vector<std::string> names = args;
    if (!list_file.empty()) {
        std::ifstream in(list_file);
        PCP_CHECK(in, list_file << ": cannot open the list file");
        const fs::path base = fs::path(list_file).parent_path();
        std::string line;
        while (std::getline(in, line)) {
            line.erase(0, line.find_first_not_of(" \t\r"));
            line.erase(line.find_last_not_of(" \t\r") + 1);
            if (line.empty() || line[0] == '#') continue;
            const fs::path p(line);
            names.push_back(p.is_absolute() ? line : (base / p).string());
        }
    }
    std::vector<std::string> files;
    for (const std::string& name : names) {
        std::error_code ec;
        if (fs::is_directory(name, ec)) {
            std::vector<std::string> found;
            for (const auto& entry : fs::directory_iterator(name)) {
                const std::string ext = file_extension(entry.path().string());
                if (entry.is_regular_file() &&
                    std::find(std::begin(kCloudExtensions), std::end(kCloudExtensions), ext) != std::end(kCloudExtensions))
                    found.push_back(entry.path().string());
            }
            PCP_CHECK(!found.empty(), name << ": the directory holds no point-cloud files (.ply .xyz .txt .pts .npy)");
            std::sort(found.begin(), found.end());
            files.insert(files.end(), found.begin(), found.end());
        } else {
            files.push_back(name);
        }
    }
    return files;
}

double seconds_since(std::chrono::steady_clock::time_point start) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

void add_sampling_options(cxxopts::Options& options, const std::string& group, const SamplingOptions& d) {
    std::ostringstream spreads;
    for (std::size_t i = 0; i < d.spreads.size(); ++i) spreads << (i ? "," : "") << d.spreads[i];
    options.add_options(group)
        ("spreads", "Query spreads in units of sigma_p, comma-separated (query j of a point uses spread j mod count)",
         cxxopts::value<std::string>()->default_value(spreads.str()))
        ("uniform-fraction", "Extra queries drawn uniformly in the grown bounding box, as a fraction of the others (0 = the paper)",
         cxxopts::value<double>()->default_value(std::to_string(d.uniform_fraction)));
}

void apply_sampling_flags(const cxxopts::ParseResult& args, SamplingOptions& sampling) {
    if (args.count("spreads")) {
        std::vector<float> spreads;
        std::istringstream in(args["spreads"].as<std::string>());
        for (std::string item; std::getline(in, item, ',');) {
            char* end = nullptr;
            const float v = std::strtof(item.c_str(), &end);
            if (item.empty() || *end != '\0' || !(v > 0.0f) || !std::isfinite(v))
                throw UsageError("--spreads: '" + item + "' is not a positive number");
            spreads.push_back(v);
        }
        if (spreads.empty()) throw UsageError("--spreads needs at least one value");
        sampling.spreads = spreads;
    }
    if (args.count("uniform-fraction")) {
        const double u = args["uniform-fraction"].as<double>();
        if (!(u >= 0.0 && u <= 10.0)) throw UsageError("--uniform-fraction must be in [0, 10]");
        sampling.uniform_fraction = static_cast<float>(u);
    }
}

}  // namespace pcp::cli
