// The OpenBLAS back end of pcp::nn::gemm (declared in src/nn/gemm_backends.hpp), compiled only
// when CMake finds OpenBLAS (PCP_BLAS=AUTO|ON): the only file of libpcp that includes cblas.h. It
// runs cblas_?gemm single-threaded on the slabs of run_split (the same split and thread count as
// the Eigen back end); OpenBLAS packs into its own persistent pool.
#include "gemm_backends.hpp"

#include "pcp/core/error.hpp"

#include <omp.h>

#include <cblas.h>

#include <limits>
#include <mutex>
#include <string>

namespace pcp::nn::gemm_detail {

namespace {

inline CBLAS_TRANSPOSE cblas_trans(Trans t) { return t == Trans::No ? CblasNoTrans : CblasTrans; }

inline void blas_call(const GemmArgs<float>& g) {
    cblas_sgemm(CblasColMajor, cblas_trans(g.ta), cblas_trans(g.tb), blasint(g.m), blasint(g.n),
                blasint(g.k), g.alpha, g.a, blasint(g.lda), g.b, blasint(g.ldb), g.beta, g.c,
                blasint(g.ldc));
}

inline void blas_call(const GemmArgs<double>& g) {
    cblas_dgemm(CblasColMajor, cblas_trans(g.ta), cblas_trans(g.tb), blasint(g.m), blasint(g.n),
                blasint(g.k), g.alpha, g.a, blasint(g.lda), g.b, blasint(g.ldb), g.beta, g.c,
                blasint(g.ldc));
}

// OpenBLAS always runs single-threaded under us; the threads are run_split's (the same slabs and
// thread count as the Eigen back end). Why not OpenBLAS's own threading: its threaded level-3
// driver mallocs its job table on every call (measured: 40-49 mallocs per training step with 2
// threads, none with 1). OpenBLAS runs on one thread inside an active parallel region; outside one
// the OpenMP build takes its count from omp_get_max_threads() at the call, so that ICV is 1 for
// the call and restored after it; openblas_set_num_threads(1), once, covers the pthread build.
template <class S>
void blas_sequential(const GemmArgs<S>& g) {
    // OpenBLAS 0.3.21 on AVX-512 CPUs (its SkylakeX kernels, measured on Zen 4) mallocs on every
    // call of the plain (No, No) product for many m that are not multiples of 16 (1-8, 17, 65,
    // 129, 257, ...; k >= 32), never for the transposed forms; the Eigen kernel, which allocates
    // nothing after its first call, takes those (in the method: the 1-row output layers).
    if (g.ta == Trans::No && g.tb == Trans::No && g.m % 16 != 0) {
        eigen_sequential(g);
        return;
    }
    if (omp_in_parallel()) {
        blas_call(g);
        return;
    }
    static std::once_flag once;
    const int saved = omp_get_max_threads();
    std::call_once(once, [] { openblas_set_num_threads(1); });
    if (omp_get_max_threads() != 1) omp_set_num_threads(1);
    blas_call(g);
    if (omp_get_max_threads() != saved) omp_set_num_threads(saved);
}

}  // namespace

template <class S>
void gemm_blas(const GemmArgs<S>& g) {
    constexpr Index kMax = std::numeric_limits<blasint>::max();
    PCP_CHECK(g.m <= kMax && g.n <= kMax && g.k <= kMax && g.lda <= kMax && g.ldb <= kMax &&
                  g.ldc <= kMax,
              "nn::gemm: " << g.m << "x" << g.n << "x" << g.k
                           << " exceeds the BLAS back end's 32-bit sizes; use the Eigen back end");
    run_split(g, [](const GemmArgs<S>& s) { blas_sequential(s); });
}

template void gemm_blas<float>(const GemmArgs<float>&);
template void gemm_blas<double>(const GemmArgs<double>&);

std::string blas_core_name() {
    const char* name = openblas_get_corename();
    return name != nullptr ? std::string(name) : std::string();
}

}  // namespace pcp::nn::gemm_detail
