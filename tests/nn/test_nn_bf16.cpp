// Tests of Precision::Bf16 (pcp/nn/gemm.hpp, oneDNN back end): the selection API on every build
// (bf16 selectable where available, refused with the reason elsewhere); in the test cases tagged
// [bf16], which CTest reports as Skipped where bf16 is unavailable (tests/support/main.cpp), the
// bf16 product against a double reference computed on operands
// rounded to bf16 here (so the check is tight: only fp32 accumulation error is allowed), for all
// transpositions, strided blocks, alpha/beta, beta == 0 over NaN, 1 and 2 threads and inside an
// OpenMP parallel region; that products below kBf16MinDim keep fp32 accuracy; that the caller's
// OpenMP thread count survives; and a stage-2 training run in bf16 that must track fp32.
#include "gemm_backends.hpp"
#include "pcp/core/error.hpp"
#include "pcp/nn/gemm.hpp"
#include "pcp/nn/rng.hpp"
#include "pcp/reconstruct.hpp"
#include "pcp/cloud/shapes.hpp"

#include <catch2/catch.hpp>

#include <Eigen/Core>
#include <omp.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>

using namespace pcp::nn;

namespace {

using pcp::test::RestoreGemmSettings;

Mat<float> randn(Eigen::Index r, Eigen::Index c, Rng& rng) {
    Mat<float> m(r, c);
    for (Eigen::Index j = 0; j < c; ++j)
        for (Eigen::Index i = 0; i < r; ++i) m(i, j) = float(rng.normal());
    return m;
}

// bf16 rounding to nearest even, written independently of the library's (finite inputs only).
float round_bf16(float x) {
    std::uint32_t u;
    std::memcpy(&u, &x, sizeof u);
    const std::uint32_t lower = u & 0xffffu, keep = u & 0xffff0000u;
    std::uint32_t r = keep;
    if (lower > 0x8000u || (lower == 0x8000u && (keep & 0x10000u))) r += 0x10000u;
    float y;
    std::memcpy(&y, &r, sizeof y);
    return y;
}

Mat<float> rounded(const Mat<float>& m) { return m.unaryExpr([](float x) { return round_bf16(x); }); }

struct Shape {
    int m, n, k;
};

}  // namespace

TEST_CASE("nn: precision selection", "[nn]") {
    RestoreGemmSettings restore;
    CHECK(parse_precision("fp32") == Precision::Fp32);
    CHECK(parse_precision("auto") == (bf16_available() ? Precision::Bf16 : Precision::Fp32));
    CHECK_THROWS_WITH(parse_precision("fp16"), Catch::Contains("expected auto, fp32 or bf16"));
    CHECK(std::string(precision_name(Precision::Bf16)) == "bf16");
    CHECK(std::string(precision_name(Precision::Fp32)) == "fp32");
    CHECK(bf16_available() == bf16_unavailable_reason().empty());
    set_gemm_precision(Precision::Fp32);
    CHECK(gemm_precision() == Precision::Fp32);
    if (bf16_available()) {
        CHECK(parse_precision("bf16") == Precision::Bf16);
        set_gemm_precision(Precision::Bf16);
        CHECK(gemm_precision() == Precision::Bf16);
    } else {  // refused, naming the reason
        CHECK_THROWS_WITH(parse_precision("bf16"), Catch::Contains("not available"));
        CHECK_THROWS_WITH(set_gemm_precision(Precision::Bf16), Catch::Contains("not available"));
        CHECK(gemm_precision() == Precision::Fp32);
    }
}

