// What the three apps share: the common flags (--threads, --seed, --quiet, --verbose), the
// error-to-exit-code wrapper around main, the start-up parameter table, a progress printer with
// rate and ETA that also turns SIGINT/SIGTERM into a clean cancel, and peak-memory reporting.
// Exit codes: 0 success, 1 runtime error (bad input, failed run), 2 usage error, 130 cancelled.
#pragma once

#include "pcp/core/progress.hpp"
#include "pcp/cloud/sampling.hpp"
#include "pcp/core/types.hpp"

#include <cxxopts.hpp>

#include <chrono>
#include <cstdint>
#include <functional>
#include <stdexcept>
#include <memory>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

namespace pcp::cli {

/// Thrown for a bad command line; main exits with code 2.
class UsageError : public std::runtime_error {
public:
    explicit UsageError(const std::string& what) : std::runtime_error(what) {}
};

/// Thrown when the user interrupted the run (after a checkpoint was written); exit code 130.
class Cancelled : public std::runtime_error {
public:
    explicit Cancelled(const std::string& what) : std::runtime_error(what) {}
};

struct CommonFlags {
    int threads = 0;            ///< 0 = all cores
    std::uint64_t seed = 1;
    bool quiet = false;
    bool verbose = false;
};

/// Adds --help, --threads, --seed, --quiet, --verbose to `options`.
void add_common_options(cxxopts::Options& options);

/// Parses argv; prints help and returns false for --help; throws UsageError on a bad command line.
/// Applies the thread count to OpenMP and Eigen.
bool parse_command_line(cxxopts::Options& options, int argc, char** argv,
                        cxxopts::ParseResult& result, CommonFlags& common);

/// Adds --precision auto|fp32|bf16 (the arithmetic of the networks' large products) to `group`.
void add_precision_option(cxxopts::Options& options, const std::string& group);

/// Applies --precision to nn::set_gemm_precision; throws UsageError for an unknown value or for
/// bf16 where it is not available. Returns what was chosen, for the parameter table and the
/// summary: "bf16 (oneDNN)" or "fp32", with the reason when auto fell back to fp32, then the GEMM
/// back end (", gemm blas" or ", gemm eigen", with the reason when OpenBLAS was declined).
std::string apply_precision(const cxxopts::ParseResult& args);

/// Runs `body`, mapping exceptions to one line on stderr ("prog: error: ...") and an exit code.
int run_main(const char* program, const std::function<int()>& body);

/// Logging to stderr that honours --quiet / --verbose.
struct Log {
    const CommonFlags* flags = nullptr;
    void info(const std::string& line) const;
    void detail(const std::string& line) const;  ///< only with --verbose
};

/// Prints a "| Parameter | Value |" table to stderr (not with --quiet).
void print_parameter_table(const Log& log, const std::vector<std::pair<std::string, std::string>>& rows);

/// Per stage, the peak resident memory (MiB) seen at its last progress report.
struct StageMemory {
    std::vector<std::pair<std::string, double>> peak_mib;  ///< in the order the stages began
    double of(const std::string& stage) const;             ///< -1 for a stage never reported
};

/// A ProgressCallback that shows "stage percent [bar] step/total | it/s | ETA [| loss]" and returns
/// false once SIGINT or SIGTERM was received (installing the handlers on construction). On a
/// terminal (stderr is a tty) the line is redrawn in place at most 10 times a second and ends when
/// its stage does; otherwise one plain line every `every` steps and at the end of each stage. The
/// loss is shown only for stages that have one. With `memory`, records each stage's peak memory.
ProgressCallback make_progress_printer(const Log& log, std::int64_t every, std::shared_ptr<StageMemory> memory = nullptr);

/// Ends an open in-place progress line (a newline), so that the next message starts a line.
void end_progress_line();

/// Prints "| stage | seconds | peak MiB |" rows to stderr (not with --quiet); a negative peak
/// prints "-".
void print_stage_table(const Log& log, const std::vector<std::tuple<std::string, double, double>>& rows);

/// True once SIGINT/SIGTERM arrived after make_progress_printer installed its handlers.
bool interrupted();

/// Peak resident memory of this process in MiB.
double peak_rss_mib();
/// The memory a run may use, in MiB: MemAvailable of /proc/meminfo, lowered to the cgroup's
/// (memory.max - memory.current) in a container and to PCP_MEMORY_LIMIT_MIB when set; -1 where
/// none is known.
double available_mib();
/// Throws pcp::Error "<what> needs about N MiB of memory, M MiB are available; <advice>" when
/// need_mib exceeds what is available (nothing where that is unknown).
void check_memory_for(const std::string& what, double need_mib, const std::string& advice);

/// "1m23s"-style duration.
std::string format_duration(double seconds);

/// Reads a point cloud and checks it (finite, at least `min_points`, not degenerate); errors name
/// the file.
PointCloud load_checked_cloud(const std::string& path, Eigen::Index min_points);

/// The input files named on the command line: files as given, directories expanded to their
/// point-cloud files (sorted), plus the lines of `list_file` (if not empty; '#' comments allowed).
std::vector<std::string> collect_inputs(const std::vector<std::string>& args, const std::string& list_file);

/// Seconds since `start`.
double seconds_since(std::chrono::steady_clock::time_point start);

/// Applies --spreads (comma-separated positive factors) and --uniform-fraction, when given, to
/// `sampling`; throws UsageError for bad values.
void apply_sampling_flags(const cxxopts::ParseResult& args, SamplingOptions& sampling);

/// The two sampling options for add_options (their defaults taken from `d`).
void add_sampling_options(cxxopts::Options& options, const std::string& group, const SamplingOptions& d);

}  // namespace pcp::cli
