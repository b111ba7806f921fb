// The GEMM back ends this build has, and a guard that restores the process-wide GEMM settings a
// test changes (threads, back end, precision): shared by the gemm and step tests, which run every
// back end.
#pragma once

#include "pcp/nn/gemm.hpp"

#include <Eigen/Core>

#include <vector>

namespace pcp::test {

inline std::vector<nn::GemmBackend> gemm_backends() {
    std::vector<nn::GemmBackend> b{nn::GemmBackend::Eigen};
    if (nn::gemm_backend_available(nn::GemmBackend::Blas)) b.push_back(nn::GemmBackend::Blas);
    return b;
}

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
