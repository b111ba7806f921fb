// Tests for the networks' initialisation and numerics (pcp/nn/networks.hpp, steps.hpp): the
// geometric init makes F the SDF of a sphere of radius 0.5; float and double agree on the
// gradients at the paper's sizes; evaluation with one cache per thread matches serial evaluation.
#include "pcp/core/error.hpp"
#include "pcp/nn/networks.hpp"
#include "pcp/nn/steps.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace pcp::nn;
using Eigen::MatrixXd;
using Eigen::MatrixXf;
using Eigen::VectorXd;

namespace {

MatrixXd random_directions(int n, Rng& rng) {
    MatrixXd d(3, n);
    for (int j = 0; j < n; ++j) {
        for (int i = 0; i < 3; ++i) d(i, j) = rng.normal();
        d.col(j).normalize();
    }
    return d;
}

// s along 48 directions at radii 0.1..0.9: the mean of s at r = radius (zero for the sphere),
// the largest s at r <= 0.6 radius and the smallest s at r >= 1.8 radius.
struct SphereStats {
    double mean_at_radius = 0.0;
    double max_inside = -1e9;
    double min_outside = 1e9;
};

SphereStats sphere_stats(const BranchMlp<float>& F, double radius, const MatrixXd& dirs) {
    const int n = int(dirs.cols());
    BranchMlpCache<float> cache(F.shape, n, false);
    const MatrixXf f = MatrixXf::Zero(F.shape.in_b, 1);
    SphereStats st;
    for (double r : {0.6 * radius, radius, 1.8 * radius}) {
        const MatrixXf q = (r * dirs).cast<float>();
        const auto s = decoder_eval<float>(F, q, f, cache);
        if (r == radius) st.mean_at_radius = s.mean();
        if (r < radius) st.max_inside = s.maxCoeff();
        if (r > radius) st.min_outside = s.minCoeff();
    }
    return st;
}

double rel_err(const VectorXd& a, const VectorXd& b) { return (a - b).norm() / b.norm(); }

}  // namespace

TEST_CASE("nn: geometric init makes F the SDF of a sphere of radius 0.5 (negative inside)", "[nn]") {
    Rng rng(21, 0);
    const MatrixXd dirs = random_directions(48, rng);
    BranchMlp<float> F(decoder_shape(256, 512, 8));
    init_decoder_geometric(F, rng);
    // Measured over 8 seeds (H = 512, L = 8, 256 directions): the mean of s on |q| = 0.5 lies in
    // [-0.07, 0.09] and the slope d mean(s)/d|q| in [0.8, 1.2] (a 9-layer random network's gain
    // varies by seed); single directions scatter by about +-0.1 on |q| = 0.5. So F starts as an
    // approximate sphere of radius 0.5, negative inside.
    const SphereStats st = sphere_stats(F, 0.5, dirs);
    INFO("mean s on |q| = 0.5: " << st.mean_at_radius << ", max s at |q| = 0.3: " << st.max_inside
                                 << ", min s at |q| = 0.9: " << st.min_outside);
    CHECK(std::abs(st.mean_at_radius) < 0.12);
    CHECK(st.max_inside < 0.0);
    CHECK(st.min_outside > 0.0);
    // The release's constant 2 sqrt(pi)/sqrt(H) doubles the slope with this layout: s = 2|q| - 0.5,
    // a sphere of radius 0.25, which is why init_decoder_geometric defaults to sqrt(pi)/sqrt(H).
    BranchMlp<float> F2(decoder_shape(256, 512, 8));
    Rng rng2(21, 1);
    init_decoder_geometric(F2, rng2, 0.5, 2.0 * std::sqrt(3.14159265358979 / 512.0));
    const SphereStats st2 = sphere_stats(F2, 0.5, dirs);
    INFO("release constant: mean s on |q| = 0.5: " << st2.mean_at_radius);
    CHECK(st2.mean_at_radius > 0.3);
    CHECK(std::abs(sphere_stats(F2, 0.25, dirs).mean_at_radius) < 0.12);
}

