// Gradient tests of the neural core (pcp/nn/*): the GEMM module against its three-loop reference,
// the batched passes against the per-sample reference (tests/nn_reference.hpp), and every
// hand-written derivative of METHOD.md §4 against central differences in double: the layers, F's
// input gradient, the parameter backward, the stage-1 double backprop of the full loss (decoder +
// PointNet encoder), the stage-2 path into Q through a frozen F, and the pulling loss itself.
// A planted bug (the tangent term dropped) must make the stage-1 check fail.
#include "nn/planted_bug.hpp"
#include "nn_reference.hpp"

#include "pcp/core/error.hpp"
#include "pcp/nn/gemm.hpp"
#include "pcp/nn/layers.hpp"
#include "pcp/nn/networks.hpp"
#include "pcp/nn/pull_loss.hpp"
#include "pcp/nn/steps.hpp"

#include <catch2/catch.hpp>

using namespace pcp::nn;
using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace {

constexpr double kEps = 1e-6;   // central-difference step
constexpr double kTol = 1e-6;   // relative tolerance
constexpr double kAtol = 1e-10; // absolute floor: the FD's own round-off (loss ~0.1, eps 1e-6)
// Parameters probed per network. The reference forward these checks difference runs in this file,
// which the sanitizer build compiles at -O0 (tests/CMakeLists.txt): there a quarter of them, drawn
// the same way, keeps the run within the CI budget; the Release build probes all 48.
constexpr int kProbes = PCP_TEST_SANITIZED ? 12 : 48;

MatrixXd randn(int r, int c, Rng& rng, double sd = 1.0) {
    MatrixXd m(r, c);
    for (int j = 0; j < c; ++j)
        for (int i = 0; i < r; ++i) m(i, j) = rng.normal(0.0, sd);
    return m;
}

// Small-width networks with generic (non-zero) biases.
BranchMlp<double> make_decoder(int C, int H, int L, Rng& rng) {
    BranchMlp<double> F(decoder_shape(C, H, L));
    init_decoder_geometric(F, rng);
    for (int l = 0; l < F.layout.num_layers(); ++l)
        for (int i = 0; i < F.layout.rows(l); ++i) F.b(l)(i, 0) += rng.normal(0.0, 0.05);
    return F;
}

BranchMlp<double> make_query_net(int C, int H, int L, int K, Rng& rng) {
    BranchMlp<double> Q(query_net_shape(C, H, L, K));
    init_query_net(Q, rng, false);
    for (int l = 0; l < Q.layout.num_layers(); ++l)
        for (int i = 0; i < Q.layout.rows(l); ++i) Q.b(l)(i, 0) += rng.normal(0.0, 0.05);
    // keep the shift small so that q_l' stays in the decoder's region
    Q.W(layer_head(Q.shape)).topRows(3) *= 0.1;
    return Q;
}

PointNet<double> make_encoder(const PointNetShape& shape, Rng& rng) {
    PointNet<double> E(shape);
    init_pointnet(E, rng);
    for (int l = 0; l < E.layout.num_layers(); ++l)
        for (int i = 0; i < E.layout.rows(l); ++i) E.b(l)(i, 0) += rng.normal(0.0, 0.05);
    return E;
}

void require_check(const nnref::GradCheck& r, int total, const std::string& what) {
    INFO(what << ": checked " << r.checked << ", skipped (kink crossed) " << r.skipped
              << ", failed " << r.failed << ", max rel err " << r.max_rel << "\n"
              << r.report);
    CHECK(r.failed == 0);
    CHECK(r.checked >= 1);
    CHECK(r.skipped <= total / 20);  // kinks must be rare, or the check proves little
}

}  // namespace

TEST_CASE("nn: gemm matches the three-loop reference for every transpose on strided blocks",
          "[nn]") {
    Rng rng(1, 0);
    for (int ta = 0; ta < 2; ++ta)
        for (int tb = 0; tb < 2; ++tb)
            for (double beta : {0.0, 1.0, -0.5}) {
                const int m = 7, n = 5, k = 9;
                MatrixXd Abig = randn(20, 20, rng), Bbig = randn(20, 20, rng);
                MatrixXd Cbig = randn(20, 20, rng);
                const Trans TA = ta ? Trans::Yes : Trans::No;
                const Trans TB = tb ? Trans::Yes : Trans::No;
                auto A = Abig.block(1, 2, ta ? k : m, ta ? m : k);
                auto B = Bbig.block(3, 1, tb ? n : k, tb ? k : n);
                MatrixXd Cref = Cbig;
                gemm<double>(Cbig.block(2, 3, m, n), A, B, 0.7, beta, TA, TB);
                gemm_reference<double>(Cref.block(2, 3, m, n), A, B, 0.7, beta, TA, TB);
                CHECK((Cbig - Cref).cwiseAbs().maxCoeff() < 1e-12);
            }
    MatrixXd C(3, 3), A(3, 4), B(5, 3);
    CHECK_THROWS_WITH(gemm<double>(C, A, B, 1.0, 0.0), Catch::Contains("shape mismatch"));
}

