// Forward passes, the input-gradient sweep, parameter backward, the double backprop of the
// pulling loss (METHOD.md §4; shared condition in stage 1, per-query condition when stage 2 trains
// F) and the initialisations of the networks in pcp/nn/networks.hpp.
//
// Letters: N = batch, H = width, L = hidden layers, C = condition size. Buffers are column-major
// `features x N`; `.leftCols(n)` selects the current batch inside a cache sized for the maximum.
//
// FLOPs skipped on purpose (the method does not need them), so the benchmark counts only these:
//  * shared condition (stage 1: one f per region): the f-branch W_f f + b_f and the f-half of
//    hidden 1, W_1[:, H:] h_f, are one column, folded into a bias (c1_shared) -> hidden 1 costs
//    H x H per query instead of H x 2H;
//  * the input-gradient sweep computes only the q-half rows of W_1^T d_1 unless ds/df per query
//    is asked for (stage 2);
//  * the tangent is zero on the condition branch, so hidden 1's tangent product uses only the
//    q-half columns of W_1, and the f-half weight gradient is rank one: (D_1 lambda) h_f^T;
//  * a per-query condition (stage 2 with F trained, an ablation) costs the double backprop two
//    more GEMMs (dL/dW_1b and dL/dW_b); only that path pays them;
//  * an auto-decoded code (one condition column, F frozen) gets sum_i lambda_i g_f^(i) from
//    D_1 lambda (O(H^2)) instead of the per-query g_f (O(H C N));
//  * dL/dx is never formed at a network's first layer (inputs are data).
#include "pcp/nn/networks.hpp"

#include "pcp/core/error.hpp"
#include "pcp/nn/gemm.hpp"
#include "pcp/nn/layers.hpp"
#include "nn/planted_bug.hpp"

#include <algorithm>
#include <cmath>
#include <type_traits>
#include <utility>

