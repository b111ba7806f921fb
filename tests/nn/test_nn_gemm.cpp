// Tests of the GEMM module (pcp/nn/gemm.hpp): each back end in its own test cases (Eigen always;
// BLAS tagged [blas], reported Skipped by CTest where it is not built, tests/support/main.cpp), on
// 1 and 2 threads, against the three-loop reference gemm_reference: all four
// transposition cases, odd sizes (including a depth above the kernel's k-block, and shapes that
// the Eigen back end splits by columns and by rows between threads), operands that are strided
// blocks of larger matrices, alpha/beta variants, beta == 0 over NaN, k == 0; the back-end
// selection API; and that the BLAS back end leaves the caller's OpenMP thread count as it was.
#include "pcp/core/error.hpp"
#include "gemm_backends.hpp"
#include "pcp/nn/gemm.hpp"
#include "pcp/nn/rng.hpp"

#include <catch2/catch.hpp>

#include <Eigen/Core>
#include <omp.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

using namespace pcp::nn;

namespace {

using pcp::test::RestoreGemmSettings;

template <class S>
Mat<S> randn(Eigen::Index r, Eigen::Index c, Rng& rng) {
    Mat<S> m(r, c);
    for (Eigen::Index j = 0; j < c; ++j)
        for (Eigen::Index i = 0; i < r; ++i) m(i, j) = S(rng.normal());
    return m;
}

struct Shape {
    int m, n, k;
};

// m x n x k: tiny, vectors, a depth above the kernel's k-block (several packed panels), and
// shapes large enough for the Eigen back end to split C by columns (n >= m) and by rows, with
// ragged last slabs.
const Shape kShapes[] = {{7, 5, 9}, {1, 1, 1}, {1, 13, 6}, {11, 1, 6},
                         {45, 37, 530}, {64, 97, 40}, {150, 21, 50}};

// For every shape, transposition and (alpha, beta): op(A), op(B) and C are blocks at odd offsets
// of larger matrices; C's block holds NaN when beta == 0. The back end must match the reference on
// 1 and 2 threads within the rounding bound (k + 2) eps (|alpha| |op(A)| |op(B)| + |beta C|) per
// entry, and leave everything outside C's block untouched.
template <class S>
void check_all_cases(GemmBackend backend) {
    RestoreGemmSettings restore;
    Rng rng(41, sizeof(S));
    const S eps = std::numeric_limits<S>::epsilon();
    const S alphas_betas[3][2] = {{S(1), S(0)}, {S(0.7), S(1)}, {S(-1.3), S(-0.5)}};
    for (const Shape& sh : kShapes)
        for (int ta = 0; ta < 2; ++ta)
            for (int tb = 0; tb < 2; ++tb)
                for (const auto& ab : alphas_betas) {
                    const S alpha = ab[0], beta = ab[1];
                    const Trans TA = ta ? Trans::Yes : Trans::No, TB = tb ? Trans::Yes : Trans::No;
                    const int ar = ta ? sh.k : sh.m, ac = ta ? sh.m : sh.k;
                    const int br = tb ? sh.n : sh.k, bc = tb ? sh.k : sh.n;
                    const Mat<S> Abig = randn<S>(ar + 3, ac + 2, rng);
                    const Mat<S> Bbig = randn<S>(br + 2, bc + 3, rng);
                    Mat<S> C0 = randn<S>(sh.m + 4, sh.n + 2, rng);
                    if (beta == S(0)) C0.block(3, 1, sh.m, sh.n).setConstant(std::numeric_limits<S>::quiet_NaN());
                    const auto A = Abig.block(2, 1, ar, ac);
                    const auto B = Bbig.block(1, 2, br, bc);
                    Mat<S> Cref = C0;
                    gemm_reference<S>(Cref.block(3, 1, sh.m, sh.n), A, B, alpha, beta, TA, TB);
                    // rounding bound from the absolute values
                    Mat<S> bound = C0.cwiseAbs();
                    if (beta == S(0)) bound.setZero();
                    const Mat<S> Aabs = A.cwiseAbs(), Babs = B.cwiseAbs();
                    gemm_reference<S>(bound.block(3, 1, sh.m, sh.n), Aabs, Babs, std::abs(alpha),
                                      std::abs(beta), TA, TB);
                    bound *= S(sh.k + 2) * eps;
                    for (int threads : {1, 2}) {
                        set_gemm_backend(backend);
                        Eigen::setNbThreads(threads);
                        Mat<S> C = C0;
                        gemm<S>(C.block(3, 1, sh.m, sh.n), A, B, alpha, beta, TA, TB);
                        const Mat<S> err = (C - Cref).cwiseAbs();
                        bool outside_same = true, inside_ok = true;
                        for (int j = 0; j < C.cols(); ++j)
                            for (int i = 0; i < C.rows(); ++i) {
                                const bool inside = i >= 3 && i < 3 + sh.m && j >= 1 && j < 1 + sh.n;
                                if (!inside && !(C(i, j) == C0(i, j))) outside_same = false;
                                if (inside && !(err(i, j) <= bound(i, j))) inside_ok = false;
                            }
                        INFO("back end " << gemm_backend_name(backend) << ", " << threads
                                         << " thread(s), " << sh.m << "x" << sh.n << "x" << sh.k
                                         << ", ta " << ta << ", tb " << tb << ", alpha " << alpha
                                         << ", beta " << beta);
                        CHECK(inside_ok);
                        CHECK(outside_same);
                    }
                }
}

// k == 0: C = beta C, also over NaN with beta == 0.
void check_empty_depth(GemmBackend backend) {
    RestoreGemmSettings restore;
    Rng rng(42, 0);
    const Mat<double> A(4, 0), B(0, 3);
    set_gemm_backend(backend);
    Mat<double> C = randn<double>(4, 3, rng);
    const Mat<double> C0 = C;
    gemm<double>(C, A, B, 2.0, -0.5);
    CHECK((C - (-0.5) * C0).cwiseAbs().maxCoeff() == 0.0);
    gemm<double>(C, A, B, 2.0, 1.0);
    CHECK((C - (-0.5) * C0).cwiseAbs().maxCoeff() == 0.0);
    C.setConstant(std::numeric_limits<double>::quiet_NaN());
    gemm<double>(C, A, B, 2.0, 0.0);
    CHECK(C.cwiseAbs().maxCoeff() == 0.0);
}

// The caller's OpenMP thread count (ICV) and Eigen's thread count survive a product.
void check_thread_counts_kept(GemmBackend backend) {
    RestoreGemmSettings restore;
    const int saved = omp_get_max_threads();
    Rng rng(43, 0);
    const Mat<float> A = randn<float>(128, 128, rng), B = randn<float>(128, 64, rng);
    Mat<float> C(128, 64);
    set_gemm_backend(backend);
    for (int threads : {1, 2}) {
        Eigen::setNbThreads(threads);
        omp_set_num_threads(3);
        gemm<float>(C, A, B, 1.0f, 0.0f);
        INFO(threads << " thread(s)");
        CHECK(omp_get_max_threads() == 3);
        CHECK(Eigen::nbThreads() == threads);
    }
    omp_set_num_threads(saved);
}

}  // namespace