TEST_CASE("nn: the fused dense + ReLU layer gives the two calls' numbers", "[nn]") {
    Rng rng(4, 0);
    const int D = 7, H = 9, N = 13;
    const MatrixXd W = randn(H, D, rng), b = randn(H, 1, rng, 0.5), A = randn(D, N, rng);
    MatrixXd two(H, N);
    linear_forward<double>(two, A, W, b);
    relu_forward<double>(two);
    REQUIRE((two.array() == 0.0).any());  // some units are cut, some pass
    REQUIRE((two.array() > 0.0).any());
    // Into a block of a taller, wider matrix (outer stride != rows), as the caches use it.
    MatrixXd big = MatrixXd::Constant(H + 3, N + 2, 7.0);
    linear_relu_forward<double>(big.topRows(H).leftCols(N), A, W, b);
    CHECK(big.topRows(H).leftCols(N) == two);
    CHECK((big.bottomRows(3).array() == 7.0).all());
    CHECK((big.rightCols(2).array() == 7.0).all());
    // In float too (the pipeline's type), bit for bit.
    const Eigen::MatrixXf Wf = W.cast<float>(), bf = b.cast<float>(), Af = A.cast<float>();
    Eigen::MatrixXf twof(H, N), fused(H, N);
    linear_forward<float>(twof, Af, Wf, bf);
    relu_forward<float>(twof);
    linear_relu_forward<float>(fused, Af, Wf, bf);
    CHECK(fused == twof);
    MatrixXd bad(H + 1, 1);
    CHECK_THROWS_WITH(bias_relu<double>(two, bad), Catch::Contains("nn::bias_relu"));
    CHECK_THROWS_WITH(linear_relu_forward<double>(two, A, W, bad), Catch::Contains("nn::linear_relu_forward"));
}

TEST_CASE("nn: dense, ReLU and max-pool layers match finite differences", "[nn]") {
    Rng rng(2, 0);
    const int D = 5, H = 6, N = 4;
    MatrixXd W = randn(H, D, rng), b = randn(H, 1, rng, 0.1), A = randn(D, N, rng),
             w = randn(H, N, rng);
    // L = sum(w .* relu(W A + b)); checked w.r.t. W, b, A by packing them into one vector.
    auto loss = [&](const MatrixXd& W_, const MatrixXd& b_, const MatrixXd& A_, nnref::Kinks* k) {
        MatrixXd Z(H, N);
        linear_forward<double>(Z, A_, W_, b_);
        if (k)
            for (int i = 0; i < Z.size(); ++i) k->relu(Z(i));
        relu_forward<double>(Z);
        return (w.array() * Z.array()).sum();
    };
    MatrixXd Z(H, N);
    linear_forward<double>(Z, A, W, b);
    relu_forward<double>(Z);
    MatrixXd G = w;
    relu_backward<double>(G, Z);
    MatrixXd dW(H, D), db(H, 1), dA(D, N);
    linear_backward_params<double>(dW, db, G, A, GradMode::Overwrite);
    linear_backward_input<double>(dA, G, W, GradMode::Overwrite);
    // Accumulate mode adds.
    MatrixXd dW2 = dW, db2 = db;
    linear_backward_params<double>(dW2, db2, G, A, GradMode::Accumulate);
    CHECK((dW2 - 2 * dW).norm() < 1e-12);
    CHECK((db2 - 2 * db).norm() < 1e-12);

    VectorXd x(W.size() + b.size() + A.size());
    x << Eigen::Map<VectorXd>(W.data(), W.size()), Eigen::Map<VectorXd>(b.data(), b.size()),
        Eigen::Map<VectorXd>(A.data(), A.size());
    VectorXd analytic(x.size());
    analytic << Eigen::Map<VectorXd>(dW.data(), dW.size()),
        Eigen::Map<VectorXd>(db.data(), db.size()), Eigen::Map<VectorXd>(dA.data(), dA.size());
    std::vector<Eigen::Index> coords(x.size());
    for (Eigen::Index i = 0; i < x.size(); ++i) coords[i] = i;
    auto packed = [&](nnref::Kinks* k) {
        Eigen::Map<const MatrixXd> W_(x.data(), H, D), b_(x.data() + H * D, H, 1),
            A_(x.data() + H * D + H, D, N);
        return loss(W_, b_, A_, k);
    };
    const auto r = nnref::check_gradient(x, analytic, coords, packed, kEps, kTol, kAtol, "dense");
    require_check(r, int(coords.size()), "dense + ReLU");

    // Max-pool: L = sum(w_p .* maxpool(A)).
    MatrixXd P = randn(H, 7, rng);
    VectorXd pooled(H), wp = randn(H, 1, rng);
    Eigen::VectorXi arg(H);
    maxpool_forward<double>(pooled, arg, P);
    for (int r2 = 0; r2 < H; ++r2) CHECK(pooled(r2) == P.row(r2).maxCoeff());
    MatrixXd dP(H, 7);
    maxpool_backward<double>(dP, wp, arg, GradMode::Overwrite);
    for (int r2 = 0; r2 < H; ++r2)
        for (int j = 0; j < 7; ++j) CHECK(dP(r2, j) == (j == arg(r2) ? wp(r2) : 0.0));
}