namespace pcp::nn {

// ------------------------------------------------------------------------------------------------
// ParamLayout
// ------------------------------------------------------------------------------------------------

int ParamLayout::add_layer(int rows, int cols) {
    PCP_CHECK(rows > 0 && cols > 0,
              "nn::ParamLayout: a layer needs positive sizes, got " << rows << "x" << cols);
    layers_.push_back({rows, cols, size_});
    size_ += Eigen::Index(rows) * cols + rows;
    return num_layers() - 1;
}

bool ParamLayout::operator==(const ParamLayout& o) const {
    if (layers_.size() != o.layers_.size()) return false;
    for (std::size_t i = 0; i < layers_.size(); ++i)
        if (layers_[i].rows != o.layers_[i].rows || layers_[i].cols != o.layers_[i].cols)
            return false;
    return true;
}

// ------------------------------------------------------------------------------------------------
// Shapes and construction
// ------------------------------------------------------------------------------------------------

BranchMlpShape decoder_shape(int cond, int width, int depth, int dim) {
    return BranchMlpShape{dim, cond, width, depth, 1};
}

BranchMlpShape query_net_shape(int cond, int width, int depth, int codes, int dim) {
    return BranchMlpShape{dim, codes, width, depth, dim + cond};
}

PointNetShape pointnet_shape(int cond, int pool_width, int hidden, int dim) {
    PointNetShape s;
    s.point_widths = {dim, pool_width};
    s.head_widths = {pool_width, hidden, cond};
    return s;
}

namespace {

void check_shape(const BranchMlpShape& s) {
    PCP_CHECK(s.in_a > 0 && s.in_b >= 0 && s.width > 0 && s.depth >= 1 && s.out > 0,
              "nn::BranchMlp: invalid shape (in_a " << s.in_a << ", in_b " << s.in_b << ", width "
                                                    << s.width << ", depth " << s.depth
                                                    << ", out " << s.out << ")");
}

ParamLayout make_layout(const BranchMlpShape& s) {
    check_shape(s);
    ParamLayout lay;
    const int H = s.width;
    lay.add_layer(H, s.in_a);
    if (s.in_b > 0) lay.add_layer(H, s.in_b);
    lay.add_layer(H, s.in_b > 0 ? 2 * H : H);
    for (int k = 2; k <= s.depth; ++k) lay.add_layer(H, H);
    lay.add_layer(s.out, H);
    return lay;
}

ParamLayout make_layout(const PointNetShape& s) {
    PCP_CHECK(s.point_widths.size() >= 2 && s.head_widths.size() >= 2 &&
                  s.point_widths.front() >= 1 && s.point_widths.back() == s.head_widths.front(),
              "nn::PointNet: invalid shape: the per-point widths must start at the points' "
              "dimension and end at the head's first width, and both need at least two entries");
    ParamLayout lay;
    for (std::size_t k = 1; k < s.point_widths.size(); ++k)
        lay.add_layer(s.point_widths[k], s.point_widths[k - 1]);
    for (std::size_t k = 1; k < s.head_widths.size(); ++k)
        lay.add_layer(s.head_widths[k], s.head_widths[k - 1]);
    return lay;
}

}  // namespace

template <class S>
BranchMlp<S>::BranchMlp(const BranchMlpShape& s)
    : shape(s), layout(make_layout(s)), params(Vec<S>::Zero(layout.size())) {}

template <class S>
PointNet<S>::PointNet(const PointNetShape& s)
    : shape(s), layout(make_layout(s)), params(Vec<S>::Zero(layout.size())) {}

template <class S>
BranchMlpCache<S>::BranchMlpCache(const BranchMlpShape& s, int max_n, bool with_backward)
    : shape(s), max_batch(max_n) {
    check_shape(s);
    PCP_CHECK(max_n >= 1, "nn::BranchMlpCache: max_batch must be >= 1");
    const int H = s.width;
    const int H0 = s.in_b > 0 ? 2 * H : H;
    a0.resize(H0, max_n);
    hb_shared.resize(H, 1);
    c1_shared.resize(H, 1);
    a.assign(s.depth, Mat<S>(H, max_n));
    out.resize(s.out, max_n);
    if (with_backward) {
        delta.resize(s.depth + 1);
        delta[0].resize(H0, max_n);
        for (int k = 1; k <= s.depth; ++k) delta[k].resize(H, max_n);
        g_a.resize(s.in_a, max_n);
        g_b.resize(std::max(s.in_b, 0), max_n);
        tan0.resize(H, max_n);
        tan1.resize(std::max(H, s.in_a), max_n);
        dL_dout.resize(s.out, max_n);
        r1.resize(H, 1);
        rb.resize(H, 1);
    }
}

template <class S>
PointNetCache<S>::PointNetCache(const PointNetShape& s, int max_m, bool with_backward)
    : shape(s), max_points(max_m) {
    make_layout(s);  // validates
    PCP_CHECK(max_m >= 1, "nn::PointNetCache: max_points must be >= 1");
    for (std::size_t k = 1; k < s.point_widths.size(); ++k)
        pa.emplace_back(s.point_widths[k], max_m);
    pooled.resize(s.point_widths.back(), 1);
    argmax.resize(s.point_widths.back());
    for (std::size_t j = 1; j < s.head_widths.size(); ++j) ha.emplace_back(s.head_widths[j], 1);
    if (with_backward) {
        for (std::size_t j = 1; j < s.head_widths.size(); ++j)
            hdelta.emplace_back(s.head_widths[j], 1);
        dL_dpooled.resize(s.point_widths.back(), 1);
        int wmax = 0;
        for (std::size_t k = 1; k + 1 < s.point_widths.size(); ++k)
            wmax = std::max(wmax, s.point_widths[k]);
        if (wmax > 0) {
            pdelta0.resize(wmax, max_m);
            pdelta1.resize(wmax, max_m);
        }
    }
}

// ------------------------------------------------------------------------------------------------
// Two-branch MLP passes
// ------------------------------------------------------------------------------------------------

namespace {

template <class S>
Eigen::Map<const Mat<S>> as_col(const CVecRef<S>& v) {
    return Eigen::Map<const Mat<S>>(v.data(), v.size(), 1);
}

template <class S>
void check_backward_cache(const BranchMlpCache<S>& c, const char* who) {
    PCP_CHECK(!c.delta.empty(), who << ": the cache was built without backward buffers "
                                       "(construct it with with_backward = true)");
}

}  // namespace

template <class S>
void branch_mlp_forward(const BranchMlp<S>& net, const CMatRef<S>& xa, const CMatRef<S>& xb,
                        BranchMlpCache<S>& c) {
    const BranchMlpShape& sh = net.shape;
    const int H = sh.width;
    const Eigen::Index n = xa.cols();
    PCP_CHECK(c.shape == sh, "nn::branch_mlp_forward: the cache was built for another shape");
    PCP_CHECK(xa.rows() == sh.in_a && n >= 1 && n <= c.max_batch,
              "nn::branch_mlp_forward: x_a is " << xa.rows() << "x" << n << ", expected "
                                                << sh.in_a << " x (1.." << c.max_batch << ")");
    if (sh.in_b > 0)
        PCP_CHECK(xb.rows() == sh.in_b && (xb.cols() == n || xb.cols() == 1),
                  "nn::branch_mlp_forward: x_b is " << xb.rows() << "x" << xb.cols()
                                                    << ", expected " << sh.in_b << " x " << n
                                                    << " or " << sh.in_b << " x 1");
    else
        PCP_CHECK(xb.size() == 0, "nn::branch_mlp_forward: this network has no second input");
    c.n = static_cast<int>(n);
    c.shared_b = sh.in_b > 0 && xb.cols() == 1;
    c.grad_b = false;

    // Branches: h_a = relu(W_a x_a + b_a) (H x N); h_b = relu(W_b x_b + b_b).
    auto A0a = c.a0.topRows(H).leftCols(n);
    linear_relu_forward<S>(A0a, xa, net.W(0), net.b(0));
    const int l1 = layer_hidden(sh, 1);
    const auto W1 = net.W(l1);
    if (sh.in_b > 0) {
        if (c.shared_b) {
            // One column for the whole batch; the f-half of hidden 1 becomes a bias (H x 1).
            linear_relu_forward<S>(c.hb_shared, xb, net.W(1), net.b(1));
            c.c1_shared = net.b(l1);
            gemm<S>(c.c1_shared, W1.rightCols(H), c.hb_shared, S(1), S(1));
        } else {
            auto A0b = c.a0.bottomRows(H).leftCols(n);
            linear_relu_forward<S>(A0b, xb, net.W(1), net.b(1));
        }
    }
    // Hidden 1: a_1 = relu(W_1 [h_a; h_b] + b_1).
    auto Z1 = c.a[0].leftCols(n);
    if (sh.in_b == 0) {
        linear_relu_forward<S>(Z1, A0a, W1, net.b(l1));
    } else if (c.shared_b) {
        gemm<S>(Z1, W1.leftCols(H), A0a, S(1), S(0));  // q-half only: H x H per query
        bias_relu<S>(Z1, c.c1_shared);
    } else {
        linear_relu_forward<S>(Z1, c.a0.leftCols(n), W1, net.b(l1));
    }
    // Hidden 2..L.
    for (int k = 2; k <= sh.depth; ++k) {
        auto Z = c.a[k - 1].leftCols(n);
        linear_relu_forward<S>(Z, c.a[k - 2].leftCols(n), net.W(layer_hidden(sh, k)),
                               net.b(layer_hidden(sh, k)));
    }
    // Head (linear).
    linear_forward<S>(c.out.leftCols(n), c.a[sh.depth - 1].leftCols(n), net.W(layer_head(sh)),
                      net.b(layer_head(sh)));
}

template <class S>
void decoder_input_grad(const BranchMlp<S>& net, BranchMlpCache<S>& c, bool want_b) {
    const BranchMlpShape& sh = net.shape;
    const int H = sh.width;
    const int L = sh.depth;
    const Eigen::Index n = c.n;
    PCP_CHECK(sh.out == 1, "nn::decoder_input_grad: needs a scalar network (out == 1), got out = "
                               << sh.out);
    PCP_CHECK(n >= 1, "nn::decoder_input_grad: call branch_mlp_forward first");
    check_backward_cache(c, "nn::decoder_input_grad");
    PCP_CHECK(!want_b || sh.in_b > 0, "nn::decoder_input_grad: no second input to differentiate");

    // Seed ds/ds = 1: d_L = w_o .* m_L (w_o is the 1 x H head row, contiguous).
    const Eigen::Map<const Vec<S>> wo(net.W(layer_head(sh)).data(), H);
    {
        auto D = c.delta[L].leftCols(n);
        const auto A = c.a[L - 1].leftCols(n);
        for (Eigen::Index j = 0; j < n; ++j)
            D.col(j) = (A.col(j).array() > S(0)).select(wo.array(), S(0)).matrix();
    }
    // d_{k-1} = (W_k^T d_k) .* m_{k-1}, k = L..2.
    for (int k = L; k >= 2; --k) {
        auto Dp = c.delta[k - 1].leftCols(n);
        gemm<S>(Dp, net.W(layer_hidden(sh, k)), c.delta[k].leftCols(n), S(1), S(0), Trans::Yes);
        relu_backward<S>(Dp, c.a[k - 2].leftCols(n));
    }
    // Branch layer: d_0 = (W_1^T d_1) .* m_0, split into the q-half (d_0a) and the f-half (d_0b).
    const auto W1 = net.W(layer_hidden(sh, 1));
    const auto D1 = c.delta[1].leftCols(n);
    auto D0a = c.delta[0].topRows(H).leftCols(n);
    if (sh.in_b > 0 && want_b && !c.shared_b) {
        auto D0 = c.delta[0].leftCols(n);
        gemm<S>(D0, W1, D1, S(1), S(0), Trans::Yes);
        relu_backward<S>(D0, c.a0.leftCols(n));
    } else {
        // q-half rows only (stage 1 needs no per-query ds/df).
        gemm<S>(D0a, W1.leftCols(H), D1, S(1), S(0), Trans::Yes);
        relu_backward<S>(D0a, c.a0.topRows(H).leftCols(n));
        if (want_b) {  // shared condition, per-query ds/df asked for
            auto D0b = c.delta[0].bottomRows(H).leftCols(n);
            gemm<S>(D0b, W1.rightCols(H), D1, S(1), S(0), Trans::Yes);
            relu_backward<S>(D0b, c.hb_shared);
        }
    }
    // g = ds/dq = W_a^T d_0a (3 x N); g_f = ds/df = W_b^T d_0b (C x N).
    gemm<S>(c.g_a.leftCols(n), net.W(0), D0a, S(1), S(0), Trans::Yes);
    if (want_b)
        gemm<S>(c.g_b.leftCols(n), net.W(1), c.delta[0].bottomRows(H).leftCols(n), S(1), S(0),
                Trans::Yes);
    c.grad_b = want_b;
}

template <class S>
void branch_mlp_backward(const BranchMlp<S>& net, BranchMlpCache<S>& c, const CMatRef<S>& xa,
                         const CMatRef<S>& xb, const CMatRef<S>& dL_dout, VecRef<S> dL_dtheta,
                         GradMode mode) {
    const BranchMlpShape& sh = net.shape;
    const ParamLayout& lay = net.layout;
    const int H = sh.width;
    const int L = sh.depth;
    const Eigen::Index n = c.n;
    check_backward_cache(c, "nn::branch_mlp_backward");
    PCP_CHECK(n >= 1 && xa.cols() == n && dL_dout.rows() == sh.out && dL_dout.cols() == n &&
                  dL_dtheta.size() == lay.size(),
              "nn::branch_mlp_backward: shapes do not match the last forward pass (N = "
                  << n << "): x_a " << xa.rows() << "x" << xa.cols() << ", dL_dout "
                  << dL_dout.rows() << "x" << dL_dout.cols() << ", dL_dtheta "
                  << dL_dtheta.size());
    S* G = dL_dtheta.data();
    const S beta = mode == GradMode::Overwrite ? S(0) : S(1);

    // Head: dL/dW_o = dL_dout a_L^T, dL/db_o = sum; d_L = (W_o^T dL_dout) .* m_L.
    const int lh = layer_head(sh);
    linear_backward_params<S>(lay.W(G, lh), lay.b(G, lh), dL_dout, c.a[L - 1].leftCols(n),
                              mode);
    linear_backward_input<S>(c.delta[L].leftCols(n), dL_dout, net.W(lh), GradMode::Overwrite);
    relu_backward<S>(c.delta[L].leftCols(n), c.a[L - 1].leftCols(n));
    // Hidden L..2.
    for (int k = L; k >= 2; --k) {
        const int l = layer_hidden(sh, k);
        linear_backward_params<S>(lay.W(G, l), lay.b(G, l), c.delta[k].leftCols(n),
                                  c.a[k - 2].leftCols(n), mode);
        linear_backward_input<S>(c.delta[k - 1].leftCols(n), c.delta[k].leftCols(n), net.W(l),
                                 GradMode::Overwrite);
        relu_backward<S>(c.delta[k - 1].leftCols(n), c.a[k - 2].leftCols(n));
    }
    // Hidden 1 and the branch layer.
    const int l1 = layer_hidden(sh, 1);
    const auto W1 = net.W(l1);
    const auto D1 = c.delta[1].leftCols(n);
    const auto A0a = c.a0.topRows(H).leftCols(n);
    auto D0a = c.delta[0].topRows(H).leftCols(n);
    if (sh.in_b == 0 || !c.shared_b) {
        const auto A0 = c.a0.topRows(sh.in_b > 0 ? 2 * H : H).leftCols(n);
        auto D0 = c.delta[0].topRows(A0.rows()).leftCols(n);
        linear_backward_params<S>(lay.W(G, l1), lay.b(G, l1), D1, A0, mode);
        linear_backward_input<S>(D0, D1, W1, GradMode::Overwrite);
        relu_backward<S>(D0, A0);
        if (sh.in_b > 0)
            linear_backward_params<S>(lay.W(G, 1), lay.b(G, 1),
                                      c.delta[0].bottomRows(H).leftCols(n), xb, mode);
    } else {
        // Shared x_b: its half of hidden 1 saw the same column for every query.
        auto dW1 = lay.W(G, l1);
        linear_backward_params<S>(dW1.leftCols(H), lay.b(G, l1), D1, A0a, mode);
        c.r1.col(0) = D1.rowwise().sum();
        gemm<S>(dW1.rightCols(H), c.r1, c.hb_shared, S(1), beta, Trans::No, Trans::Yes);
        linear_backward_input<S>(D0a, D1, W1.leftCols(H), GradMode::Overwrite);
        relu_backward<S>(D0a, A0a);
        gemm<S>(c.rb, W1.rightCols(H), c.r1, S(1), S(0), Trans::Yes);
        relu_backward<S>(c.rb, c.hb_shared);
        linear_backward_params<S>(lay.W(G, 1), lay.b(G, 1), c.rb, xb, mode);
    }
    // Branch a: parameters only; dL/dx_a is not needed.
    linear_backward_params<S>(lay.W(G, 0), lay.b(G, 0), D0a, xa, mode);
}

namespace {

template <class S>
void add_or_set(Eigen::Map<Mat<S>> dst, const Mat<S>& src, GradMode mode) {
    if (mode == GradMode::Overwrite)
        dst = src;
    else
        dst += src;
}

}  // namespace

namespace detail {
bool& tangent_dropped() {
    thread_local bool dropped = false;
    return dropped;
}
}  // namespace detail

template <class S>
void decoder_double_backward(const BranchMlp<S>& net, BranchMlpCache<S>& c, const CMatRef<S>& q,
                             const CMatRef<S>& f, const CVecRef<S>& dL_ds, const CMatRef<S>& dL_dg,
                             VecRef<S> dL_dtheta, VecRef<S> dL_df, GradMode mode) {
    const BranchMlpShape& sh = net.shape;
    const ParamLayout& lay = net.layout;
    const int H = sh.width;
    const int L = sh.depth;
    const int C = sh.in_b;
    const Eigen::Index n = c.n;
    check_backward_cache(c, "nn::decoder_double_backward");
    PCP_CHECK(sh.out == 1 && sh.in_b > 0,
              "nn::decoder_double_backward: needs the decoder F (out == 1, a condition branch)");
    const bool shared = c.shared_b;
    PCP_CHECK(n >= 1 && q.rows() == sh.in_a && q.cols() == n && f.rows() == C &&
                  f.cols() == (shared ? 1 : n) && dL_ds.size() == n && dL_dg.rows() == sh.in_a &&
                  dL_dg.cols() == n && dL_dtheta.size() == lay.size() &&
                  (dL_df.size() == 0 || dL_df.size() == C || (!shared && dL_df.size() == C * n)),
              "nn::decoder_double_backward: shapes do not match the last forward pass (N = "
                  << n << ", " << (shared ? "shared" : "per-query") << " condition)");
    PCP_CHECK(shared || c.grad_b,
              "nn::decoder_double_backward: a per-query condition needs decoder_input_grad with "
              "want_b = true first (for the f-half d_0b)");
    S* G = dL_dtheta.data();
    const S beta = mode == GradMode::Overwrite ? S(0) : S(1);
    const auto lam = as_col<S>(dL_ds);                  // N x 1
    const auto lam_row = dL_ds.transpose().array();     // 1 x N, for column scaling
    const bool tangent = !detail::tangent_dropped();

    // Branch a (q -> H): tangent u_0a = m_0a .* (W_a v); dL/dW_a = D_0a (lambda q + v)^T,
    // dL/db_a = D_0a lambda.
    const auto A0a = c.a0.topRows(H).leftCols(n);
    const auto D0a = c.delta[0].topRows(H).leftCols(n);
    auto U = c.tan0.leftCols(n);
    gemm<S>(U, net.W(0), dL_dg, S(1), S(0));
    relu_backward<S>(U, A0a);
    {
        auto X = c.tan1.topRows(sh.in_a).leftCols(n);  // scratch, in_a x N
        X = (q.array().rowwise() * lam_row).matrix();
        if (tangent) X += dL_dg;
        gemm<S>(lay.W(G, 0), D0a, X, S(1), beta, Trans::No, Trans::Yes);
        gemm<S>(lay.b(G, 0), D0a, lam, S(1), beta);
    }

    // Hidden 1, W_1 = [W_1a | W_1b] (H x 2H). The tangent on the condition half is zero, so
    // u_1 = m_1 .* (W_1a u_0a) uses the q-half columns only.
    const int l1 = layer_hidden(sh, 1);
    const auto W1 = net.W(l1);
    const auto D1 = c.delta[1].leftCols(n);
    Mat<S>* ucur = &c.tan1;  // holds u_{k-1} at the top of each layer below
    Mat<S>* unext = &c.tan0;
    gemm<S>(ucur->topRows(H).leftCols(n), W1.leftCols(H), U, S(1), S(0));
    relu_backward<S>(ucur->topRows(H).leftCols(n), c.a[0].leftCols(n));
    // B = lambda .* a_0a + u_0a (overwrites u_0a, no longer needed); dL/dW_1a = D_1 B^T.
    U = (A0a.array().rowwise() * lam_row).matrix() + (tangent ? S(1) : S(0)) * U;
    auto dW1 = lay.W(G, l1);
    gemm<S>(dW1.leftCols(H), D1, U, S(1), beta, Trans::No, Trans::Yes);
    // r_1 = D_1 lambda = dL/db_1.
    gemm<S>(c.r1, D1, lam, S(1), S(0));
    add_or_set<S>(lay.b(G, l1), c.r1, mode);
    if (shared) {
        // The condition half is rank one: dL/dW_1b = r_1 h_f^T.
        gemm<S>(dW1.rightCols(H), c.r1, c.hb_shared, S(1), beta, Trans::No, Trans::Yes);
        // Condition branch (f -> H), one column: r_b = (W_1b^T r_1) .* m_b = sum_i lambda_i
        // d_0b^(i); dL/dW_b = r_b f^T, dL/db_b = r_b, dL/df = W_b^T r_b = sum_i lambda_i g_f^(i).
        gemm<S>(c.rb, W1.rightCols(H), c.r1, S(1), S(0), Trans::Yes);
        relu_backward<S>(c.rb, c.hb_shared);
        gemm<S>(lay.W(G, 1), c.rb, f, S(1), beta, Trans::No, Trans::Yes);
        add_or_set<S>(lay.b(G, 1), c.rb, mode);
        if (dL_df.size() > 0) {
            Eigen::Map<Mat<S>> df(dL_df.data(), C, 1);
            gemm<S>(df, net.W(1), c.rb, S(1), beta, Trans::Yes);
        }
    } else {
        // Per-query condition (reusing U, H x N, as scratch):
        // dL/dW_1b = D_1 (lambda .* H_f)^T.
        const auto A0b = c.a0.bottomRows(H).leftCols(n);
        const auto D0b = c.delta[0].bottomRows(H).leftCols(n);
        U = (A0b.array().rowwise() * lam_row).matrix();
        gemm<S>(dW1.rightCols(H), D1, U, S(1), beta, Trans::No, Trans::Yes);
        // Condition branch: dL/dW_b = (D_0b .* lambda) F^T, dL/db_b = D_0b lambda.
        U = (D0b.array().rowwise() * lam_row).matrix();
        gemm<S>(lay.W(G, 1), U, f, S(1), beta, Trans::No, Trans::Yes);
        gemm<S>(c.rb, D0b, lam, S(1), S(0));
        add_or_set<S>(lay.b(G, 1), c.rb, mode);
        if (dL_df.size() == C) {  // sum_i lambda_i g_f^(i) = W_b^T (D_0b lambda)
            Eigen::Map<Mat<S>> df(dL_df.data(), C, 1);
            gemm<S>(df, net.W(1), c.rb, S(1), beta, Trans::Yes);
        } else if (dL_df.size() == C * n) {  // lambda_i g_f^(i) per query
            Eigen::Map<Mat<S>> df(dL_df.data(), C, n);
            if (mode == GradMode::Overwrite)
                df = (c.g_b.leftCols(n).array().rowwise() * lam_row).matrix();
            else
                df += (c.g_b.leftCols(n).array().rowwise() * lam_row).matrix();
        }
    }

    // Hidden 2..L: u_k = m_k .* (W_k u_{k-1}); dL/dW_k = D_k (lambda .* a_{k-1} + u_{k-1})^T;
    // dL/db_k = D_k lambda.
    for (int k = 2; k <= L; ++k) {
        const int l = layer_hidden(sh, k);
        const auto Ak_1 = c.a[k - 2].leftCols(n);
        const auto Dk = c.delta[k].leftCols(n);
        auto Ucur = ucur->topRows(H).leftCols(n);
        auto Unext = unext->topRows(H).leftCols(n);
        gemm<S>(Unext, net.W(l), Ucur, S(1), S(0));
        relu_backward<S>(Unext, c.a[k - 1].leftCols(n));
        Ucur = (Ak_1.array().rowwise() * lam_row).matrix() + (tangent ? S(1) : S(0)) * Ucur;
        gemm<S>(lay.W(G, l), Dk, Ucur, S(1), beta, Trans::No, Trans::Yes);
        gemm<S>(lay.b(G, l), Dk, lam, S(1), beta);
        std::swap(ucur, unext);
    }

    // Head: dL/dw_o = sum_i (lambda_i a_L + u_L) (row 1 x H, contiguous), dL/db_o = sum lambda.
    const int lh = layer_head(sh);
    Eigen::Map<Vec<S>> dwo(lay.W(G, lh).data(), H);
    auto Ucur = ucur->topRows(H).leftCols(n);  // u_L
    Ucur = (c.a[L - 1].leftCols(n).array().rowwise() * lam_row).matrix() +
           (tangent ? S(1) : S(0)) * Ucur;
    if (mode == GradMode::Overwrite)
        dwo.noalias() = Ucur.rowwise().sum();
    else
        dwo.noalias() += Ucur.rowwise().sum();
    const S sum_lam = dL_ds.sum();
    G[lay.b_offset(lh)] = (mode == GradMode::Overwrite ? S(0) : G[lay.b_offset(lh)]) + sum_lam;
}

template <class S>
void decoder_shared_condition_grad(const BranchMlp<S>& net, BranchMlpCache<S>& c,
                                   const CVecRef<S>& dL_ds, VecRef<S> dL_df, GradMode mode) {
    const BranchMlpShape& sh = net.shape;
    const Eigen::Index n = c.n;
    check_backward_cache(c, "nn::decoder_shared_condition_grad");
    PCP_CHECK(sh.out == 1 && sh.in_b > 0 && c.shared_b && n >= 1 && dL_ds.size() == n &&
                  dL_df.size() == sh.in_b,
              "nn::decoder_shared_condition_grad: needs the decoder F run with one condition "
              "column shared by the batch, lambda of size N = " << n << " and dL_df of size C");
    const int H = sh.width;
    gemm<S>(c.r1, c.delta[1].leftCols(n), as_col<S>(dL_ds), S(1), S(0));
    gemm<S>(c.rb, net.W(layer_hidden(sh, 1)).rightCols(H), c.r1, S(1), S(0), Trans::Yes);
    relu_backward<S>(c.rb, c.hb_shared);
    Eigen::Map<Mat<S>> df(dL_df.data(), sh.in_b, 1);
    gemm<S>(df, net.W(1), c.rb, S(1), mode == GradMode::Overwrite ? S(0) : S(1), Trans::Yes);
}

// ------------------------------------------------------------------------------------------------
// PointNet
// ------------------------------------------------------------------------------------------------

template <class S>
void pointnet_forward(const PointNet<S>& net, const CMatRef<S>& points, PointNetCache<S>& c) {
    const Eigen::Index m = points.cols();
    PCP_CHECK(c.shape == net.shape, "nn::pointnet_forward: the cache was built for another shape");
    PCP_CHECK(points.rows() == net.shape.point_widths.front() && m >= 1 && m <= c.max_points,
              "nn::pointnet_forward: points are " << points.rows() << "x" << m << ", expected "
                                                  << net.shape.point_widths.front() << " x (1.."
                                                  << c.max_points << ")");
    c.m = static_cast<int>(m);
    const int P = net.num_point_layers();
    for (int k = 0; k < P; ++k) {
        auto Z = c.pa[k].leftCols(m);
        linear_relu_forward<S>(Z, k == 0 ? points : CMatRef<S>(c.pa[k - 1].leftCols(m)), net.W(k), net.b(k));
    }
    maxpool_forward<S>(c.pooled.col(0), c.argmax, c.pa[P - 1].leftCols(m));
    const int J = net.num_head_layers();
    for (int j = 0; j < J; ++j) {
        linear_forward<S>(c.ha[j], j == 0 ? c.pooled : c.ha[j - 1], net.W(P + j), net.b(P + j));
        if (j + 1 < J) relu_forward<S>(c.ha[j]);
    }
}

template <class S>
void pointnet_backward(const PointNet<S>& net, PointNetCache<S>& c, const CMatRef<S>& points,
                       const CVecRef<S>& dL_df, VecRef<S> dL_dtheta, GradMode mode) {
    const ParamLayout& lay = net.layout;
    const int P = net.num_point_layers();
    const int J = net.num_head_layers();
    const Eigen::Index m = c.m;
    PCP_CHECK(!c.hdelta.empty(), "nn::pointnet_backward: the cache was built without backward "
                                 "buffers (construct it with with_backward = true)");
    PCP_CHECK(m >= 1 && points.cols() == m && dL_df.size() == net.shape.cond() &&
                  dL_dtheta.size() == lay.size(),
              "nn::pointnet_backward: shapes do not match the last forward pass (M = " << m << ")");
    S* G = dL_dtheta.data();

    // Head, J..1: dL/dW = delta h^T, dL/db = delta; delta_prev = (W^T delta) .* m.
    c.hdelta[J - 1].col(0) = dL_df;
    for (int j = J - 1; j >= 0; --j) {
        const Mat<S>& in = j == 0 ? c.pooled : c.ha[j - 1];
        linear_backward_params<S>(lay.W(G, P + j), lay.b(G, P + j), c.hdelta[j], in, mode);
        Mat<S>& target = j == 0 ? c.dL_dpooled : c.hdelta[j - 1];
        linear_backward_input<S>(target, c.hdelta[j], net.W(P + j), GradMode::Overwrite);
        relu_backward<S>(target, in);
    }

    // Max-pool + last per-point layer, sparse: feature r of the pooled vector came from point
    // argmax(r) only, so dL/dz_P is one entry per row. dL/dW_P(r, :) = dz_r a_{P-1}(:, argmax r)^T.
    const int lp = P - 1;
    auto dWp = lay.W(G, lp);
    auto dbp = lay.b(G, lp);
    if (mode == GradMode::Overwrite) {
        dWp.setZero();
        dbp.setZero();
    }
    const auto Wp = net.W(lp);
    const bool has_below = P >= 2;
    const int w_below = has_below ? net.shape.point_widths[P - 1] : 0;
    auto Dbelow = c.pdelta0.topRows(w_below).leftCols(has_below ? m : 0);
    if (has_below) Dbelow.setZero();
    for (Eigen::Index r = 0; r < dWp.rows(); ++r) {
        const S dz = c.dL_dpooled(r, 0);  // already masked by [pooled > 0]
        if (dz == S(0)) continue;
        const int j = c.argmax(r);
        dbp(r, 0) += dz;
        if (has_below) {
            dWp.row(r) += dz * c.pa[P - 2].col(j).transpose();
            Dbelow.col(j) += dz * Wp.row(r).transpose();
        } else {
            dWp.row(r) += dz * points.col(j).transpose();
        }
    }
    // Dense per-point layers below the pool: ordinary backprop, no dL/dpoints.
    if (has_below) {
        Mat<S>* cur = &c.pdelta0;
        Mat<S>* other = &c.pdelta1;
        for (int k = P - 2; k >= 0; --k) {
            const int wk = net.shape.point_widths[k + 1];
            auto D = cur->topRows(wk).leftCols(m);
            relu_backward<S>(D, c.pa[k].leftCols(m));
            if (k == 0) {
                linear_backward_params<S>(lay.W(G, 0), lay.b(G, 0), D, points, mode);
            } else {
                linear_backward_params<S>(lay.W(G, k), lay.b(G, k), D,
                                          c.pa[k - 1].leftCols(m), mode);
                auto Dn = other->topRows(net.shape.point_widths[k]).leftCols(m);
                linear_backward_input<S>(Dn, D, net.W(k), GradMode::Overwrite);
                std::swap(cur, other);
            }
        }
    }
}

// ------------------------------------------------------------------------------------------------
// Initialisation
// ------------------------------------------------------------------------------------------------

namespace {

template <class M>
void fill_normal(M&& W, Rng& rng, double mean, double stddev) {
    for (Eigen::Index j = 0; j < W.cols(); ++j)
        for (Eigen::Index i = 0; i < W.rows(); ++i)
            W(i, j) = static_cast<typename std::decay_t<M>::Scalar>(rng.normal(mean, stddev));
}

}  // namespace

template <class S>
void init_decoder_geometric(BranchMlp<S>& F, Rng& rng, double radius, double output_mean) {
    const BranchMlpShape& sh = F.shape;
    PCP_CHECK(sh.out == 1, "nn::init_decoder_geometric: needs the decoder (out == 1)");
    const double H = sh.width;
    const double sd = std::sqrt(2.0) / std::sqrt(H);
    F.params.setZero();
    for (int l = 0; l < layer_head(sh); ++l) fill_normal(F.W(l), rng, 0.0, sd);
    const double mean = output_mean != 0.0 ? output_mean : std::sqrt(3.14159265358979323846 / H);
    fill_normal(F.W(layer_head(sh)), rng, mean, 1e-6);
    F.b(layer_head(sh))(0, 0) = static_cast<S>(-radius);
}

template <class S>
void init_query_net(BranchMlp<S>& Q, Rng& rng, bool zero_shift_head) {
    const BranchMlpShape& sh = Q.shape;
    Q.params.setZero();
    for (int l = 0; l < Q.layout.num_layers(); ++l) {
        const bool head = l == layer_head(sh);
        const double fan_in = Q.layout.cols(l);
        fill_normal(Q.W(l), rng, 0.0, std::sqrt((head ? 1.0 : 2.0) / fan_in));
    }
    if (zero_shift_head) Q.W(layer_head(sh)).topRows(std::min(sh.in_a, sh.out)).setZero();
}

template <class S>
void init_pointnet(PointNet<S>& E, Rng& rng) {
    E.params.setZero();
    const int last = E.layout.num_layers() - 1;
    for (int l = 0; l <= last; ++l)
        fill_normal(E.W(l), rng, 0.0, std::sqrt((l == last ? 1.0 : 2.0) / E.layout.cols(l)));
}

// ------------------------------------------------------------------------------------------------
// Explicit instantiations
// ------------------------------------------------------------------------------------------------

#define PCP_NN_INSTANTIATE_NETWORKS(S)                                                             \
    template struct BranchMlp<S>;                                                                  \
    template struct BranchMlpCache<S>;                                                             \
    template struct PointNet<S>;                                                                   \
    template struct PointNetCache<S>;                                                              \
    template void branch_mlp_forward<S>(const BranchMlp<S>&, const CMatRef<S>&,                    \
                                        const CMatRef<S>&, BranchMlpCache<S>&);                    \
    template void decoder_input_grad<S>(const BranchMlp<S>&, BranchMlpCache<S>&, bool);            \
    template void branch_mlp_backward<S>(const BranchMlp<S>&, BranchMlpCache<S>&,                  \
                                         const CMatRef<S>&, const CMatRef<S>&, const CMatRef<S>&,  \
                                         VecRef<S>, GradMode);                                     \
    template void decoder_double_backward<S>(const BranchMlp<S>&, BranchMlpCache<S>&,              \
                                             const CMatRef<S>&, const CMatRef<S>&,                 \
                                             const CVecRef<S>&, const CMatRef<S>&, VecRef<S>,      \
                                             VecRef<S>, GradMode);                           \
    template void decoder_shared_condition_grad<S>(const BranchMlp<S>&, BranchMlpCache<S>&,        \
                                                   const CVecRef<S>&, VecRef<S>, GradMode);        \
    template void pointnet_forward<S>(const PointNet<S>&, const CMatRef<S>&, PointNetCache<S>&);   \
    template void pointnet_backward<S>(const PointNet<S>&, PointNetCache<S>&, const CMatRef<S>&,   \
                                       const CVecRef<S>&, VecRef<S>, GradMode);                    \
    template void init_decoder_geometric<S>(BranchMlp<S>&, Rng&, double, double);                  \
    template void init_query_net<S>(BranchMlp<S>&, Rng&, bool);                                    \
    template void init_pointnet<S>(PointNet<S>&, Rng&);
PCP_NN_INSTANTIATE_NETWORKS(float)
PCP_NN_INSTANTIATE_NETWORKS(double)
#undef PCP_NN_INSTANTIATE_NETWORKS

}  // namespace pcp::nn
