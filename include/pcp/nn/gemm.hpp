// The one place where the neural core multiplies matrices. Every layer, forward or backward,
// calls pcp::nn::gemm; nothing else in src/nn/ writes `A * B`. Two back ends live behind it, in
// src/nn/gemm.cpp only:
//   - Eigen (always built, the portable path): Eigen 3.4's packed GEMM kernel driven by our own
//     code, with packing buffers that persist per thread (grown once to the largest shape, then
//     reused), so that a training step allocates nothing; multi-threaded over OpenMP by splitting
//     C into one slab per thread when Eigen::nbThreads() > 1.
//   - Blas (built when CMake finds OpenBLAS, option PCP_BLAS=AUTO|ON|OFF): cblas_sgemm/dgemm,
//     single-threaded OpenBLAS on each thread's slab of C under the same OpenMP split and thread
//     count (OpenBLAS's own threaded driver mallocs on every call); OpenBLAS's packing buffers
//     come from its own persistent pool. 1.3-1.4x Eigen's rate on AVX2 (docs/BENCHMARKS.md).
// The back end is a process-wide setting: set_gemm_backend(), or the environment variable
// PCP_GEMM=eigen|blas read at the first call; by default Blas when built, else Eigen. Neither
// allocates on the heap after its first call at the largest shape (per thread).
// Inside an OpenMP parallel region either back end runs single-threaded in the calling thread.
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
/// k == 0 is allowed (C = beta * C). Uses the back end chosen by set_gemm_backend().
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

/// The GEMM back ends (see the top of this file).
enum class GemmBackend { Eigen, Blas };

/// Whether this build of libpcp contains the back end (Eigen: always; Blas: PCP_BLAS found it).
bool gemm_backend_available(GemmBackend backend);

/// Selects the back end of every later gemm call in the process. Throws pcp::Error when the back
/// end is not available in this build. Not to be called while another thread runs gemm.
void set_gemm_backend(GemmBackend backend);

/// The back end gemm uses now (resolves the default and PCP_GEMM on first use).
GemmBackend gemm_backend();

/// "eigen" or "blas".
const char* gemm_backend_name(GemmBackend backend);

/// Parses "eigen" or "blas" (as for PCP_GEMM or a --gemm option); throws pcp::Error otherwise.
GemmBackend parse_gemm_backend(const char* name);

}  // namespace pcp::nn