TEST_CASE("nn: batched passes match the per-sample reference", "[nn]") {
    Rng rng(3, 0);
    const int C = 6, H = 16, L = 8, N = 9;
    const BranchMlp<double> F = make_decoder(C, H, L, rng);
    const MatrixXd q = randn(3, N, rng, 0.3);
    for (bool shared : {true, false}) {
        const MatrixXd f = randn(C, shared ? 1 : N, rng, 0.5);
        BranchMlpCache<double> cache(F.shape, 16);
        branch_mlp_forward<double>(F, q, f, cache);
        decoder_input_grad(F, cache, true);
        for (int i = 0; i < N; ++i) {
            const VectorXd fi = f.col(shared ? 0 : i);
            const auto tr = nnref::forward(F, q.col(i), fi, nullptr);
            VectorXd ga, gb;
            nnref::input_grad(F, tr, ga, gb);
            CHECK(std::abs(cache.out(0, i) - tr.out(0)) < 1e-12);
            CHECK((cache.g_a.col(i) - ga).norm() < 1e-12);
            CHECK((cache.g_b.col(i) - gb).norm() < 1e-12);
        }
    }
    // Query network with a code branch, and the encoder.
    const BranchMlp<double> Q = make_query_net(C, H, L, 3, rng);
    MatrixXd codes = MatrixXd::Zero(3, N);
    for (int i = 0; i < N; ++i) codes(i % 3, i) = 1.0;
    BranchMlpCache<double> qc(Q.shape, N, false);
    branch_mlp_forward<double>(Q, q, codes, qc);
    for (int i = 0; i < N; ++i) {
        const auto tr = nnref::forward(Q, q.col(i), codes.col(i), nullptr);
        CHECK((qc.out.col(i) - tr.out).norm() < 1e-12);
    }
    const PointNet<double> E = make_encoder(pointnet_shape(C, 32, 16), rng);
    PointNetCache<double> ec(E.shape, 20);
    const MatrixXd pts = randn(3, 13, rng, 0.3);
    pointnet_forward<double>(E, pts, ec);
    CHECK((ec.f() - nnref::pointnet(E, pts, nullptr)).norm() < 1e-12);
    // Shapes are checked on entry.
    BranchMlpCache<double> cache(F.shape, 16);
    CHECK_THROWS_WITH(branch_mlp_forward<double>(F, MatrixXd(2, 4), MatrixXd(C, 1), cache),
                      Catch::Contains("x_a is 2x4"));
}

TEST_CASE("nn: F's input gradient (ds/dq and ds/df) matches finite differences", "[nn]") {
    Rng rng(4, 0);
    const int C = 6, H = 24, L = 8, N = 12;
    const BranchMlp<double> F = make_decoder(C, H, L, rng);
    MatrixXd q = randn(3, N, rng, 0.3);
    MatrixXd f = randn(C, N, rng, 0.5);
    BranchMlpCache<double> cache(F.shape, N);
    branch_mlp_forward<double>(F, q, f, cache);
    decoder_input_grad(F, cache, true);
    int checked = 0, skipped = 0, failed = 0;
    double max_rel = 0.0;
    for (int i = 0; i < N; ++i) {
        // Skip a sample when any of its pre-activations is within 10 eps of a kink.
        nnref::Kinks k;
        nnref::forward(F, q.col(i), f.col(i), &k);
        if (k.min_abs < 10 * kEps) {
            ++skipped;
            continue;
        }
        VectorXd x(3 + C);
        x << q.col(i), f.col(i);
        VectorXd analytic(3 + C);
        analytic << cache.g_a.col(i), cache.g_b.col(i);
        std::vector<Eigen::Index> coords(3 + C);
        for (int c = 0; c < 3 + C; ++c) coords[c] = c;
        auto s_of = [&](nnref::Kinks* kk) {
            return nnref::forward(F, x.head(3), x.tail(C), kk).out(0);
        };
        const auto r = nnref::check_gradient(x, analytic, coords, s_of, kEps, kTol, kAtol, "g");
        INFO("sample " << i << "\n" << r.report);
        checked += r.checked;
        skipped += r.skipped;
        failed += r.failed;
        max_rel = std::max(max_rel, r.max_rel);
    }
    INFO("checked " << checked << " skipped " << skipped << " max rel " << max_rel);
    CHECK(failed == 0);
    CHECK(skipped <= 1);
    CHECK(checked >= (N - 1) * (3 + C));
}

