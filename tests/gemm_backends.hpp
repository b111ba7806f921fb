// The GEMM back ends this build has, and a guard that restores the process-wide GEMM settings a
// test changes: shared by the gemm and step tests, which run every back end.
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
    ~RestoreGemmSettings() {
        Eigen::setNbThreads(threads);
        nn::set_gemm_backend(backend);
    }
};

}  // namespace pcp::test
