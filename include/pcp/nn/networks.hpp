// The three networks of METHOD.md §2 and their hand-written passes (METHOD.md §4).
//
// Points have dim = 3 coordinates (2 in the plane demonstration, pcp/demo/demo2d.hpp): every "3"
// below is the shape's in_a, and the PointNet's first per-point width.
//
//  * BranchMlp: two input branches (x_a -> H and optional x_b -> H, each ReLU, concatenated to 2H),
//    then L hidden layers of width H each followed by ReLU, then a linear head H -> out.
//      - the local SDF decoder F:   x_a = q (3), x_b = condition f (C), out = 1 (s)
//      - the query network Q:       x_a = q_g (3), x_b = one-hot shape code (K, optional), out = 3 + C
//        (rows 0..2 = shift dq, rows 3.. = condition f')
//  * PointNet: shared per-point MLP (3 -> w_1 -> ... -> w_P, ReLU after each), max-pool over the
//    points of one region, FC head (w_P -> ... -> C, ReLU between, linear output).
//
// Every network is plain data: a shape, a ParamLayout and ONE flat parameter vector; W(l), b(l)
// are Eigen::Map views into it (gradients use the same layout). Passes never modify a network.
// Forward fills a cache sized once for a maximum batch; backward consumes it. Evaluating with one
// cache per thread is therefore thread-safe. Matrices are column-major `features x N`.
//
// Letters: N = queries in the batch, M = points in a region, H = width, L = hidden layers,
// C = condition size, K = number of shape codes.
#pragma once

#include "pcp/nn/common.hpp"
#include "pcp/nn/rng.hpp"

#include <vector>

namespace pcp::nn {

// ------------------------------------------------------------------------------------------------
// Flat parameter layout
// ------------------------------------------------------------------------------------------------

/// Where each dense layer's W (rows x cols, column-major) and b (rows) live in a flat vector:
/// [W_0, b_0, W_1, b_1, ...].
class ParamLayout {
public:
    /// Appends a dense layer; returns its index.
    int add_layer(int rows, int cols);
    int num_layers() const { return static_cast<int>(layers_.size()); }
    int rows(int l) const { return layers_.at(l).rows; }
    int cols(int l) const { return layers_.at(l).cols; }
    Eigen::Index w_offset(int l) const { return layers_.at(l).offset; }
    Eigen::Index b_offset(int l) const {
        return layers_.at(l).offset + Eigen::Index(layers_.at(l).rows) * layers_.at(l).cols;
    }
    /// Total number of scalars.
    Eigen::Index size() const { return size_; }

    template <class S>
    Eigen::Map<Mat<S>> W(S* flat, int l) const {
        return Eigen::Map<Mat<S>>(flat + w_offset(l), rows(l), cols(l));
    }
    template <class S>
    Eigen::Map<const Mat<S>> W(const S* flat, int l) const {
        return Eigen::Map<const Mat<S>>(flat + w_offset(l), rows(l), cols(l));
    }
    /// b as a rows x 1 matrix (so that it can be a gemm operand).
    template <class S>
    Eigen::Map<Mat<S>> b(S* flat, int l) const {
        return Eigen::Map<Mat<S>>(flat + b_offset(l), rows(l), 1);
    }
    template <class S>
    Eigen::Map<const Mat<S>> b(const S* flat, int l) const {
        return Eigen::Map<const Mat<S>>(flat + b_offset(l), rows(l), 1);
    }

    bool operator==(const ParamLayout& o) const;
    bool operator!=(const ParamLayout& o) const { return !(*this == o); }

private:
    struct Entry {
        int rows;
        int cols;
        Eigen::Index offset;
    };
    std::vector<Entry> layers_;
    Eigen::Index size_ = 0;
};

// ------------------------------------------------------------------------------------------------
// Two-branch MLP: the decoder F and the query network Q
// ------------------------------------------------------------------------------------------------

struct BranchMlpShape {
    int in_a = 3;     ///< width of the first input (the query point: 3)
    int in_b = 0;     ///< width of the second branch's input (F: C; Q: K codes); 0 = no branch
    int width = 512;  ///< H, width of the branches and of every hidden layer
    int depth = 8;    ///< L, hidden layers after the (concatenated) branches
    int out = 1;      ///< head outputs (F: 1; Q: 3 + C)
    bool operator==(const BranchMlpShape& o) const {
        return in_a == o.in_a && in_b == o.in_b && width == o.width && depth == o.depth &&
               out == o.out;
    }
};

/// The decoder F: q (dim: 3, or 2 in the plane demonstration) and condition f (C) -> s (1).
BranchMlpShape decoder_shape(int cond, int width = 512, int depth = 8, int dim = 3);
/// The query network Q: q_g (dim) [+ one-hot code (K)] -> (dq (dim), f' (C)).
BranchMlpShape query_net_shape(int cond, int width = 512, int depth = 8, int codes = 0,
                               int dim = 3);

/// Layer indices: 0 = branch a (H x in_a); 1 = branch b (H x in_b, only if in_b > 0); then
/// hidden k = 1..L (hidden 1 is H x 2H with a b-branch, H x H without); then the head (out x H).
inline int layer_branch_a(const BranchMlpShape&) { return 0; }
inline int layer_branch_b(const BranchMlpShape&) { return 1; }
inline int layer_hidden(const BranchMlpShape& s, int k) { return (s.in_b > 0 ? 1 : 0) + k; }
inline int layer_head(const BranchMlpShape& s) { return layer_hidden(s, s.depth) + 1; }

/// A two-branch MLP's parameters (one flat vector).
template <class S>
struct BranchMlp {
    BranchMlpShape shape;
    ParamLayout layout;
    Vec<S> params;  ///< layout.size(), zero after construction (use an init_* function)