TEST_CASE("nn: parameter backward of F and Q matches finite differences", "[nn]") {
    Rng rng(5, 0);
    const int C = 5, H = 16, L = 8, N = 10;
    for (int variant = 0; variant < 3; ++variant) {
        // 0: F with a shared condition, 1: F per-query condition, 2: Q with a code branch.
        BranchMlp<double> net = variant < 2 ? make_decoder(C, H, L, rng)
                                            : make_query_net(C, H, L, 3, rng);
        const MatrixXd xa = randn(3, N, rng, 0.3);
        MatrixXd xb;
        if (variant == 0) xb = randn(C, 1, rng, 0.5);
        if (variant == 1) xb = randn(C, N, rng, 0.5);
        if (variant == 2) {
            xb = MatrixXd::Zero(3, N);
            for (int i = 0; i < N; ++i) xb(i % 3, i) = 1.0;
        }
        const MatrixXd w = randn(net.shape.out, N, rng);  // L = sum(w .* out)
        BranchMlpCache<double> cache(net.shape, N);
        branch_mlp_forward<double>(net, xa, xb, cache);
        VectorXd grad(net.layout.size());
        branch_mlp_backward<double>(net, cache, xa, xb, w, grad, GradMode::Overwrite);
        auto loss = [&](nnref::Kinks* k) {
            double sum = 0.0;
            for (int i = 0; i < N; ++i) {
                const VectorXd xbi = xb.cols() == 1 ? VectorXd(xb.col(0)) : VectorXd(xb.col(i));
                sum += w.col(i).dot(nnref::forward(net, xa.col(i), xbi, k).out);
            }
            return sum;
        };
        const auto coords = nnref::sample_coords(net.layout, PCP_TEST_SANITIZED ? 10 : 40);
        const auto r =
            nnref::check_gradient(net.params, grad, coords, loss, kEps, kTol, kAtol, "theta");
        require_check(r, int(coords.size()), "backward variant " + std::to_string(variant));
    }
}

namespace {

struct Stage1Case {
    PointNet<double> E;
    BranchMlp<double> F;
    MatrixXd q, t, points;
    int redraws = 0;
};

// Points near a sphere of radius 0.3, queries around them, targets = the nearest point; redrawn
// while any pre-activation (or max-pool lead) lies within 10 eps of a kink.
Stage1Case make_stage1_case(const PointNetShape& es, int C, int H, int L, int N, int M,
                            std::uint64_t seed) {
    Rng rng(seed, 0);
    Stage1Case c{make_encoder(es, rng), make_decoder(C, H, L, rng), {}, {}, {}, 0};
    for (;;) {
        c.points = randn(3, M, rng);
        for (int j = 0; j < M; ++j) c.points.col(j) *= 0.3 / c.points.col(j).norm();
        c.q.resize(3, N);
        c.t.resize(3, N);
        for (int i = 0; i < N; ++i) {
            c.q.col(i) = c.points.col(i % M) + randn(3, 1, rng, 0.05);
            Eigen::Index best;
            (c.points.colwise() - c.q.col(i)).colwise().squaredNorm().minCoeff(&best);
            c.t.col(i) = c.points.col(best);
        }
        nnref::Kinks k;
        nnref::stage1_loss(c.E, c.F, c.q, c.t, c.points, &k);
        if (k.min_abs >= 10 * kEps) break;
        ++c.redraws;
    }
    return c;
}

struct Stage1Result {
    nnref::GradCheck enc, dec;
    int enc_total = 0, dec_total = 0;
};

Stage1Result check_stage1(Stage1Case& c, bool drop_tangent) {
    const int N = int(c.q.cols()), M = int(c.points.cols());
    Stage1Workspace<double> ws(c.E.shape, c.F.shape, N, M);
    VectorXd dE(c.E.layout.size()), dF(c.F.layout.size());
    double L = 0;
    if (drop_tangent) {
        const pcp::nn::detail::PlantedTangentDrop planted;  // src/nn/planted_bug.hpp
        L = ws.loss_and_grad(c.E, c.F, c.q, c.t, c.points, dE, dF);
    } else {
        L = ws.loss_and_grad(c.E, c.F, c.q, c.t, c.points, dE, dF);
    }
    CHECK(std::abs(L - nnref::stage1_loss(c.E, c.F, c.q, c.t, c.points, nullptr)) < 1e-12);
    Stage1Result r;
    auto loss = [&](nnref::Kinks* k) { return nnref::stage1_loss(c.E, c.F, c.q, c.t, c.points, k); };
    const auto cf = nnref::sample_coords(c.F.layout, kProbes);
    const auto ce = nnref::sample_coords(c.E.layout, kProbes);
    r.dec = nnref::check_gradient(c.F.params, dF, cf, loss, kEps, kTol, kAtol, "dL/dtheta_F");
    r.enc = nnref::check_gradient(c.E.params, dE, ce, loss, kEps, kTol, kAtol, "dL/dtheta_E");
    r.dec_total = int(cf.size());
    r.enc_total = int(ce.size());
    return r;
}

}  // namespace

TEST_CASE("nn: stage-1 gradients of the full loss (decoder + PointNet) match finite differences",
          "[nn]") {
    // The release's encoder (one per-point layer) and a classic deeper one (3 -> 16 -> 32).
    PointNetShape deep;
    deep.point_widths = {3, 16, 32};
    deep.head_widths = {32, 16, 8};
    for (const PointNetShape& es : {pointnet_shape(8, 32, 16), deep}) {
        Stage1Case c = make_stage1_case(es, 8, 16, 8, 12, 10, 6);
        CHECK(c.redraws <= 3);
        const Stage1Result r = check_stage1(c, false);
        require_check(r.dec, r.dec_total, "stage 1 decoder");
        require_check(r.enc, r.enc_total, "stage 1 encoder");
    }
}

