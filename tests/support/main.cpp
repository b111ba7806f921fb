// The Catch2 v2 main shared by every test binary (CATCH_CONFIG_RUNNER). On top of Catch's own:
//  - Optional back ends as tags. A test case tagged [bf16] needs Precision::Bf16 (this build has
//    oneDNN and the CPU has AVX512-BF16 or AMX), one tagged [blas] the BLAS back end; its body
//    checks for real and never returns early. When every test case a run selects needs something
//    missing here (CTest runs one test case per process), the binary prints one line
//    "SKIPPED: <reason>" and exits 77, which CTest (SKIP_RETURN_CODE 77) reports as Skipped. A run
//    without a test spec leaves such test cases out and says so on stderr; a spec that mixes them
//    with runnable test cases runs them all (they then fail, naming what is missing).
//  - Catch's own exit code is the number of failed assertions, so 77 would read as a skip: it
//    becomes 78.
//  - --pcp-report-backends prints which GEMM back ends and precisions this build and CPU run, one
//    line (scripts/test.sh and the CTest test gemm_backends_report show it), and exits 0.
#define CATCH_CONFIG_RUNNER
#include <catch2/catch.hpp>

#include "pcp/nn/gemm.hpp"

#include <algorithm>
#include <cstring>
#include <iostream>
#include <string>
#include <vector>

namespace {

constexpr int kSkipExitCode = 77;

// A tag whose test cases need a back end this build or CPU may lack; reason is "" when present.
struct Requirement {
    std::string tag;  // lower case, as Catch's lcaseTags
    std::string reason;
};

std::vector<Requirement> requirements() {
    using namespace pcp::nn;
    const std::string no_blas = gemm_backend_available(GemmBackend::Blas)
                                    ? ""
                                    : "this build of libpcp has no BLAS back end (OpenBLAS was not found "
                                      "at configure time, or PCP_BLAS=OFF)";
    return {{"bf16", bf16_unavailable_reason()}, {"blas", no_blas}};
}

// What the test case needs and lacks here, joined with "; " ("" when it can run).
std::string missing_for(const Catch::TestCase& test, const std::vector<Requirement>& reqs) {
    std::string missing;
    const std::vector<std::string>& tags = test.getTestCaseInfo().lcaseTags;
    for (const Requirement& r : reqs) {
        if (r.reason.empty() || std::find(tags.begin(), tags.end(), r.tag) == tags.end()) continue;
        missing += (missing.empty() ? "" : "; ") + ("[" + r.tag + "] " + r.reason);
    }
    return missing;
}

void report_backends(std::ostream& out) {
    using namespace pcp::nn;
    out << "pcp tests: GEMM back ends built: eigen";
    if (gemm_backend_available(GemmBackend::Blas)) out << ", blas";
    out << "; precisions: fp32";
    if (bf16_available())
        out << ", bf16";
    else
        out << " (bf16 unavailable: " << bf16_unavailable_reason() << ")";
    out << "\n";
}

}  // namespace

int main(int argc, char* argv[]) {
    for (int i = 1; i < argc; ++i)
        if (std::strcmp(argv[i], "--pcp-report-backends") == 0) {
            report_backends(std::cout);
            return 0;
        }
    Catch::Session session;
    const int parsed = session.applyCommandLine(argc, argv);
    if (parsed != 0) return parsed;
    const Catch::ConfigData& data = session.configData();
    const bool runs_tests = !(data.showHelp || data.listTests || data.listTestNamesOnly || data.listTags ||
                              data.listReporters);
    if (runs_tests) {
        const std::vector<Requirement> reqs = requirements();
        const Catch::Config& config = session.config();
        const std::vector<Catch::TestCase> selected =
            Catch::filterTests(Catch::getAllTestCasesSorted(config), config.testSpec(), config);
        std::string first_missing;
        std::size_t lacking = 0;
        for (const Catch::TestCase& test : selected) {
            const std::string missing = missing_for(test, reqs);
            if (missing.empty()) continue;
            if (first_missing.empty()) first_missing = missing;
            ++lacking;
        }
        if (lacking > 0 && lacking == selected.size()) {
            std::cout << "SKIPPED: " << first_missing << "\n";
            return kSkipExitCode;
        }
        if (lacking > 0 && config.hasTestFilters())
            std::cerr << "pcp tests: " << lacking << " of the selected test cases will fail here: " << first_missing
                      << " (add ~[bf16] or ~[blas] to the test spec to leave them out)\n";
        if (lacking > 0 && !config.hasTestFilters()) {
            Catch::ConfigData narrowed = data;
            std::string exclude, reasons;
            for (const Requirement& r : reqs)
                if (!r.reason.empty()) {
                    exclude += "~[" + r.tag + "]";
                    reasons += (reasons.empty() ? "" : "; ") + ("[" + r.tag + "] " + r.reason);
                }
            narrowed.testsOrTags = {exclude};
            session.useConfigData(narrowed);
            std::cerr << "pcp tests: leaving out " << lacking << " test case(s): " << reasons << "\n";
        }
    }
    const int result = session.run();
    return result == kSkipExitCode ? kSkipExitCode + 1 : result;
}