    BranchMlp() = default;
    explicit BranchMlp(const BranchMlpShape& shape);

    Eigen::Map<const Mat<S>> W(int l) const { return layout.W(params.data(), l); }
    Eigen::Map<const Mat<S>> b(int l) const { return layout.b(params.data(), l); }
    Eigen::Map<Mat<S>> W(int l) { return layout.W(params.data(), l); }
    Eigen::Map<Mat<S>> b(int l) { return layout.b(params.data(), l); }

    /// A copy with the other scalar type (e.g. a float network checked in double).
    template <class T>
    BranchMlp<T> cast() const {
        BranchMlp<T> r(shape);
        r.params = params.template cast<T>();
        return r;
    }
};

/// Activations and pass buffers of one BranchMlp, sized once for `max_batch` columns. All blocks
/// below are used through `.leftCols(n)` for the current batch n.
template <class S>
struct BranchMlpCache {
    BranchMlpCache() = default;
    /// with_backward = false allocates only what the forward pass needs (SDF evaluation).
    BranchMlpCache(const BranchMlpShape& shape, int max_batch, bool with_backward = true);

    BranchMlpShape shape;
    int max_batch = 0;
    int n = 0;              ///< batch of the last forward pass
    bool shared_b = false;  ///< x_b was one column shared by the whole batch (stage 1)
    bool grad_b = false;    ///< the last decoder_input_grad computed the f-half d_0b (want_b)

    Mat<S> a0;             ///< (H or 2H) x max: [relu(W_a x_a + b_a); relu(W_b x_b + b_b)]
                           ///< (bottom half unused when x_b is shared)
    Mat<S> hb_shared;      ///< H x 1: relu(W_b x_b + b_b) when x_b is shared
    Mat<S> c1_shared;      ///< H x 1: W_1[:, H:] hb_shared + b_1 (the f-half of hidden 1 as a bias)
    std::vector<Mat<S>> a; ///< a[k-1] = a_k = relu(z_k), k = 1..L, each H x max
    Mat<S> out;            ///< out x max, the head's output (F: s; Q: [dq; f'])

