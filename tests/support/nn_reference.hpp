// Test helpers for the neural core: plain per-sample reference implementations (loops, double)
// of the networks, the pulling loss and the two stage losses, which also record every ReLU
// pre-activation (its smallest magnitude and the sign pattern, plus the max-pool winners), and a
// central-difference gradient checker that skips coordinates whose perturbation crosses a kink.
// The library's batched GEMM path is checked against these (STYLE.md habits 7 and 8).
#pragma once

#include "pcp/nn/networks.hpp"
#include "pcp/nn/pull_loss.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <string>
#include <vector>

namespace nnref {

using Eigen::MatrixXd;
using Eigen::VectorXd;
using pcp::nn::BranchMlp;
using pcp::nn::PointNet;

/// Records ReLU pre-activations: the smallest |z| and the pattern of signs / argmax winners.
struct Kinks {
    double min_abs = std::numeric_limits<double>::infinity();
    std::vector<int> pattern;
    void relu(double z) {
        min_abs = std::min(min_abs, std::abs(z));
        pattern.push_back(z > 0.0 ? 1 : 0);
    }
    void winner(int j, double margin) {  // max-pool: the winner and its lead over the runner-up
        min_abs = std::min(min_abs, margin);
        pattern.push_back(1000 + j);
    }
};

/// z = W x + b with loops.
inline VectorXd dense(const Eigen::Map<const MatrixXd>& W, const Eigen::Map<const MatrixXd>& b,
                      const VectorXd& x) {
    VectorXd z(W.rows());
    for (Eigen::Index i = 0; i < W.rows(); ++i) {
        double acc = b(i, 0);
        for (Eigen::Index j = 0; j < W.cols(); ++j) acc += W(i, j) * x(j);
        z(i) = acc;
    }
    return z;
}

inline VectorXd relu(const VectorXd& z, Kinks* k) {
    VectorXd a(z.size());
    for (Eigen::Index i = 0; i < z.size(); ++i) {
        if (k) k->relu(z(i));
        a(i) = z(i) > 0.0 ? z(i) : 0.0;
    }
    return a;
}

/// Per-sample forward trace of a BranchMlp.
struct Trace {
    VectorXd a0;              // [h_a; h_b]
    std::vector<VectorXd> a;  // a_1..a_L
    VectorXd out;
};

inline Trace forward(const BranchMlp<double>& net, const VectorXd& xa, const VectorXd& xb,
                     Kinks* k) {
    const auto& sh = net.shape;
    const int H = sh.width;
    Trace tr;
    tr.a0.resize(sh.in_b > 0 ? 2 * H : H);
    tr.a0.head(H) = relu(dense(net.W(0), net.b(0), xa), k);
    if (sh.in_b > 0) tr.a0.tail(H) = relu(dense(net.W(1), net.b(1), xb), k);
    VectorXd x = tr.a0;
    for (int l = 1; l <= sh.depth; ++l) {
        const int li = pcp::nn::layer_hidden(sh, l);
        x = relu(dense(net.W(li), net.b(li), x), k);
        tr.a.push_back(x);
    }
    tr.out = dense(net.W(pcp::nn::layer_head(sh)), net.b(pcp::nn::layer_head(sh)), x);
    return tr;
}

/// Input gradient of a scalar BranchMlp at a traced sample (reverse sweep with loops).
inline void input_grad(const BranchMlp<double>& net, const Trace& tr, VectorXd& g_a,
                       VectorXd& g_b) {
    const auto& sh = net.shape;
    const int H = sh.width;
    auto Wo = net.W(pcp::nn::layer_head(sh));
    VectorXd d(H);
    for (int i = 0; i < H; ++i) d(i) = tr.a.back()(i) > 0.0 ? Wo(0, i) : 0.0;
    for (int l = sh.depth; l >= 1; --l) {
        auto W = net.W(pcp::nn::layer_hidden(sh, l));
        const VectorXd& below = l >= 2 ? tr.a[l - 2] : tr.a0;
        VectorXd dn = VectorXd::Zero(W.cols());
        for (Eigen::Index j = 0; j < W.cols(); ++j) {
            double acc = 0.0;
            for (Eigen::Index i = 0; i < W.rows(); ++i) acc += W(i, j) * d(i);
            dn(j) = below(j) > 0.0 ? acc : 0.0;
        }
        d = dn;
    }
    auto Wa = net.W(0);
    g_a = VectorXd::Zero(sh.in_a);
    for (int j = 0; j < sh.in_a; ++j)
        for (int i = 0; i < H; ++i) g_a(j) += Wa(i, j) * d(i);
    g_b = VectorXd::Zero(sh.in_b);
    if (sh.in_b > 0) {
        auto Wb = net.W(1);
        for (int j = 0; j < sh.in_b; ++j)
            for (int i = 0; i < H; ++i) g_b(j) += Wb(i, j) * d(H + i);
    }
}

/// PointNet forward for one region (points D x M): returns f (C).
inline VectorXd pointnet(const PointNet<double>& net, const MatrixXd& points, Kinks* k) {
    const int P = net.num_point_layers();
    const int wP = net.shape.point_widths.back();
    VectorXd pooled = VectorXd::Constant(wP, -std::numeric_limits<double>::infinity());
    VectorXd second = pooled;
    std::vector<int> win(wP, 0);
    for (Eigen::Index j = 0; j < points.cols(); ++j) {
        VectorXd x = points.col(j);
        for (int l = 0; l < P; ++l) x = relu(dense(net.W(l), net.b(l), x), k);
        for (int r = 0; r < wP; ++r) {
            if (x(r) > pooled(r)) {
                second(r) = pooled(r);
                pooled(r) = x(r);
                win[r] = int(j);
            } else if (x(r) > second(r)) {
                second(r) = x(r);
            }
        }
    }
    if (k)
        for (int r = 0; r < wP; ++r)  // a zero max (all ReLUs off) has no competing winner
            k->winner(pooled(r) > 0.0 ? win[r] : -1,
                      pooled(r) > 0.0 ? pooled(r) - std::max(second(r), 0.0)
                                      : std::numeric_limits<double>::infinity());
    VectorXd h = pooled;
    const int J = net.num_head_layers();
    for (int j = 0; j < J; ++j) {
        h = dense(net.W(P + j), net.b(P + j), h);
        if (j + 1 < J) h = relu(h, k);
    }
    return h;
}

/// |q - s g/|g| - t| for one sample.
inline double pull_one(const VectorXd& q, double s, const VectorXd& g, const VectorXd& t) {
    const double gn = std::sqrt(g.squaredNorm() + pcp::nn::kPullGradEps);
    return (q - s * g / gn - t).norm();
}

/// Stage-1 loss: mean over queries of the pulling distance with f = PointNet(points).
inline double stage1_loss(const PointNet<double>& E, const BranchMlp<double>& F, const MatrixXd& q,
                          const MatrixXd& t, const MatrixXd& points, Kinks* k) {
    const VectorXd f = pointnet(E, points, k);
    double sum = 0.0;
    for (Eigen::Index i = 0; i < q.cols(); ++i) {
        const Trace tr = forward(F, q.col(i), f, k);
        VectorXd ga, gb;
        input_grad(F, tr, ga, gb);
        sum += pull_one(q.col(i), tr.out(0), ga, t.col(i));
    }
    return sum / double(q.cols());
}

/// Stage-2 loss: (dq, f') = Q(q_g [, code]); s, g at q_g + dq; pulled from q_g.
inline double stage2_loss(const BranchMlp<double>& Q, const BranchMlp<double>& F,
                          const MatrixXd& qg, const MatrixXd& t, const MatrixXd& codes, Kinks* k) {
    const int C = F.shape.in_b;
    double sum = 0.0;
    for (Eigen::Index i = 0; i < qg.cols(); ++i) {
        const VectorXd code = codes.size() ? VectorXd(codes.col(i)) : VectorXd();
        const Trace tq = forward(Q, qg.col(i), code, k);
        const VectorXd ql = qg.col(i) + tq.out.head(qg.rows());
        const Trace tf = forward(F, ql, tq.out.tail(C), k);
        VectorXd ga, gb;
        input_grad(F, tf, ga, gb);
        sum += pull_one(qg.col(i), tf.out(0), ga, t.col(i));
    }
    return sum / double(qg.cols());
}

// ------------------------------------------------------------------------------------------------
// Gradient checker
// ------------------------------------------------------------------------------------------------

struct GradCheck {
    int checked = 0;
    int skipped = 0;  ///< perturbation changed a ReLU mask or a max-pool winner
    int failed = 0;
    double max_rel = 0.0;
    std::string report;  ///< the first mismatches, both values
};

/// Central differences on the chosen coordinates of `x` (restored afterwards).
/// loss(kinks) evaluates the loss at the current x and records kinks.
/// Pass: |a - n| <= tol * max(|a|, |n|) + max(atol, fd_noise), where fd_noise =
/// 100 DBL_EPSILON |L| / (2 eps) is the central difference's own round-off (L is evaluated to
/// ~30 ulp; measured: errors up to 1.1e-10 at |L| = 0.05, eps = 1e-6, on gradients of 1e-6).
inline GradCheck check_gradient(VectorXd& x, const VectorXd& analytic,
                                const std::vector<Eigen::Index>& coords,
                                const std::function<double(Kinks*)>& loss, double eps, double tol,
                                double atol, const std::string& what) {
    GradCheck r;
    Kinks base;
    const double L0 = loss(&base);
    atol = std::max(atol, 100.0 * std::numeric_limits<double>::epsilon() * std::abs(L0) / (2.0 * eps));
    for (Eigen::Index c : coords) {
        const double saved = x(c);
        Kinks kp, km;
        x(c) = saved + eps;
        const double lp = loss(&kp);
        x(c) = saved - eps;
        const double lm = loss(&km);
        x(c) = saved;
        if (kp.pattern != base.pattern || km.pattern != base.pattern) {
            ++r.skipped;
            continue;
        }
        ++r.checked;
        const double num = (lp - lm) / (2.0 * eps);
        const double a = analytic(c);
        const double err = std::abs(a - num);
        const double scale = std::max(std::abs(a), std::abs(num));
        if (scale > 0.0) r.max_rel = std::max(r.max_rel, err / std::max(scale, atol / tol));
        if (err > tol * scale + atol) {
            if (r.failed < 8) {
                char buf[200];
                std::snprintf(buf, sizeof buf, "  %s[%ld]: analytic % .12e  numeric % .12e\n",
                              what.c_str(), long(c), a, num);
                r.report += buf;
            }
            ++r.failed;
        }
    }
    return r;
}

/// Up to `per_layer` coordinates of every weight matrix and bias of a layout (evenly spread).
inline std::vector<Eigen::Index> sample_coords(const pcp::nn::ParamLayout& lay, int per_layer) {
    std::vector<Eigen::Index> out;
    for (int l = 0; l < lay.num_layers(); ++l) {
        const Eigen::Index nw = Eigen::Index(lay.rows(l)) * lay.cols(l);
        const Eigen::Index sw = std::max<Eigen::Index>(1, nw / per_layer);
        for (Eigen::Index i = 0; i < nw; i += sw) out.push_back(lay.w_offset(l) + i);
        const Eigen::Index nb = lay.rows(l);
        const Eigen::Index sb = std::max<Eigen::Index>(1, nb / std::max(1, per_layer / 4));
        for (Eigen::Index i = 0; i < nb; i += sb) out.push_back(lay.b_offset(l) + i);
    }
    return out;
}

}  // namespace nnref
