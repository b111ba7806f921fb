// The back ends behind pcp::nn::gemm (pcp/nn/gemm.hpp), as src/nn/gemm.cpp (the dispatcher) sees
// them: the raw operand block GemmArgs that the dispatcher builds after its shape checks, the
// OpenMP split of C into slabs that the Eigen and BLAS back ends share, and one entry point per
// back end. Each back end lives in its own file and is compiled only when its library is found:
//   src/nn/gemm_eigen.cpp  always (the portable path)
//   src/nn/gemm_blas.cpp   when CMake finds OpenBLAS (PCP_BLAS); the dispatcher then has PCP_WITH_BLAS
//   src/nn/gemm_dnnl.cpp   when CMake finds oneDNN (PCP_DNNL); the dispatcher then has PCP_WITH_DNNL
// Only the dispatcher knows which of them exist; a back-end file never tests PCP_WITH_*.
#pragma once

#include "pcp/nn/gemm.hpp"

#include <Eigen/Core>
#include <omp.h>

#include <algorithm>
#include <exception>
#include <string>

namespace pcp::nn::gemm_detail {

using Eigen::Index;

// Raw operands of C = alpha op(A) op(B) + beta C, all column-major storage. op(A) is read as a
// row-major matrix when ta == Yes (A^T in place), likewise op(B).
template <class S>
struct GemmArgs {
    Index m, n, k;
    const S* a;
    Index lda;
    const S* b;
    Index ldb;
    S* c;
    Index ldc;
    S alpha, beta;
    Trans ta, tb;
};

// C := beta C on the m x n block at c (column-major, stride ldc). beta == 0 writes zeros (NaN in
// the old contents is not propagated).
template <class S>
void scale_block(S* c, Index ldc, Index m, Index n, S beta) {
    if (beta == S(1)) return;
    for (Index j = 0; j < n; ++j) {
        S* col = c + j * ldc;
        if (beta == S(0))
            std::fill(col, col + m, S(0));
        else
            for (Index i = 0; i < m; ++i) col[i] *= beta;
    }
}

// The slab [lo, hi) of C's columns (by_cols) or rows, as its own product.
template <class S>
GemmArgs<S> slab(const GemmArgs<S>& g, bool by_cols, Index lo, Index hi) {
    GemmArgs<S> s = g;
    if (by_cols) {  // op(B)'s columns lo..hi: B's columns (No) or rows (Yes)
        s.n = hi - lo;
        s.b = g.tb == Trans::No ? g.b + lo * g.ldb : g.b + lo;
        s.c = g.c + lo * g.ldc;
    } else {  // op(A)'s rows lo..hi: A's rows (No) or columns (Yes)
        s.m = hi - lo;
        s.a = g.ta == Trans::No ? g.a + lo : g.a + lo * g.lda;
        s.c = g.c + lo;
    }
    return s;
}

// Below this many multiply-adds per thread a split does not pay for the threads' wake-up (the
// same order as Eigen's own minimum task size).
constexpr double kMinMaddsPerThread = 65536.0;

// Runs `sequential` (one thread's product, any back end) on g: directly, or on one slab of C per
// thread in an OpenMP region of min(Eigen::nbThreads(), what the size supports) threads. Inside an
// enclosing parallel region it runs on the calling thread alone.
template <class S, class Sequential>
void run_split(const GemmArgs<S>& g, Sequential sequential) {
    int threads = omp_in_parallel() ? 1 : std::max(1, Eigen::nbThreads());
    const bool by_cols = g.n >= g.m;
    const Index dim = by_cols ? g.n : g.m;
    // Slab widths in multiples of the micro-kernels' panels (8 columns, 32 rows cover every
    // nr/mr of the float and double AVX2 kernels) so that no slab ends in a ragged panel.
    const Index grain = by_cols ? 8 : 32;
    const double madds = double(g.m) * double(g.n) * double(g.k);
    threads = int(std::min<double>({double(threads), double(std::max<Index>(1, dim / grain)),
                                    std::max(1.0, madds / kMinMaddsPerThread)}));
    if (threads <= 1) {
        sequential(g);
        return;
    }
    std::exception_ptr error;
#pragma omp parallel num_threads(threads)
    {
        const Index nt = omp_get_num_threads(), t = omp_get_thread_num();
        const Index panels = (dim + grain - 1) / grain;
        const Index lo = std::min(dim, panels * t / nt * grain);
        const Index hi = std::min(dim, panels * (t + 1) / nt * grain);
        try {
            if (hi > lo) sequential(slab(g, by_cols, lo, hi));
        } catch (...) {
#pragma omp critical(pcp_gemm_error)
            if (!error) error = std::current_exception();
        }
    }
    if (error) std::rethrow_exception(error);
}

// ---- Eigen (src/nn/gemm_eigen.cpp; float and double) ----

/// The whole product of g on the Eigen back end, split over threads by run_split.
template <class S>
void gemm_eigen(const GemmArgs<S>& g);

/// One thread's Eigen product on the whole of g (C := beta C, then the packed kernel); the BLAS
/// back end falls back to it for the shapes where OpenBLAS would allocate.
template <class S>
void eigen_sequential(const GemmArgs<S>& g);

// ---- OpenBLAS (src/nn/gemm_blas.cpp; float and double) ----

/// The whole product of g on the BLAS back end (single-threaded cblas_?gemm per slab of
/// run_split). Throws pcp::Error when a size exceeds BLAS's 32-bit integers.
template <class S>
void gemm_blas(const GemmArgs<S>& g);

/// The name of the kernel OpenBLAS chose for this CPU (openblas_get_corename()).
std::string blas_core_name();

// ---- oneDNN bf16 (src/nn/gemm_dnnl.cpp; float only) ----

/// C = alpha op(A) op(B) + beta C with both operands rounded to bf16 and fp32 accumulation.
/// Throws pcp::Error when oneDNN fails.
void gemm_dnnl_bf16(const GemmArgs<float>& g);

/// Whether oneDNN detects native bf16 units on this CPU (AVX512-BF16 or AMX).
bool dnnl_cpu_has_bf16_units();

/// How many oneDNN matmul primitives gemm_dnnl_bf16 has created (all threads).
long dnnl_primitives_created();

}  // namespace pcp::nn::gemm_detail