TEST_CASE("nn: the stage-1 checker rejects the planted bug (tangent term dropped)", "[nn]") {
    Stage1Case c = make_stage1_case(pointnet_shape(8, 32, 16), 8, 16, 8, 12, 10, 6);
    const Stage1Result r = check_stage1(c, true);
    INFO("planted bug: decoder failed " << r.dec.failed << " of " << r.dec.checked
                                        << ", max rel " << r.dec.max_rel);
    CHECK(r.dec.failed > r.dec.checked / 4);  // most weight gradients are wrong without u
    CHECK(r.dec.max_rel > 1e-2);
}

TEST_CASE("nn: stage-2 gradients into Q through the frozen F match finite differences", "[nn]") {
    for (int K : {0, 3}) {
        Rng rng(7 + K, 0);
        const int C = 6, H = 16, L = 8, N = 10;
        const BranchMlp<double> F = make_decoder(C, H, L, rng);
        BranchMlp<double> Q = make_query_net(C, H, L, K, rng);
        MatrixXd qg, t, codes;
        int redraws = 0;
        for (;;) {
            qg = randn(3, N, rng, 0.3);
            t = qg + randn(3, N, rng, 0.05);
            codes = MatrixXd::Zero(K, K ? N : 0);
            for (int i = 0; K && i < N; ++i) codes(i % K, i) = 1.0;
            nnref::Kinks k;
            nnref::stage2_loss(Q, F, qg, t, codes, &k);
            if (k.min_abs >= 10 * kEps) break;
            ++redraws;
        }
        CHECK(redraws <= 3);
        Stage2Workspace<double> ws(Q.shape, F.shape, N);
        VectorXd dQ(Q.layout.size());
        const double L0 = ws.loss_and_grad(Q, F, qg, t, codes, dQ);
        auto loss = [&](nnref::Kinks* k) { return nnref::stage2_loss(Q, F, qg, t, codes, k); };
        CHECK(std::abs(L0 - loss(nullptr)) < 1e-12);
        CHECK(std::abs(ws.loss(Q, F, qg, t, codes) - L0) < 1e-15);
        const auto coords = nnref::sample_coords(Q.layout, kProbes);
        const auto r = nnref::check_gradient(Q.params, dQ, coords, loss, kEps, kTol, kAtol, "dL/dtheta_Q");
        require_check(r, int(coords.size()), "stage 2, K = " + std::to_string(K));
    }
}

TEST_CASE("nn: in the plane (points of dimension 2) stage-1 and stage-2 gradients match finite differences",
          "[nn]") {
    // The plane demonstration (pcp/demo/demo2d.hpp) runs the same networks with in_a = 2.
    const int D = 2, C = 6, H = 16, L = 4, N = 10, M = 8;
    Rng rng(21, 0);
    PointNet<double> E = make_encoder(pointnet_shape(C, 32, 16, D), rng);
    BranchMlp<double> F(decoder_shape(C, H, L, D));
    init_decoder_geometric(F, rng);
    for (int l = 0; l < F.layout.num_layers(); ++l)
        for (int i = 0; i < F.layout.rows(l); ++i) F.b(l)(i, 0) += rng.normal(0.0, 0.05);
    BranchMlp<double> Q(query_net_shape(C, H, L, 0, D));
    REQUIRE(Q.shape.in_a == D);
    REQUIRE(Q.shape.out == D + C);
    init_query_net(Q, rng, false);
    for (int l = 0; l < Q.layout.num_layers(); ++l)
        for (int i = 0; i < Q.layout.rows(l); ++i) Q.b(l)(i, 0) += rng.normal(0.0, 0.05);
    Q.W(layer_head(Q.shape)).topRows(D) *= 0.1;
    MatrixXd points, q, t;
    int redraws = 0;
    for (;;) {  // points on a circle of radius 0.3, queries around them, t = the nearest point
        points = randn(D, M, rng);
        for (int j = 0; j < M; ++j) points.col(j) *= 0.3 / points.col(j).norm();
        q.resize(D, N);
        t.resize(D, N);
        for (int i = 0; i < N; ++i) {
            q.col(i) = points.col(i % M) + randn(D, 1, rng, 0.05);
            Eigen::Index best;
            (points.colwise() - q.col(i)).colwise().squaredNorm().minCoeff(&best);
            t.col(i) = points.col(best);
        }
        nnref::Kinks k1, k2;
        nnref::stage1_loss(E, F, q, t, points, &k1);
        nnref::stage2_loss(Q, F, q, t, MatrixXd(), &k2);
        if (std::min(k1.min_abs, k2.min_abs) >= 10 * kEps) break;
        ++redraws;
    }
    CHECK(redraws <= 5);
    // Stage 1: decoder and encoder.
    Stage1Workspace<double> ws1(E.shape, F.shape, N, M);
    VectorXd dE(E.layout.size()), dF(F.layout.size());
    const double L1 = ws1.loss_and_grad(E, F, q, t, points, dE, dF);
    auto loss1 = [&](nnref::Kinks* k) { return nnref::stage1_loss(E, F, q, t, points, k); };
    CHECK(std::abs(L1 - loss1(nullptr)) < 1e-12);
    const auto cf = nnref::sample_coords(F.layout, kProbes);
    const auto ce = nnref::sample_coords(E.layout, kProbes);
    require_check(nnref::check_gradient(F.params, dF, cf, loss1, kEps, kTol, kAtol, "dL/dtheta_F"), int(cf.size()),
                  "2D stage 1 decoder");
    require_check(nnref::check_gradient(E.params, dE, ce, loss1, kEps, kTol, kAtol, "dL/dtheta_E"), int(ce.size()),
                  "2D stage 1 encoder");
    // Stage 2: Q through the frozen F.
    Stage2Workspace<double> ws2(Q.shape, F.shape, N);
    VectorXd dQ(Q.layout.size());
    const MatrixXd no_codes;
    const double L2 = ws2.loss_and_grad(Q, F, q, t, no_codes, dQ);
    auto loss2 = [&](nnref::Kinks* k) { return nnref::stage2_loss(Q, F, q, t, no_codes, k); };
    CHECK(std::abs(L2 - loss2(nullptr)) < 1e-12);
    const auto cq = nnref::sample_coords(Q.layout, kProbes);
    require_check(nnref::check_gradient(Q.params, dQ, cq, loss2, kEps, kTol, kAtol, "dL/dtheta_Q"), int(cq.size()),
                  "2D stage 2");
    // A 3D query network does not fit a 2D decoder.
    CHECK_THROWS_AS(Stage2Workspace<double>(query_net_shape(C, H, L), F.shape, N), pcp::Error);
}