    // Backward buffers (empty when with_backward = false).
    std::vector<Mat<S>> delta;  ///< delta[0]: (H or 2H) x max for the branch layer; delta[k]:
                                ///< H x max for hidden k. Input-gradient sweep: ds_dz (METHOD's d_k);
                                ///< parameter backward: dL_dz.
    Mat<S> g_a;                 ///< in_a x max: g = ds/dx_a (F: ds/dq)
    Mat<S> g_b;                 ///< in_b x max: ds/dx_b (F: g_f = ds/df)
    Mat<S> tan0, tan1;          ///< H x max: tangent u_k ping-pong (stage-1 double backprop)
    Mat<S> dL_dout;             ///< out x max: a seed buffer for branch_mlp_backward (stage 2)
    Mat<S> r1, rb;              ///< H x 1 scratch: sum_i lambda_i d_1^(i), its f-branch image
};

/// Forward pass. Writes cache.out.leftCols(N) (and all activations).
/// @param[in] xa  in_a x N (F, Q: query points).
/// @param[in] xb  in_b x N (per query), or in_b x 1 (one column shared by the batch: stage 1's
///                region condition; the b-branch and the f-half of hidden 1 are then computed once),
///                or 0 x 0 when the shape has no b-branch.
template <class S>
void branch_mlp_forward(const BranchMlp<S>& net, const CMatRef<S>& xa, const CMatRef<S>& xb,
                        BranchMlpCache<S>& cache);

/// Input-gradient sweep of a scalar network (out == 1) after branch_mlp_forward (METHOD.md §4,
/// seed 1): d_L = w_o .* m_L, d_{k-1} = (W_k^T d_k) .* m_{k-1}, g = W_a^T d_0a. Fills
/// cache.delta (all d_k), cache.g_a (N columns: g = ds/dq) and, if want_b, cache.g_b (ds/df).
/// Without want_b only the q-half rows of W_1^T d_1 are computed.
template <class S>
void decoder_input_grad(const BranchMlp<S>& net, BranchMlpCache<S>& cache, bool want_b);

/// Ordinary parameter backward after branch_mlp_forward: given dL/dout (out x N), writes the
/// gradient of L w.r.t. all parameters (flat, same layout as net.params). dL/dx_a is not
/// computed (no caller needs it: Q's and F's inputs are data). Uses cache.delta as dL_dz.
/// @param[in]     xa, xb     the inputs given to the forward pass.
/// @param[in]     dL_dout    out x N (may be cache.dL_dout.leftCols(N)).
/// @param[in,out] dL_dtheta  layout.size().
template <class S>
void branch_mlp_backward(const BranchMlp<S>& net, BranchMlpCache<S>& cache, const CMatRef<S>& xa,
                         const CMatRef<S>& xb, const CMatRef<S>& dL_dout, VecRef<S> dL_dtheta,
                         GradMode mode);

/// Double backprop of the pulling loss through the decoder F (METHOD.md §4), after
/// branch_mlp_forward and decoder_input_grad. The loss reaches the weights through s (seed
/// lambda) and through g = ds/dq (seed v): the tangent u_0 = [m_0a .* (W_a v); 0] (zero on the
/// condition branch, f does not move along v) is propagated forward with the same masks,
/// u_k = m_k .* (W_k u_{k-1}), and
///   dL/dW_k = sum_i d_k (lambda_i a_{k-1} + u_{k-1})^T,  dL/db_k = sum_i lambda_i d_k,
///   dL/dw_o = sum_i (lambda_i a_L + u_L),               dL/db_o = sum_i lambda_i,
/// with a_0 = [h_q; h_f] and, for the branches, a_{-1} = q (tangent v) and f (tangent 0):
///   dL/dW_a = D_0a (lambda q + v)^T,  dL/dW_b = D_0b (lambda f)^T   (D_0b = the f-half d_0b).
/// Since u_0b = 0, the condition branch and the f-half of hidden 1 receive gradient through
/// lambda only (their weights move the masks, not the tangent).
///
/// Two condition layouts:
///  * shared (stage 1: one condition per region, f is C x 1): the f-half of hidden 1 is rank
///    one, dL/dW_1b = (D_1 lambda) h_f^T, and the condition branch is one column;
///  * per query (stage 2 with F trained: f is C x N): dL/dW_1b = D_1 (lambda .* H_f)^T and
///    dL/dW_b = (D_0b .* lambda) F^T; needs decoder_input_grad(..., want_b = true) (for D_0b).
/// @param[in]  q          3 x N, F's query input (stage 1: region queries; stage 2: q_l').
/// @param[in]  f          C x 1 (shared) or C x N, as in the forward pass.
/// @param[in]  dL_ds      N, lambda (from pull_loss).
/// @param[in]  dL_dg      3 x N, v (from pull_loss).
/// @param[out] dL_dtheta  F's parameter gradient (layout.size()).
/// @param[out] dL_df      size C: sum_i lambda_i g_f^(i) (the encoder's or a shared code's
///                        gradient); size C x N (per-query layout only, column-major):
///                        lambda_i g_f^(i) per column; size 0: not computed.
template <class S>
void decoder_double_backward(const BranchMlp<S>& net, BranchMlpCache<S>& cache,
                             const CMatRef<S>& q, const CMatRef<S>& f, const CVecRef<S>& dL_ds,
                             const CMatRef<S>& dL_dg, VecRef<S> dL_dtheta, VecRef<S> dL_df,
                             GradMode mode);

/// dL/df = sum_i lambda_i g_f^(i) (C) for a condition column shared by the batch (F frozen, e.g.
/// an auto-decoded code), after branch_mlp_forward (shared f) and decoder_input_grad (either
/// want_b): r_1 = D_1 lambda, r_b = (W_1b^T r_1) .* m_b, dL/df = W_b^T r_b -- O(H N + H^2 + H C)
/// instead of the per-query g_f's O(H C N).
template <class S>
void decoder_shared_condition_grad(const BranchMlp<S>& net, BranchMlpCache<S>& cache,
                                   const CVecRef<S>& dL_ds, VecRef<S> dL_df, GradMode mode);

// ------------------------------------------------------------------------------------------------
// PointNet encoder
// ------------------------------------------------------------------------------------------------

struct PointNetShape {
    std::vector<int> point_widths{3, 1024};      ///< per-point MLP: 3 -> ... (ReLU after each)
    std::vector<int> head_widths{1024, 512, 256};  ///< FC head: pool width -> ... -> C
    int cond() const { return head_widths.back(); }
    bool operator==(const PointNetShape& o) const {
        return point_widths == o.point_widths && head_widths == o.head_widths;
    }
};

/// The release's encoder (dim (3) -> pool_width, max-pool, pool_width -> hidden -> cond).
PointNetShape pointnet_shape(int cond, int pool_width = 1024, int hidden = 512, int dim = 3);

/// Layer indices: per-point layers 0..P-1, then head layers P..P+J-1.
template <class S>
struct PointNet {
    PointNetShape shape;
    ParamLayout layout;
    Vec<S> params;

