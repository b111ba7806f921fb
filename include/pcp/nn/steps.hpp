// The two training steps of PCP on top of the networks, and the evaluation of the SDF.
//
//  * Stage 1 (prior training, METHOD.md eq. 2): PointNet(points of a region) -> f (C x 1);
//    F(q, f) -> s; g = ds/dq; pulling loss -> (lambda, v); double backprop into F and, through
//    dL/df = sum_i lambda_i g_f^(i) and the max-pool, into the encoder.
//  * Stage 2 (query-network fitting, METHOD.md eq. 3-5): Q(q_g [, code]) -> (dq, f');
//    q_l' = q_g + dq; F(q_l', f') -> s, (g_q, g_f) = dF/d(q_l', f'); pulling loss at q_g ->
//    lambda; dL/d(dq) = lambda g_q, dL/df' = lambda g_f; backprop into Q only (F is frozen: no
//    F weight gradient is ever formed).
//
// A *Workspace holds every buffer of one step, sized once (max queries / points); after the first
// step nothing is allocated by libpcp (test_nn_steps.cpp counts allocations). The *Trainer classes
// add Adam, the learning-rate schedule and clipping. Networks passed by const reference are never
// modified. Shapes: q, t, q_g: 3 x N; points: 3 x M; codes: K x N one-hot (or 0 x 0).
#pragma once

#include "pcp/nn/adam.hpp"
#include "pcp/nn/networks.hpp"

#include <cstdint>

namespace pcp::nn {

// ------------------------------------------------------------------------------------------------
// Stage 1
// ------------------------------------------------------------------------------------------------

template <class S>
struct Stage1Workspace {
    Stage1Workspace(const PointNetShape& encoder, const BranchMlpShape& decoder, int max_queries,
                    int max_points);

    /// Loss of one region and the gradients of all encoder and decoder parameters (overwritten).
    /// @param[in]  q        3 x N queries in region coordinates.
    /// @param[in]  t        3 x N their targets (nearest input points).
    /// @param[in]  points   3 x M the encoder's input (the paper: the targets of the region's queries).
    /// @param[out] dL_dE    encoder.layout.size().
    /// @param[out] dL_dF    decoder.layout.size().
    /// @param[in]  test_drop_tangent  TEST ONLY (planted bug, see decoder_double_backward).
    /// @return L = mean |p - t|.
    double loss_and_grad(const PointNet<S>& encoder, const BranchMlp<S>& decoder,
                         const CMatRef<S>& q, const CMatRef<S>& t, const CMatRef<S>& points,
                         VecRef<S> dL_dE, VecRef<S> dL_dF, bool test_drop_tangent = false);

    /// The loss only (forward + input-gradient sweep).
    double loss(const PointNet<S>& encoder, const BranchMlp<S>& decoder, const CMatRef<S>& q,
                const CMatRef<S>& t, const CMatRef<S>& points);

    PointNetCache<S> enc;
    BranchMlpCache<S> dec;
    Vec<S> dL_ds;  ///< N: lambda
    Mat<S> dL_dg;  ///< 3 x N: v
    Vec<S> dL_df;  ///< C
};

// ------------------------------------------------------------------------------------------------
// Stage 2
// ------------------------------------------------------------------------------------------------

template <class S>
struct Stage2Workspace {
    Stage2Workspace(const BranchMlpShape& query_net, const BranchMlpShape& decoder,
                    int max_queries);

    /// Loss of a batch of global queries and the gradient of Q's parameters (overwritten).
    /// @param[in]  q_g    3 x N global queries; t: 3 x N targets.
    /// @param[in]  codes  K x N one-hot shape codes, or 0 x 0 when Q has no code branch.
    /// @param[out] dL_dQ  query_net.layout.size().
    double loss_and_grad(const BranchMlp<S>& query_net, const BranchMlp<S>& decoder,
                         const CMatRef<S>& q_g, const CMatRef<S>& t, const CMatRef<S>& codes,
                         VecRef<S> dL_dQ);