TEST_CASE("nn: pull loss derivatives match finite differences, p == t gives no NaN", "[nn]") {
    Rng rng(9, 0);
    const int N = 6;
    const MatrixXd q = randn(3, N, rng), t = randn(3, N, rng), g = randn(3, N, rng);
    const MatrixXd s = randn(1, N, rng);
    VectorXd lam(N);
    MatrixXd v(3, N);
    pull_loss<double>(q, s, g, t, lam, v);
    VectorXd no_lam(0);
    MatrixXd no_v(3, 0);
    auto L_of = [&](const MatrixXd& s_, const MatrixXd& g_) {
        return pull_loss<double>(q, s_, g_, t, no_lam, no_v);
    };
    for (int i = 0; i < N; ++i) {
        MatrixXd sp = s, sm = s;
        sp(0, i) += kEps;
        sm(0, i) -= kEps;
        CHECK(std::abs((L_of(sp, g) - L_of(sm, g)) / (2 * kEps) - lam(i)) <
              1e-6 * std::abs(lam(i)) + kAtol);
        for (int d = 0; d < 3; ++d) {
            MatrixXd gp = g, gm = g;
            gp(d, i) += kEps;
            gm(d, i) -= kEps;
            CHECK(std::abs((L_of(s, gp) - L_of(s, gm)) / (2 * kEps) - v(d, i)) <
                  1e-6 * std::abs(v(d, i)) + kAtol);
        }
    }
    // A query pulled exactly onto its target: loss 0, derivatives 0, no NaN.
    MatrixXd q1(3, 1), s1(1, 1), g1(3, 1), t1(3, 1);
    q1 << 0.5, 0, 0;
    s1 << 0.25;
    g1 << 2, 0, 0;  // |g| = 2 (+1e-12): p = q - 0.25 * (1, 0, 0) = (0.25, 0, 0)
    t1 << 0.25, 0, 0;
    VectorXd lam1(1);
    MatrixXd v1(3, 1);
    const double L1 = pull_loss<double>(q1, s1, g1, t1, lam1, v1);
    CHECK(L1 < 1e-12);
    CHECK(std::isfinite(lam1(0)));
    CHECK(v1.allFinite());
}

// ------------------------------------------------------------------------------------------------
// Stage-2 ablations (Stage2Config): per-query double backprop of F, F trained with Q, a free code
// ------------------------------------------------------------------------------------------------