TEST_CASE("nn: float and double agree on the gradients at the paper's sizes", "[nn]") {
    // H = 512, L = 8, C = 256 and 512; small batches so that the test stays fast.
    for (int C : {256, 512}) {
        Rng rng(22, std::uint64_t(C));
        BranchMlp<double> F(decoder_shape(C, 512, 8));
        init_decoder_geometric(F, rng);
        PointNet<double> E(pointnet_shape(C, 1024, 512));
        init_pointnet(E, rng);
        BranchMlp<double> Q(query_net_shape(C, 512, 8));
        init_query_net(Q, rng, false);
        Q.W(layer_head(Q.shape)).topRows(3) *= 0.1;
        const int N = 6, M = 16;
        MatrixXd pts(3, M), q(3, N), t(3, N);
        for (int j = 0; j < M; ++j)
            for (int i = 0; i < 3; ++i) pts(i, j) = rng.normal(0.0, 0.3);
        for (int j = 0; j < N; ++j)
            for (int i = 0; i < 3; ++i) {
                q(i, j) = pts(i, j) + rng.normal(0.0, 0.05);
                t(i, j) = pts(i, j);
            }
        // Stage 1.
        Stage1Workspace<double> wd(E.shape, F.shape, N, M);
        Stage1Workspace<float> wf(E.shape, F.shape, N, M);
        VectorXd dEd(E.layout.size()), dFd(F.layout.size());
        Vec<float> dEf(E.layout.size()), dFf(F.layout.size());
        const double Ld = wd.loss_and_grad(E, F, q, t, pts, dEd, dFd);
        const double Lf = wf.loss_and_grad(E.cast<float>(), F.cast<float>(), q.cast<float>(),
                                           t.cast<float>(), pts.cast<float>(), dEf, dFf);
        INFO("C = " << C << ": stage 1 rel err decoder " << rel_err(dFf.cast<double>(), dFd)
                    << ", encoder " << rel_err(dEf.cast<double>(), dEd));
        CHECK(std::abs(Lf - Ld) <= 1e-4 * Ld);
        CHECK(rel_err(dFf.cast<double>(), dFd) <= 1e-4);
        CHECK(rel_err(dEf.cast<double>(), dEd) <= 1e-4);
        // Per layer as well (a small layer could hide in the total).
        for (int l = 0; l < F.layout.num_layers(); ++l) {
            const auto seg = [&](const auto& v) {
                return VectorXd(v.segment(F.layout.w_offset(l),
                                          F.layout.b_offset(l) + F.layout.rows(l) - F.layout.w_offset(l))
                                    .template cast<double>());
            };
            CHECK(rel_err(seg(dFf), seg(dFd)) <= 1e-4);
        }
        // Stage 2.
        Stage2Workspace<double> sd(Q.shape, F.shape, N);
        Stage2Workspace<float> sf(Q.shape, F.shape, N);
        VectorXd dQd(Q.layout.size());
        Vec<float> dQf(Q.layout.size());
        const MatrixXd no_codes;
        sd.loss_and_grad(Q, F, q, t, no_codes, dQd);
        sf.loss_and_grad(Q.cast<float>(), F.cast<float>(), q.cast<float>(), t.cast<float>(),
                         MatrixXf(), dQf);
        INFO("stage 2 rel err " << rel_err(dQf.cast<double>(), dQd));
        CHECK(rel_err(dQf.cast<double>(), dQd) <= 1e-4);
    }
}

TEST_CASE("nn: SDF evaluation with one cache per thread matches serial evaluation", "[nn]") {
    Rng rng(23, 0);
    BranchMlp<float> F(decoder_shape(16, 32, 4));
    init_decoder_geometric(F, rng);
    BranchMlp<float> Q(query_net_shape(16, 32, 4));
    init_query_net(Q, rng, false);
    const int blocks = 8, n = 50;
    MatrixXf q = MatrixXf::Random(3, blocks * n) * 0.5f;
    MatrixXf serial(1, blocks * n), parallel(1, blocks * n);
    {
        GlobalSdfCache<float> c(Q.shape, F.shape, n);
        for (int b = 0; b < blocks; ++b)
            serial.middleCols(b * n, n) = global_sdf_eval<float>(Q, F, q.middleCols(b * n, n), MatrixXf(), c);
    }
#pragma omp parallel num_threads(2)
    {
        GlobalSdfCache<float> c(Q.shape, F.shape, n);
#pragma omp for
        for (int b = 0; b < blocks; ++b)
            parallel.middleCols(b * n, n) = global_sdf_eval<float>(Q, F, q.middleCols(b * n, n), MatrixXf(), c);
    }
    CHECK(serial == parallel);
}