    PointNet() = default;
    explicit PointNet(const PointNetShape& shape);

    int num_point_layers() const { return int(shape.point_widths.size()) - 1; }
    int num_head_layers() const { return int(shape.head_widths.size()) - 1; }
    Eigen::Map<const Mat<S>> W(int l) const { return layout.W(params.data(), l); }
    Eigen::Map<const Mat<S>> b(int l) const { return layout.b(params.data(), l); }
    Eigen::Map<Mat<S>> W(int l) { return layout.W(params.data(), l); }
    Eigen::Map<Mat<S>> b(int l) { return layout.b(params.data(), l); }

    template <class T>
    PointNet<T> cast() const {
        PointNet<T> r(shape);
        r.params = params.template cast<T>();
        return r;
    }
};

template <class S>
struct PointNetCache {
    PointNetCache() = default;
    PointNetCache(const PointNetShape& shape, int max_points, bool with_backward = true);

    PointNetShape shape;
    int max_points = 0;
    int m = 0;                      ///< points of the last forward pass
    std::vector<Mat<S>> pa;         ///< per-point activations, pa[k]: w_{k+1} x max
    Mat<S> pooled;                  ///< w_P x 1 max-pool
    Eigen::VectorXi argmax;         ///< w_P: the point that won each feature
    std::vector<Mat<S>> ha;         ///< head activations, ha[j]: w_{j+1} x 1; ha.back() = f
    // backward
    std::vector<Mat<S>> hdelta;     ///< dL_dz of the head layers
    Mat<S> dL_dpooled;              ///< w_P x 1
    Mat<S> pdelta0, pdelta1;        ///< max width x max points: per-point dL_dz ping-pong

    /// The condition f (C x 1) of the last forward pass.
    const Mat<S>& f() const { return ha.back(); }
};

/// Forward pass over the points of one region. The condition is cache.f() (C x 1).
/// @param[in] points  3 x M, M >= 1, region coordinates.
template <class S>
void pointnet_forward(const PointNet<S>& net, const CMatRef<S>& points, PointNetCache<S>& cache);

/// Backward from dL/df (C) to all encoder parameters. Through the max-pool only the winning
/// point of each feature receives gradient; the last per-point layer's gradient is therefore
/// accumulated sparsely (O(w_P w_{P-1}) instead of a dense O(w_P w_{P-1} M) GEMM).
template <class S>
void pointnet_backward(const PointNet<S>& net, PointNetCache<S>& cache, const CMatRef<S>& points,
                       const CVecRef<S>& dL_df, VecRef<S> dL_dtheta, GradMode mode);

// ------------------------------------------------------------------------------------------------
// Initialisation (draws in double, then rounds, so float and double copies agree)
// ------------------------------------------------------------------------------------------------

/// Geometric initialisation of the decoder (METHOD.md §2): hidden and branch weights
/// N(0, sqrt(2)/sqrt(H)), zero biases, head weights N(mean, 1e-6), head bias -radius; F starts
/// as (approximately) the SDF of a sphere of `radius`, negative inside, for a zero condition.
/// `output_mean` = 0 picks sqrt(pi)/sqrt(H), the value that gives the sphere with this
/// two-branch layout (measured in test_nn_networks.cpp; METHOD.md quotes the release's
/// 2 sqrt(pi)/sqrt(H), which with our layout gives a sphere of radius/2).
template <class S>
void init_decoder_geometric(BranchMlp<S>& F, Rng& rng, double radius = 0.5,
                            double output_mean = 0.0);

/// He-normal initialisation of the query network (weights N(0, sqrt(2/fan_in)), zero biases;
/// head N(0, sqrt(1/fan_in))). With zero_shift_head the head's dq rows (0..2) start at zero, so
/// that Q initially maps q_l' = q_g.
template <class S>
void init_query_net(BranchMlp<S>& Q, Rng& rng, bool zero_shift_head = true);

/// He-normal initialisation of the encoder (linear output layer: N(0, sqrt(1/fan_in))).
template <class S>
void init_pointnet(PointNet<S>& E, Rng& rng);

}  // namespace pcp::nn
