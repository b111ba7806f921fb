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
    if (p == nn::Precision::Bf16) return "bf16 (oneDNN)";
    if (want == "auto") return "fp32 (bf16 unavailable: " + nn::bf16_unavailable_reason() + ")";
    return "fp32";
}

int run_main(const char* program, const std::function<int()>& body) {
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

void Log::info(const std::string& line) const {
    if (!flags || !flags->quiet) std::cerr << line << std::endl;
}

void Log::detail(const std::string& line) const {
    if (flags && flags->verbose) std::cerr << line << std::endl;
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

ProgressCallback make_progress_printer(const Log& log, std::int64_t every) {
    std::signal(SIGINT, on_signal);
    std::signal(SIGTERM, on_signal);
    struct State {
        std::string stage;
        std::int64_t last_printed = -1;
    };
    auto state = std::make_shared<State>();
    return [log, every, state](const Progress& p) {
        if (p.stage != state->stage) {
            state->stage = p.stage;
            state->last_printed = -1;
        }
        const bool last = p.total > 0 && p.step >= p.total;
        if (p.step == 0 || last || p.step - state->last_printed >= every) {
            state->last_printed = p.step;
            const double rate = p.elapsed_s > 0 ? static_cast<double>(p.step - p.step_offset) / p.elapsed_s : 0.0;
            std::ostringstream line;
            line << p.stage << " " << p.step;
            if (p.total > 0) line << "/" << p.total;
            char buf[96];
            std::snprintf(buf, sizeof buf, " | loss %.6g | %.1f it/s", p.loss, rate);
            line << buf;
            if (p.total > 0 && rate > 0)
                line << " | ETA " << format_duration(static_cast<double>(p.total - p.step) / rate);
            log.info(line.str());
        }
        return !g_interrupted.load();
    };
}

double peak_rss_mib() {
    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);
    return static_cast<double>(usage.ru_maxrss) / 1024.0;  // ru_maxrss is KiB on Linux
}

PointCloud load_checked_cloud(const std::string& path, Eigen::Index min_points) {
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
