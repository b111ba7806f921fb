// The dispatcher of pcp::nn::gemm (pcp/nn/gemm.hpp): the process-wide settings (back end,
// precision) and their defaults from PCP_GEMM / PCP_PRECISION, the argument checks, the routing of
// each product to a back end, and the three-loop reference the tests use. The back ends themselves
// live in one file each (src/nn/gemm_eigen.cpp always; src/nn/gemm_blas.cpp and
// src/nn/gemm_dnnl.cpp only when CMake finds OpenBLAS or oneDNN, see src/nn/gemm_backends.hpp).
// CMake tells this file which of them are compiled in (PCP_WITH_BLAS, PCP_WITH_DNNL on this one
// source file); the entry points of an absent back end are only named in discarded `if constexpr`
// branches, so they need no definition.
#include "pcp/nn/gemm.hpp"

#include "gemm_backends.hpp"
#include "pcp/core/error.hpp"

#include <Eigen/Core>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cstdlib>
#include <cstring>
#include <string>
#include <type_traits>

namespace pcp::nn {

namespace {

using Eigen::Index;
using gemm_detail::GemmArgs;

// ------------------------------------------------------------------------------------------------
// Back-end selection
// ------------------------------------------------------------------------------------------------

// Which back ends this build compiled in (src/nn/gemm_blas.cpp, src/nn/gemm_dnnl.cpp): CMake sets
// these defines on this file when it adds those files to the library.
#if defined(PCP_WITH_BLAS)
constexpr bool kHaveBlas = true;
#else
constexpr bool kHaveBlas = false;
#endif
#if defined(PCP_WITH_DNNL)
constexpr bool kHaveDnnl = true;
#else
constexpr bool kHaveDnnl = false;
#endif

constexpr int kUnresolved = -1;
std::atomic<int> g_backend{kUnresolved};
std::atomic<int> g_precision{kUnresolved};

Precision default_precision() {
    const char* env = std::getenv("PCP_PRECISION");
    if (env != nullptr && *env != '\0') {
        try {
            return parse_precision(env);
        } catch (const Error& e) {
            PCP_CHECK(false, "PCP_PRECISION=" << env << ": " << e.what());
        }
    }
    return Precision::Fp32;
}

GemmBackend default_backend() {
    const char* env = std::getenv("PCP_GEMM");
    if (env != nullptr && *env != '\0') {
        const GemmBackend b = parse_gemm_backend(env);
        PCP_CHECK(gemm_backend_available(b),
                  "PCP_GEMM=" << env << ": this build of libpcp has no BLAS back end (configure "
                                        "with -DPCP_BLAS=ON and OpenBLAS installed), or unset PCP_GEMM");
        return b;
    }
    return kHaveBlas && blas_default_declined_reason().empty() ? GemmBackend::Blas : GemmBackend::Eigen;
}

bool cpu_has_avx2_fma() {
#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__))
    return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
#else
    return false;
#endif
}

template <class S>
void check_shapes(const char* who, const MatRef<S>& C, const CMatRef<S>& A, const CMatRef<S>& B,
                  Trans ta, Trans tb) {
    const Index m = ta == Trans::No ? A.rows() : A.cols();
    const Index ka = ta == Trans::No ? A.cols() : A.rows();
    const Index kb = tb == Trans::No ? B.rows() : B.cols();
    const Index n = tb == Trans::No ? B.cols() : B.rows();
    PCP_CHECK(m == C.rows() && n == C.cols() && ka == kb,
              who << ": shape mismatch: C is " << C.rows() << "x" << C.cols() << ", op(A) is " << m
                  << "x" << ka << ", op(B) is " << kb << "x" << n);
}

// A stride BLAS accepts (>= rows, >= 1) also for a single-column operand.
template <class M>
Index leading_dim(const M& X) {
    return std::max<Index>({X.outerStride(), X.rows(), Index(1)});
}

}  // namespace

bool gemm_backend_available(GemmBackend backend) {
    return backend == GemmBackend::Eigen || kHaveBlas;
}

void set_gemm_backend(GemmBackend backend) {
    PCP_CHECK(gemm_backend_available(backend),
              "nn::set_gemm_backend: this build of libpcp has no BLAS back end (configure with "
              "-DPCP_BLAS=ON and OpenBLAS installed)");
    g_backend.store(int(backend));
}

// The value of a process-wide setting, resolved from its default (environment) on first use.
template <class E, class Default>
E resolved(std::atomic<int>& setting, Default default_value) {
    int v = setting.load(std::memory_order_relaxed);
    if (v == kUnresolved) {
        int expected = kUnresolved;
        setting.compare_exchange_strong(expected, int(default_value()));
        v = setting.load();
    }
    return E(v);
}

GemmBackend gemm_backend() { return resolved<GemmBackend>(g_backend, default_backend); }

const char* gemm_backend_name(GemmBackend backend) {
    return backend == GemmBackend::Blas ? "blas" : "eigen";
}

bool blas_core_suits_cpu(const std::string& core, bool cpu_has_avx2_fma) {
    if (!cpu_has_avx2_fma) return true;
    std::string lower(core);
    std::transform(lower.begin(), lower.end(), lower.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    for (const char* avx2_class : {"haswell", "zen", "skylakex", "cooperlake", "sapphirerapids"})
        if (lower == avx2_class) return true;
    return false;
}

std::string blas_core_name() {
    if constexpr (kHaveBlas) return gemm_detail::blas_core_name();
    return "";
}

std::string blas_default_declined_reason() {
    if constexpr (kHaveBlas) {
        static const std::string reason = [] {
            const std::string core = blas_core_name();
            if (blas_core_suits_cpu(core, cpu_has_avx2_fma())) return std::string();
            return "OpenBLAS runs its " + (core.empty() ? std::string("unnamed") : core) +
                   " kernel, which does not use this CPU's AVX2 and FMA";
        }();
        return reason;
    }
    return "";
}

GemmBackend parse_gemm_backend(const char* name) {
    if (std::strcmp(name, "eigen") == 0) return GemmBackend::Eigen;
    if (std::strcmp(name, "blas") == 0) return GemmBackend::Blas;
    PCP_CHECK(false, "unknown GEMM back end '" << name << "': expected eigen or blas");
    return GemmBackend::Eigen;
}

bool bf16_available() { return bf16_unavailable_reason().empty(); }

std::string bf16_unavailable_reason() {
    if (!kHaveDnnl)
        return "this build of libpcp has no oneDNN back end (install libdnnl-dev and configure with "
               "-DPCP_DNNL=AUTO or ON)";
    if constexpr (kHaveDnnl) {
        static const bool units = gemm_detail::dnnl_cpu_has_bf16_units();
        if (!units) return "this CPU has neither AVX512-BF16 nor AMX";
    }
    return "";
}

void set_gemm_precision(Precision precision) {
    PCP_CHECK(precision == Precision::Fp32 || bf16_available(),
              "nn::set_gemm_precision: bf16 is not available: " << bf16_unavailable_reason());
    g_precision.store(int(precision));
}

Precision gemm_precision() { return resolved<Precision>(g_precision, default_precision); }

long bf16_primitives_created() {
    if constexpr (kHaveDnnl) return gemm_detail::dnnl_primitives_created();
    return 0;
}

const char* precision_name(Precision precision) { return precision == Precision::Bf16 ? "bf16" : "fp32"; }

Precision parse_precision(const std::string& name) {
    if (name == "fp32") return Precision::Fp32;
    if (name == "auto") return bf16_available() ? Precision::Bf16 : Precision::Fp32;
    PCP_CHECK(name == "bf16", "unknown precision '" << name << "': expected auto, fp32 or bf16");
    PCP_CHECK(bf16_available(), "precision bf16 is not available: " << bf16_unavailable_reason());
    return Precision::Bf16;
}

template <class S>
void gemm(MatRef<S> C, const CMatRef<S>& A, const CMatRef<S>& B, S alpha, S beta, Trans ta,
          Trans tb) {
    check_shapes("nn::gemm", C, A, B, ta, tb);
    if (C.size() == 0) return;
    const Index k = ta == Trans::No ? A.cols() : A.rows();
    if (k == 0) {  // the product is zero
        gemm_detail::scale_block(C.data(), C.outerStride(), C.rows(), C.cols(), beta);
        return;
    }
    const GemmArgs<S> g{C.rows(), C.cols(), k,     A.data(), leading_dim(A), B.data(), leading_dim(B),
                        C.data(), leading_dim(C), alpha, beta, ta,       tb};
    if constexpr (kHaveDnnl && std::is_same_v<S, float>) {
        if (g.m >= kBf16MinDim && g.n >= kBf16MinDim && g.k >= kBf16MinDim &&
            gemm_precision() == Precision::Bf16) {
            gemm_detail::gemm_dnnl_bf16(g);
            return;
        }
    }
    if constexpr (kHaveBlas) {
        if (gemm_backend() == GemmBackend::Blas) {
            gemm_detail::gemm_blas(g);
            return;
        }
    }
    gemm_detail::gemm_eigen(g);
}

template <class S>
void gemm_reference(MatRef<S> C, const CMatRef<S>& A, const CMatRef<S>& B, S alpha, S beta,
                    Trans ta, Trans tb) {
    check_shapes("nn::gemm_reference", C, A, B, ta, tb);
    const Index k = ta == Trans::No ? A.cols() : A.rows();
    for (Index j = 0; j < C.cols(); ++j)
        for (Index i = 0; i < C.rows(); ++i) {
            double acc = 0.0;
            for (Index l = 0; l < k; ++l) {
                const double a = ta == Trans::No ? A(i, l) : A(l, i);
                const double b = tb == Trans::No ? B(l, j) : B(j, l);
                acc += a * b;
            }
            const double prev = beta == S(0) ? 0.0 : double(beta) * double(C(i, j));
            C(i, j) = S(double(alpha) * acc + prev);
        }
}

template void gemm<float>(MatRef<float>, const CMatRef<float>&, const CMatRef<float>&, float,
                          float, Trans, Trans);
template void gemm<double>(MatRef<double>, const CMatRef<double>&, const CMatRef<double>&, double,
                           double, Trans, Trans);
template void gemm_reference<float>(MatRef<float>, const CMatRef<float>&, const CMatRef<float>&,
                                    float, float, Trans, Trans);
template void gemm_reference<double>(MatRef<double>, const CMatRef<double>&,
                                     const CMatRef<double>&, double, double, Trans, Trans);

}  // namespace pcp::nn
