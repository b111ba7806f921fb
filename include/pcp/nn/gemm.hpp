// The one place where the neural core multiplies matrices. Every layer, forward or backward,
// calls pcp::nn::gemm; nothing else in src/nn/ writes `A * B`. The portable back end is Eigen's
// own GEMM (multi-threaded through OpenMP when Eigen::setNbThreads > 1); a BLAS or oneDNN back
// end (e.g. bf16 on CPUs that have it) can be added in src/nn/gemm.cpp without touching a layer.
#pragma once

#include "pcp/nn/common.hpp"

namespace pcp::nn {

/// Whether an operand is used as stored (No) or transposed (Yes).
enum class Trans { No, Yes };

/// C = alpha * op(A) * op(B) + beta * C, with op(X) = X or X^T.
///
/// @param[in,out] C  m x n, column-major block (any outer stride). With beta == 0 its previous
///                   contents are ignored (may be uninitialised, NaN is not propagated).
/// @param[in]     A  m x k if ta == No, k x m if ta == Yes.
/// @param[in]     B  k x n if tb == No, n x k if tb == Yes.
/// Throws pcp::Error when the shapes do not agree. C must not alias A or B.
/// k == 0 is allowed (C = beta * C).
template <class S>
void gemm(MatRef<S> C, const CMatRef<S>& A, const CMatRef<S>& B, S alpha, S beta,
          Trans ta = Trans::No, Trans tb = Trans::No);

/// The plain reference: the same contract computed with three loops in double accumulation.
/// Used by the tests to check the fast path; never used by the layers.
template <class S>
void gemm_reference(MatRef<S> C, const CMatRef<S>& A, const CMatRef<S>& B, S alpha, S beta,
                    Trans ta = Trans::No, Trans tb = Trans::No);

/// FLOPs of one gemm call (2 m n k), for the benchmarks' accounting.
inline double gemm_flops(double m, double n, double k) { return 2.0 * m * n * k; }

}  // namespace pcp::nn
