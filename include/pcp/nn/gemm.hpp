// The one place where the neural core multiplies matrices. Every layer, forward or backward,
// calls pcp::nn::gemm; nothing else in src/nn/ writes `A * B`. Two back ends live behind it, each
// in its own file behind the dispatcher src/nn/gemm.cpp (src/nn/gemm_eigen.cpp, src/nn/gemm_blas.cpp;
// the bf16 products below in src/nn/gemm_dnnl.cpp):
//   - Eigen (always built, the portable path): Eigen 3.4's packed GEMM kernel driven by our own
//     code, with packing buffers that persist per thread (grown once to the largest shape, then
//     reused), so that a training step allocates nothing; multi-threaded over OpenMP by splitting
//     C into one slab per thread when Eigen::nbThreads() > 1.
//   - Blas (built when CMake finds OpenBLAS, option PCP_BLAS=AUTO|ON|OFF): cblas_sgemm/dgemm,
//     single-threaded OpenBLAS on each thread's slab of C under the same OpenMP split and thread
//     count (OpenBLAS's own threaded driver mallocs on every call); OpenBLAS's packing buffers
//     come from its own persistent pool. 1.3-1.4x Eigen's rate on AVX2 (docs/NOTEBOOK.md,
//     "Neural core").
// The back end is a process-wide setting: set_gemm_backend(), or the environment variable
// PCP_GEMM=eigen|blas read at the first call; by default Blas when built and its kernel suits the
// CPU (blas_default_declined_reason()), else Eigen. Neither
// allocates on the heap after its first call at the largest shape (per thread).
// Inside an OpenMP parallel region either back end runs single-threaded in the calling thread.
//
// Precision (issue 7) is a second, independent process-wide setting. Fp32 (the default): every
// product as above. Bf16 (built when CMake finds oneDNN, option PCP_DNNL=AUTO|ON|OFF; usable where
// the CPU has AVX512-BF16 or AMX): the large float products (m, n and k all >= kBf16MinDim) round
// both operands to bf16 and run oneDNN's bf16 matmul with fp32 accumulation and fp32 output, C and
// the weights the caller owns stay fp32 (fp32 master weights and Adam state). The small products
// (the depth-3 input layer, the 1-row output layer) and every double product keep the fp32/fp64
// path, so the finite-difference gradient checks in double are unaffected.
#pragma once

#include "pcp/nn/common.hpp"

#include <string>

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

/// Whether a BLAS kernel named `core` (OpenBLAS's openblas_get_corename(), compared without case)
/// uses the vector units of a CPU that has (or lacks) AVX2 and FMA. On such a CPU only OpenBLAS's
/// AVX2-class kernels do (Haswell, Zen, SkylakeX, Cooperlake, SapphireRapids); on a CPU model it
/// does not know, OpenBLAS falls back to its SSE3 kernel "Prescott", measured 4-6 x slower than the
/// Eigen back end (an Emerald Rapids Xeon with Debian 12's OpenBLAS 0.3.21). Without AVX2 and FMA
/// any kernel is taken to suit.
bool blas_core_suits_cpu(const std::string& core, bool cpu_has_avx2_fma);

/// The name of the kernel OpenBLAS runs on this CPU (openblas_get_corename()), "" in a build
/// without the BLAS back end.
std::string blas_core_name();

/// Why the default back end is Eigen although this build has the BLAS back end (its kernel does not
/// suit this CPU, see blas_core_suits_cpu), or "" when it does not apply. PCP_GEMM=blas and
/// set_gemm_backend() still select BLAS.
std::string blas_default_declined_reason();

/// Parses "eigen" or "blas" (as for PCP_GEMM or a --gemm option); throws pcp::Error otherwise.
GemmBackend parse_gemm_backend(const char* name);

/// Arithmetic of the large float products (see the top of this file).
enum class Precision { Fp32, Bf16 };

/// Under Precision::Bf16 a float product runs in bf16 only when m, n and k are all at least this.
constexpr Eigen::Index kBf16MinDim = 32;

/// Whether Precision::Bf16 can be selected: this build has the oneDNN back end and the CPU has
/// native bf16 units (AVX512-BF16 or AMX, as oneDNN detects them).
bool bf16_available();

/// Why bf16_available() is false ("" when it is true), for messages.
std::string bf16_unavailable_reason();

/// Selects the precision of every later float gemm call in the process. Throws pcp::Error for
/// Bf16 when !bf16_available(). Not to be called while another thread runs gemm.
void set_gemm_precision(Precision precision);

/// The precision gemm uses now: Fp32 unless set_gemm_precision or the environment variable
/// PCP_PRECISION=auto|fp32|bf16 (read at the first call) chose otherwise.
Precision gemm_precision();

/// How many oneDNN matmul primitives the bf16 path has created in this process (all threads).
/// Each thread creates one per product shape on its first use and then reuses it; a step with
/// fixed shapes creates none after its first call (the tests check this). Note that oneDNN's
/// execute itself allocates a few small blocks per product (its execution context, about 8
/// measured with oneDNN 2.6), so the bf16 path is not allocation-free like the fp32 path.
long bf16_primitives_created();

/// "fp32" or "bf16".
const char* precision_name(Precision precision);

/// Parses "fp32", "bf16" or "auto" (bf16 where bf16_available(), else fp32), as for --precision or
/// PCP_PRECISION. Throws pcp::Error for any other name and for "bf16" when !bf16_available().
Precision parse_precision(const std::string& name);

}  // namespace pcp::nn