TEST_CASE("nn: bf16 gemm equals the product of the bf16-rounded operands", "[nn][bf16]") {
    RestoreGemmSettings restore;
    set_gemm_precision(Precision::Bf16);
    Rng rng(44, 0);
    const float eps = std::numeric_limits<float>::epsilon();
    const Shape shapes[] = {{32, 32, 32}, {45, 37, 530}, {64, 97, 40}, {150, 33, 50}, {96, 300, 256}};
    const float alphas_betas[3][2] = {{1.0f, 0.0f}, {0.7f, 1.0f}, {-1.3f, -0.5f}};
    for (const Shape& sh : shapes)
        for (int ta = 0; ta < 2; ++ta)
            for (int tb = 0; tb < 2; ++tb)
                for (const auto& ab : alphas_betas) {
                    const float alpha = ab[0], beta = ab[1];
                    const Trans TA = ta ? Trans::Yes : Trans::No, TB = tb ? Trans::Yes : Trans::No;
                    const int ar = ta ? sh.k : sh.m, ac = ta ? sh.m : sh.k;
                    const int br = tb ? sh.n : sh.k, bc = tb ? sh.k : sh.n;
                    const Mat<float> Abig = randn(ar + 3, ac + 2, rng), Bbig = randn(br + 2, bc + 3, rng);
                    Mat<float> C0 = randn(sh.m + 4, sh.n + 2, rng);
                    if (beta == 0.0f) C0.block(3, 1, sh.m, sh.n).setConstant(std::numeric_limits<float>::quiet_NaN());
                    const auto A = Abig.block(2, 1, ar, ac);
                    const auto B = Bbig.block(1, 2, br, bc);
                    const Mat<float> A16 = rounded(A), B16 = rounded(B);
                    Mat<float> Cref = C0, Cfp32 = C0;
                    gemm_reference<float>(Cref.block(3, 1, sh.m, sh.n), A16, B16, alpha, beta, TA, TB);
                    gemm_reference<float>(Cfp32.block(3, 1, sh.m, sh.n), A, B, alpha, beta, TA, TB);
                    Mat<float> bound = beta == 0.0f ? Mat<float>::Zero(C0.rows(), C0.cols()) : Mat<float>(C0.cwiseAbs());
                    const Mat<float> Aabs = A16.cwiseAbs(), Babs = B16.cwiseAbs();
                    gemm_reference<float>(bound.block(3, 1, sh.m, sh.n), Aabs, Babs, std::abs(alpha), std::abs(beta), TA, TB);
                    bound *= float(sh.k + 2) * eps;
                    for (int mode = 0; mode < 3; ++mode) {  // 1 thread, 2 threads, inside a parallel region
                        Eigen::setNbThreads(mode == 0 ? 1 : 2);
                        Mat<float> C = C0;
                        if (mode < 2) {
                            gemm<float>(C.block(3, 1, sh.m, sh.n), A, B, alpha, beta, TA, TB);
                        } else {
                            Mat<float> C2 = C0;
#pragma omp parallel num_threads(2)
                            {
                                Mat<float>& mine = omp_get_thread_num() == 0 ? C : C2;
                                gemm<float>(mine.block(3, 1, sh.m, sh.n), A, B, alpha, beta, TA, TB);
                            }
                            CHECK(((C - C2).array().abs() == 0).all());
                        }
                        bool outside_same = true, inside_ok = true;
                        double max_from_fp32 = 0.0;
                        for (int j = 0; j < C.cols(); ++j)
                            for (int i = 0; i < C.rows(); ++i) {
                                const bool inside = i >= 3 && i < 3 + sh.m && j >= 1 && j < 1 + sh.n;
                                if (!inside && !(C(i, j) == C0(i, j))) outside_same = false;
                                if (inside && !(std::abs(C(i, j) - Cref(i, j)) <= bound(i, j))) inside_ok = false;
                                if (inside) max_from_fp32 = std::max(max_from_fp32, double(std::abs(C(i, j) - Cfp32(i, j))));
                            }
                        INFO(sh.m << "x" << sh.n << "x" << sh.k << ", ta " << ta << ", tb " << tb << ", alpha " << alpha
                                  << ", beta " << beta << ", mode " << mode);
                        CHECK(inside_ok);
                        CHECK(outside_same);
                        // bf16 really ran: the result differs from the fp32 product by far more
                        // than fp32 rounding (relative bf16 rounding is 2^-9 per operand).
                        CHECK(max_from_fp32 > 1e-3);
                    }
                }
}