namespace {

/// Reference loss of any stage-2 configuration (per sample, loops): Q(q_g [, code]) -> rows;
/// q_l' and f' formed as Stage2Config says; pulled from q_g with s, g of F at (q_l', f').
double stage2_loss_cfg(const BranchMlp<double>& Q, const BranchMlp<double>& F, const MatrixXd& qg,
                       const MatrixXd& t, const MatrixXd& cond, const Stage2Config& cfg,
                       nnref::Kinks* k) {
    const int C = F.shape.in_b;
    double sum = 0.0;
    for (Eigen::Index i = 0; i < qg.cols(); ++i) {
        const nnref::Trace tq = nnref::forward(Q, qg.col(i), VectorXd(), k);
        VectorXd ql = qg.col(i);
        int row = 0;
        if (cfg.point == QueryPoint::Shift) ql += tq.out.head(3);
        if (cfg.point == QueryPoint::Direct) ql = tq.out.head(3);
        if (cfg.point != QueryPoint::Identity) row = 3;
        VectorXd f;
        switch (cfg.condition) {
            case QueryCondition::Predicted: f = tq.out.segment(row, C); break;
            case QueryCondition::FreeCode: f = cond.col(0); break;
            case QueryCondition::Given: f = cond.col(i); break;
        }
        const nnref::Trace tf = nnref::forward(F, ql, f, k);
        VectorXd ga, gb;
        nnref::input_grad(F, tf, ga, gb);
        sum += nnref::pull_one(qg.col(i), tf.out(0), ga, t.col(i));
    }
    return sum / double(qg.cols());
}

/// The per-query-condition loss of F alone: mean_i |q_i - s_i g_i/|g_i| - t_i| with
/// s_i = F(q_i, f_i) (the quantity decoder_double_backward differentiates).
double per_query_loss(const BranchMlp<double>& F, const MatrixXd& q, const MatrixXd& f,
                      const MatrixXd& t, nnref::Kinks* k) {
    double sum = 0.0;
    for (Eigen::Index i = 0; i < q.cols(); ++i) {
        const nnref::Trace tr = nnref::forward(F, q.col(i), f.col(i), k);
        VectorXd ga, gb;
        nnref::input_grad(F, tr, ga, gb);
        sum += nnref::pull_one(q.col(i), tr.out(0), ga, t.col(i));
    }
    return sum / double(q.cols());
}

std::vector<Eigen::Index> all_coords(Eigen::Index n) {
    std::vector<Eigen::Index> c(static_cast<std::size_t>(n));
    for (Eigen::Index i = 0; i < n; ++i) c[static_cast<std::size_t>(i)] = i;
    return c;
}

}  // namespace

TEST_CASE("nn: double backprop with a per-query condition matches finite differences", "[nn]") {
    for (int H : {16, 32}) {
        Rng rng(40 + H, 0);
        const int C = 6, L = 8, N = 10;
        BranchMlp<double> F = make_decoder(C, H, L, rng);
        MatrixXd q, f, t;
        int redraws = 0;
        for (;;) {
            q = randn(3, N, rng, 0.3);
            f = randn(C, N, rng, 0.5);
            t = q + randn(3, N, rng, 0.05);
            nnref::Kinks k;
            per_query_loss(F, q, f, t, &k);
            if (k.min_abs >= 10 * kEps) break;
            ++redraws;
        }
        CHECK(redraws <= 3);
        BranchMlpCache<double> cache(F.shape, N);
        branch_mlp_forward<double>(F, q, f, cache);
        decoder_input_grad(F, cache, true);
        VectorXd lam(N);
        MatrixXd v(3, N);
        const double L0 = pull_loss<double>(q, cache.out.leftCols(N), cache.g_a.leftCols(N), t, lam, v);
        CHECK(std::abs(L0 - per_query_loss(F, q, f, t, nullptr)) < 1e-12);
        VectorXd dF(F.layout.size()), df(C * N), df_sum(C), dF2(F.layout.size());
        decoder_double_backward<double>(F, cache, q, f, lam, v, dF, df, GradMode::Overwrite);
        // The summed form and Accumulate mode agree with the per-query form.
        decoder_double_backward<double>(F, cache, q, f, lam, v, dF2, df_sum, GradMode::Overwrite);
        CHECK((Eigen::Map<const MatrixXd>(df.data(), C, N).rowwise().sum() - df_sum).norm() < 1e-12);
        decoder_double_backward<double>(F, cache, q, f, lam, v, dF2, df_sum, GradMode::Accumulate);
        CHECK((dF2 - 2 * dF).norm() < 1e-12 * dF.norm());

        auto loss_theta = [&](nnref::Kinks* k) { return per_query_loss(F, q, f, t, k); };
        const auto cf = nnref::sample_coords(F.layout, kProbes);
        const auto rF = nnref::check_gradient(F.params, dF, cf, loss_theta, kEps, kTol, kAtol, "dL/dtheta_F");
        require_check(rF, int(cf.size()), "per-query double backprop, H = " + std::to_string(H));
        // dL/df per query (the path into a predicted f').
        VectorXd fx = Eigen::Map<const VectorXd>(f.data(), f.size());
        auto loss_f = [&](nnref::Kinks* k) {
            return per_query_loss(F, q, Eigen::Map<const MatrixXd>(fx.data(), C, N), t, k);
        };
        const auto cfx = all_coords(fx.size());
        const auto rf = nnref::check_gradient(fx, df, cfx, loss_f, kEps, kTol, kAtol, "dL/df");
        require_check(rf, int(cfx.size()), "per-query dL/df, H = " + std::to_string(H));
    }
    // Without d_0b (input gradient swept without want_b) the per-query pass refuses to run.
    Rng rng(49, 0);
    const BranchMlp<double> F = make_decoder(4, 16, 8, rng);
    BranchMlpCache<double> cache(F.shape, 4);
    const MatrixXd q = randn(3, 4, rng), f = randn(4, 4, rng);
    branch_mlp_forward<double>(F, q, f, cache);
    decoder_input_grad(F, cache, false);
    VectorXd dF(F.layout.size()), none(0), lam = VectorXd::Ones(4);
    CHECK_THROWS_WITH(decoder_double_backward<double>(F, cache, q, f, lam, MatrixXd::Zero(3, 4), dF,
                                                      none, GradMode::Overwrite),
                      Catch::Contains("want_b = true"));
}

