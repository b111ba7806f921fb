// A guard that restores the process-wide GEMM settings a test changes (threads, back end,
// precision): shared by the gemm, bf16, step and realdata tests. Which back ends a test needs is
// said by its tags ([blas], [bf16]), not by looping over the available ones: a back end that is
// absent then shows as Skipped (tests/support/main.cpp) instead of passing untested.
#pragma once

#include "pcp/nn/gemm.hpp"

#include <Eigen/Core>

namespace pcp::test {

struct RestoreGemmSettings {
    int threads = Eigen::nbThreads();
    nn::GemmBackend backend = nn::gemm_backend();
    nn::Precision precision = nn::gemm_precision();
    ~RestoreGemmSettings() {
        Eigen::setNbThreads(threads);
        nn::set_gemm_backend(backend);
        nn::set_gemm_precision(precision);
    }
};

}  // namespace pcp::test