TEST_CASE("nn: under bf16, products below kBf16MinDim keep fp32 accuracy", "[nn][bf16]") {
    RestoreGemmSettings restore;
    set_gemm_precision(Precision::Bf16);
    Rng rng(45, 0);
    const float eps = std::numeric_limits<float>::epsilon();
    for (const Shape& sh : {Shape{1, 500, 256}, Shape{256, 500, 3}, Shape{256, 31, 256}}) {
        const Mat<float> A = randn(sh.m, sh.k, rng), B = randn(sh.k, sh.n, rng);
        Mat<float> C(sh.m, sh.n), Cref(sh.m, sh.n), bound(sh.m, sh.n);
        gemm<float>(C, A, B, 1.0f, 0.0f);
        gemm_reference<float>(Cref, A, B, 1.0f, 0.0f);
        gemm_reference<float>(bound, Mat<float>(A.cwiseAbs()), Mat<float>(B.cwiseAbs()), 1.0f, 0.0f);
        INFO(sh.m << "x" << sh.n << "x" << sh.k);
        CHECK(((C - Cref).array().abs() <= bound.array() * float(sh.k + 2) * eps).all());
    }
}

TEST_CASE("nn: bf16 gemm keeps the caller's OpenMP thread count", "[nn][bf16]") {
    RestoreGemmSettings restore;
    set_gemm_precision(Precision::Bf16);
    const int saved = omp_get_max_threads();
    Rng rng(46, 0);
    const Mat<float> A = randn(128, 128, rng), B = randn(128, 64, rng);
    Mat<float> C(128, 64);
    for (int threads : {1, 2}) {
        Eigen::setNbThreads(threads);
        omp_set_num_threads(3);
        gemm<float>(C, A, B, 1.0f, 0.0f);
        CHECK(omp_get_max_threads() == 3);
        CHECK(Eigen::nbThreads() == threads);
    }
    omp_set_num_threads(saved);
}

// reconstruct() evaluates its meshing grid in fp32 under bf16 training (fp32_grid, the default)
// and leaves the process in bf16 afterwards. The grid's evaluation batches (4096 points, in the
// OpenMP workers) have shapes the training never uses, so bf16 evaluation creates new oneDNN
// primitives where fp32 evaluation creates none: the counter tells which precision the grid ran.
TEST_CASE("reconstruct: under bf16 the SDF grid runs in fp32 unless asked otherwise", "[nn][bf16][heavy]") {
    RestoreGemmSettings restore;
    set_gemm_precision(Precision::Bf16);
    pcp::ReconstructOptions o = pcp::ReconstructOptions::preset("fast");
    o.prior_source = pcp::PriorSource::SelfPrior;  // a tiny self-prior: the test is about the grid's precision
    o.self_prior.network.width = 32;
    o.self_prior.network.depth = 4;
    o.self_prior.network.condition = 32;
    o.self_prior.max_steps = 30;
    o.self_prior.regions.grid = 2;
    o.fit.width = 32;
    o.fit.depth = 4;
    o.fit.queries_per_step = 200;
    o.fit.steps = 30;
    o.fit.schedule.progress_every = 1 << 30;
    o.resolution = 32;
    const pcp::Points cloud = pcp::sample_sphere(1500, 0.4, Eigen::Vector3d::Zero(), 4).points;
    pcp::reconstruct(cloud, nullptr, o);  // warm-up: the training's primitives
    CHECK(gemm_precision() == Precision::Bf16);
    const long before = bf16_primitives_created();
    pcp::reconstruct(cloud, nullptr, o);
    const long fp32_grid_created = bf16_primitives_created() - before;
    CHECK(gemm_precision() == Precision::Bf16);
    o.fp32_grid = false;
    pcp::reconstruct(cloud, nullptr, o);
    const long bf16_grid_created = bf16_primitives_created() - before - fp32_grid_created;
    CHECK(gemm_precision() == Precision::Bf16);
    INFO("primitives created: fp32 grid " << fp32_grid_created << ", bf16 grid " << bf16_grid_created);
    CHECK(fp32_grid_created == 0);
    CHECK(bf16_grid_created > 0);
}