TEST_CASE("nn: stage-2 ablation gradients (Q, F, free code) match finite differences", "[nn]") {
    struct Variant {
        const char* name;
        Stage2Config cfg;
        bool plain_init;  // geometric initialisation as is (the no-prior start), no bias noise
    };
    std::vector<Variant> variants;
    auto add = [&](const char* name, QueryPoint p, QueryCondition c, bool train, bool plain) {
        Stage2Config cfg;
        cfg.point = p;
        cfg.condition = c;
        cfg.train_decoder = train;
        variants.push_back({name, cfg, plain});
    };
    add("method", QueryPoint::Shift, QueryCondition::Predicted, false, false);
    add("no-shift", QueryPoint::Identity, QueryCondition::Predicted, false, false);
    add("direct", QueryPoint::Direct, QueryCondition::Predicted, false, false);
    add("free-code", QueryPoint::Shift, QueryCondition::FreeCode, false, false);
    add("given", QueryPoint::Shift, QueryCondition::Given, false, false);
    add("tune-prior", QueryPoint::Shift, QueryCondition::Predicted, true, false);
    add("no-prior", QueryPoint::Shift, QueryCondition::Predicted, true, true);
    add("free-code + F", QueryPoint::Shift, QueryCondition::FreeCode, true, false);
    add("given + F", QueryPoint::Shift, QueryCondition::Given, true, false);
    int seed = 60;
    for (const Variant& var : variants) {
        INFO("variant " << var.name);
        Rng rng(++seed, 0);
        const int C = 6, H = 16, L = 8, N = 10;
        BranchMlp<double> F = make_decoder(C, H, L, rng);
        if (var.plain_init) init_decoder_geometric(F, rng);
        BranchMlp<double> Q(stage2_query_shape(var.cfg, C, H, L));
        init_query_net(Q, rng, false);
        for (int l = 0; l < Q.layout.num_layers(); ++l)
            for (int i = 0; i < Q.layout.rows(l); ++i) Q.b(l)(i, 0) += rng.normal(0.0, 0.05);
        if (var.cfg.point == QueryPoint::Shift) Q.W(layer_head(Q.shape)).topRows(3) *= 0.1;
        if (var.cfg.point == QueryPoint::Direct) Q.W(layer_head(Q.shape)).topRows(3) *= 0.3;
        MatrixXd qg, t, cond;
        int redraws = 0;
        for (;;) {
            qg = randn(3, N, rng, 0.3);
            t = qg + randn(3, N, rng, 0.05);
            if (var.cfg.condition == QueryCondition::FreeCode) cond = randn(C, 1, rng, 0.5);
            if (var.cfg.condition == QueryCondition::Given) cond = randn(C, N, rng, 0.5);
            nnref::Kinks k;
            stage2_loss_cfg(Q, F, qg, t, cond, var.cfg, &k);
            if (k.min_abs >= 10 * kEps) break;
            ++redraws;
        }
        CHECK(redraws <= 3);
        Stage2Workspace<double> ws(Q.shape, F.shape, N, var.cfg);
        VectorXd dQ(Q.layout.size()), dF(var.cfg.train_decoder ? F.layout.size() : 0),
            dc(var.cfg.condition == QueryCondition::FreeCode ? C : 0);
        const MatrixXd none;
        const double L0 = ws.loss_and_grad(Q, F, qg, t, none, cond, dQ, dF, dc);
        auto loss = [&](nnref::Kinks* k) { return stage2_loss_cfg(Q, F, qg, t, cond, var.cfg, k); };
        CHECK(std::abs(L0 - loss(nullptr)) < 1e-12);
        CHECK(std::abs(ws.loss(Q, F, qg, t, none, cond) - L0) < 1e-15);
        // The field used for meshing is the one trained.
        GlobalSdfCache<double> ec(Q.shape, F.shape, N);
        const MatrixXd s = global_sdf_eval<double>(Q, F, qg, none, cond, var.cfg, ec);
        CHECK((s - ws.dec.out.leftCols(N)).cwiseAbs().maxCoeff() == 0.0);

        const auto cq = nnref::sample_coords(Q.layout, kProbes);
        const auto rQ = nnref::check_gradient(Q.params, dQ, cq, loss, kEps, kTol, kAtol, "dL/dtheta_Q");
        require_check(rQ, int(cq.size()), std::string(var.name) + ": dL/dtheta_Q");
        if (var.cfg.train_decoder) {
            const auto cf = nnref::sample_coords(F.layout, kProbes);
            const auto rF = nnref::check_gradient(F.params, dF, cf, loss, kEps, kTol, kAtol, "dL/dtheta_F");
            require_check(rF, int(cf.size()), std::string(var.name) + ": dL/dtheta_F");
        }
        if (var.cfg.condition == QueryCondition::FreeCode) {
            VectorXd code = cond.col(0);
            auto loss_code = [&](nnref::Kinks* k) {
                return stage2_loss_cfg(Q, F, qg, t, code, var.cfg, k);
            };
            const auto cc = all_coords(C);
            const auto rc = nnref::check_gradient(code, dc, cc, loss_code, kEps, kTol, kAtol, "dL/dcode");
            require_check(rc, C, std::string(var.name) + ": dL/dcode");
        }
    }
}