    /// The loss only.
    double loss(const BranchMlp<S>& query_net, const BranchMlp<S>& decoder, const CMatRef<S>& q_g,
                const CMatRef<S>& t, const CMatRef<S>& codes);

    BranchMlpCache<S> qn;   ///< Q's activations; qn.dL_dout holds [lambda g_q; lambda g_f]
    BranchMlpCache<S> dec;  ///< F's activations and input-gradient sweep
    Mat<S> q_local;         ///< 3 x N: q_l' = q_g + dq
    Vec<S> dL_ds;           ///< N: lambda
};

// ------------------------------------------------------------------------------------------------
// Evaluation (thread-safe with one cache per thread)
// ------------------------------------------------------------------------------------------------

/// s = F(q, f) for a batch: returns cache.out.leftCols(N) (1 x N), valid until the next call.
/// @param[in] q  3 x N points; f: C x 1 (shared) or C x N.
template <class S>
Eigen::Block<Mat<S>, 1, Eigen::Dynamic> decoder_eval(const BranchMlp<S>& decoder,
                                                     const CMatRef<S>& q, const CMatRef<S>& f,
                                                     BranchMlpCache<S>& cache);

/// Buffers of global_sdf_eval for one thread.
template <class S>
struct GlobalSdfCache {
    GlobalSdfCache(const BranchMlpShape& query_net, const BranchMlpShape& decoder, int max_batch)
        : qn(query_net, max_batch, false), dec(decoder, max_batch, false), q_local(3, max_batch) {}
    BranchMlpCache<S> qn, dec;
    Mat<S> q_local;
};

/// The global SDF F_g(q_g) = F(q_g + dq, f') with (dq, f') = Q(q_g [, code]) (paper eq. 4):
/// returns 1 x N, valid until the next call with this cache.
template <class S>
Eigen::Block<Mat<S>, 1, Eigen::Dynamic> global_sdf_eval(const BranchMlp<S>& query_net,
                                                        const BranchMlp<S>& decoder,
                                                        const CMatRef<S>& q_g,
                                                        const CMatRef<S>& codes,
                                                        GlobalSdfCache<S>& cache);

// ------------------------------------------------------------------------------------------------
// Trainers: workspace + Adam + schedule + clipping
// ------------------------------------------------------------------------------------------------

struct OptimOptions {
    AdamOptions adam;      ///< beta1 0.9, beta2 0.999, eps 1e-8
    LrSchedule lr;         ///< constant 1e-4 (METHOD.md §3) unless set
    double clip_norm = 0;  ///< global gradient-norm clipping; 0 = off
};

template <class S>
class Stage1Trainer {
public:
    Stage1Trainer(PointNet<S> encoder, BranchMlp<S> decoder, int max_queries, int max_points,
                  OptimOptions options = {});

    /// One step on one region: gradients, clipping, Adam on encoder and decoder.
    /// @return the loss before the update.
    double step(const CMatRef<S>& q, const CMatRef<S>& t, const CMatRef<S>& points);

    PointNet<S> encoder;
    BranchMlp<S> decoder;
    AdamState<S> adam_encoder, adam_decoder;
    std::int64_t steps = 0;  ///< steps taken (the schedule's position)
    OptimOptions options;
    double last_grad_norm = 0;
    Stage1Workspace<S> workspace;
    Vec<S> grad_encoder, grad_decoder;
};

template <class S>
class Stage2Trainer {
public:
    /// The decoder is copied and frozen.
    Stage2Trainer(BranchMlp<S> query_net, BranchMlp<S> decoder, int max_queries,
                  OptimOptions options = {});

    /// One step: gradient into Q, clipping, Adam on Q. codes: K x N or 0 x 0.
    /// @return the loss before the update.
    double step(const CMatRef<S>& q_g, const CMatRef<S>& t, const CMatRef<S>& codes);

    BranchMlp<S> query_net;
    const BranchMlp<S> decoder;
    AdamState<S> adam_query;
    std::int64_t steps = 0;
    OptimOptions options;
    double last_grad_norm = 0;
    Stage2Workspace<S> workspace;
    Vec<S> grad_query;
};

}  // namespace pcp::nn