TEST_CASE("nn: the eigen gemm back end matches the reference (float)", "[nn]") { check_all_cases<float>(GemmBackend::Eigen); }

TEST_CASE("nn: the eigen gemm back end matches the reference (double)", "[nn]") { check_all_cases<double>(GemmBackend::Eigen); }

TEST_CASE("nn: the blas gemm back end matches the reference (float)", "[nn][blas]") { check_all_cases<float>(GemmBackend::Blas); }

TEST_CASE("nn: the blas gemm back end matches the reference (double)", "[nn][blas]") { check_all_cases<double>(GemmBackend::Blas); }

TEST_CASE("nn: the eigen gemm back end with k == 0 scales C by beta", "[nn]") { check_empty_depth(GemmBackend::Eigen); }

TEST_CASE("nn: the blas gemm back end with k == 0 scales C by beta", "[nn][blas]") { check_empty_depth(GemmBackend::Blas); }

TEST_CASE("nn: gemm back-end selection", "[nn]") {
    RestoreGemmSettings restore;
    CHECK(gemm_backend_available(GemmBackend::Eigen));
    CHECK(parse_gemm_backend("eigen") == GemmBackend::Eigen);
    CHECK(parse_gemm_backend("blas") == GemmBackend::Blas);
    CHECK_THROWS_WITH(parse_gemm_backend("mkl"), Catch::Contains("expected eigen or blas"));
    CHECK(std::string(gemm_backend_name(GemmBackend::Blas)) == "blas");
    set_gemm_backend(GemmBackend::Eigen);
    CHECK(gemm_backend() == GemmBackend::Eigen);
    if (gemm_backend_available(GemmBackend::Blas)) {
        set_gemm_backend(GemmBackend::Blas);
        CHECK(gemm_backend() == GemmBackend::Blas);
    } else {
        CHECK_THROWS_WITH(set_gemm_backend(GemmBackend::Blas), Catch::Contains("no BLAS back end"));
        CHECK(gemm_backend() == GemmBackend::Eigen);
    }
    Mat<float> C(3, 3), A(3, 4), B(5, 3);
    CHECK_THROWS_WITH(gemm<float>(C, A, B, 1.0f, 0.0f), Catch::Contains("shape mismatch"));
}

TEST_CASE("nn: OpenBLAS's generic kernel is declined as the default on an AVX2 CPU", "[nn]") {
    // On a CPU model it does not know, OpenBLAS 0.3.21 runs its SSE3 kernel "Prescott" (an Emerald
    // Rapids Xeon: 25 GFLOP/s against Eigen's 160); only its AVX2-class kernels suit an AVX2 CPU.
    for (const char* core : {"Haswell", "Zen", "SkylakeX", "Cooperlake", "SapphireRapids", "HASWELL"})
        CHECK(blas_core_suits_cpu(core, true));
    for (const char* core : {"Prescott", "Core2", "Sandybridge", "Nehalem", "Unknown", "", "Haswell2"})
        CHECK_FALSE(blas_core_suits_cpu(core, true));
    for (const char* core : {"Prescott", "Sandybridge", ""}) CHECK(blas_core_suits_cpu(core, false));
    CHECK(blas_core_name().empty() != gemm_backend_available(GemmBackend::Blas));
    // Declining names the kernel, and only a build with the BLAS back end declines.
    const std::string why = blas_default_declined_reason();
    if (!why.empty()) {
        CHECK(gemm_backend_available(GemmBackend::Blas));
        CHECK(why.find("OpenBLAS runs its ") == 0);
        CHECK(why.find(blas_core_name()) != std::string::npos);
        CHECK_FALSE(blas_core_suits_cpu(blas_core_name(), true));
    }
}

TEST_CASE("nn: the eigen gemm back end keeps the caller's OpenMP thread count", "[nn]") {
    check_thread_counts_kept(GemmBackend::Eigen);
}

TEST_CASE("nn: the blas gemm back end keeps the caller's OpenMP thread count", "[nn][blas]") {
    check_thread_counts_kept(GemmBackend::Blas);
}
