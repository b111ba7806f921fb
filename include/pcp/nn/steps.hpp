// The two training steps of PCP on top of the networks, and the evaluation of the SDF.
//
//  * Stage 1 (prior training, METHOD.md eq. 2): PointNet(points of a region) -> f (C x 1);
//    F(q, f) -> s; g = ds/dq; pulling loss -> (lambda, v); double backprop into F and, through
//    dL/df = sum_i lambda_i g_f^(i) and the max-pool, into the encoder.
//  * Stage 2 (query-network fitting, METHOD.md eq. 3-5): Q(q_g [, code]) -> (dq, f');
//    q_l' = q_g + dq; F(q_l', f') -> s, (g_q, g_f) = dF/d(q_l', f'); pulling loss at q_g ->
//    lambda; dL/d(dq) = lambda g_q, dL/df' = lambda g_f; backprop into Q only (F is frozen: no
//    F weight gradient is ever formed).
//  * Stage 2 variants (Stage2Config, the paper's ablations of tables 9-10): q_l' = q_g (Q predicts
//    no point), or q_l' predicted directly; f' one auto-decoded code shared by the batch, or given
//    per query by the caller (e.g. the frozen encoder's region condition); and F trained together
//    with Q (per-query double backprop of F, decoder_double_backward). Each variant does only
//    the work it needs: the method's default path is the one above, unchanged.
//
// A *Workspace holds every buffer of one step, sized once (max queries / points); after the first
// step nothing is allocated by libpcp (test_nn_steps.cpp counts allocations). The *Trainer classes
// add Adam, the learning-rate schedule and clipping. Networks passed by const reference are never
// modified. Shapes: q, t, q_g: 3 x N; points: 3 x M; codes: K x N one-hot (or 0 x 0). Every 3
// is the networks' point dimension D (the decoder's in_a): 2 in the plane demonstration.
#pragma once

#include "pcp/nn/adam.hpp"
#include "pcp/nn/networks.hpp"

#include <cstdint>
#include <vector>

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
    /// @return L = mean |p - t|.
    double loss_and_grad(const PointNet<S>& encoder, const BranchMlp<S>& decoder,
                         const CMatRef<S>& q, const CMatRef<S>& t, const CMatRef<S>& points,
                         VecRef<S> dL_dE, VecRef<S> dL_dF);

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

/// Where F's query input q_l' comes from in stage 2.
enum class QueryPoint {
    Shift,     ///< q_l' = q_g + dq, dq = Q's rows 0..2 (the method, paper eq. 3)
    Identity,  ///< q_l' = q_g; Q predicts no point ("No dq")
    Direct,    ///< q_l' = Q's rows 0..2 ("Direct q_l'")
};

/// Where F's condition input f' comes from in stage 2.
enum class QueryCondition {
    Predicted,  ///< f' = Q's C rows after the point rows (the method)
    FreeCode,   ///< one trained C-vector shared by all queries (auto-decoding, "No f'")
    Given,      ///< C x N columns supplied by the caller, not trained ("No f' + f_l")
};

struct Stage2Config {
    QueryPoint point = QueryPoint::Shift;
    QueryCondition condition = QueryCondition::Predicted;
    bool train_decoder = false;  ///< F is trained with Q ("No prior", "Tune theta_2 + theta_3")

    /// Q's output rows for condition size C: [point (dim, unless Identity); f' (C, if Predicted)].
    int query_outputs(int C, int dim = 3) const {
        return (point == QueryPoint::Identity ? 0 : dim) + (condition == QueryCondition::Predicted ? C : 0);
    }
    bool is_method() const {
        return point == QueryPoint::Shift && condition == QueryCondition::Predicted && !train_decoder;
    }
};

/// Q's shape for a configuration: q_g (3) [+ one-hot code (K)] -> config.query_outputs(cond).
BranchMlpShape stage2_query_shape(const Stage2Config& config, int cond, int width = 512,
                                  int depth = 8, int codes = 0, int dim = 3);

template <class S>
struct Stage2Workspace {
    Stage2Workspace(const BranchMlpShape& query_net, const BranchMlpShape& decoder,
                    int max_queries, Stage2Config config = {});

    /// The method (default config): loss of a batch of global queries and the gradient of Q's
    /// parameters (overwritten).
    /// @param[in]  q_g    3 x N global queries; t: 3 x N targets.
    /// @param[in]  codes  K x N one-hot shape codes, or 0 x 0 when Q has no code branch.
    /// @param[out] dL_dQ  query_net.layout.size().
    double loss_and_grad(const BranchMlp<S>& query_net, const BranchMlp<S>& decoder,
                         const CMatRef<S>& q_g, const CMatRef<S>& t, const CMatRef<S>& codes,
                         VecRef<S> dL_dQ);

    /// Any configuration.
    /// @param[in]  cond      FreeCode: the code, C x 1; Given: C x N; Predicted: 0 x 0.
    /// @param[out] dL_dQ     query_net.layout.size().
    /// @param[out] dL_dF     decoder.layout.size() if config.train_decoder, else size 0.
    /// @param[out] dL_dcond  FreeCode: C (sum_i lambda_i g_f^(i)); otherwise size 0.
    double loss_and_grad(const BranchMlp<S>& query_net, const BranchMlp<S>& decoder,
                         const CMatRef<S>& q_g, const CMatRef<S>& t, const CMatRef<S>& codes,
                         const CMatRef<S>& cond, VecRef<S> dL_dQ, VecRef<S> dL_dF,
                         VecRef<S> dL_dcond);

    /// The loss only (cond as in loss_and_grad; the first form is the method's).
    double loss(const BranchMlp<S>& query_net, const BranchMlp<S>& decoder, const CMatRef<S>& q_g,
                const CMatRef<S>& t, const CMatRef<S>& codes);
    double loss(const BranchMlp<S>& query_net, const BranchMlp<S>& decoder, const CMatRef<S>& q_g,
                const CMatRef<S>& t, const CMatRef<S>& codes, const CMatRef<S>& cond);

    Stage2Config config;
    BranchMlpCache<S> qn;   ///< Q's activations; qn.dL_dout holds [lambda g_q; lambda g_f]
    BranchMlpCache<S> dec;  ///< F's activations and input-gradient sweep
    Mat<S> q_local;         ///< 3 x N: q_l'
    Vec<S> dL_ds;           ///< N: lambda
    Mat<S> dL_dg;           ///< 3 x N: v (only with train_decoder; 3 x 0 otherwise)
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

/// Buffers of global_sdf_eval for one thread (cond: room for a caller's per-query condition).
template <class S>
struct GlobalSdfCache {
    GlobalSdfCache(const BranchMlpShape& query_net, const BranchMlpShape& decoder, int max_batch)
        : qn(query_net, max_batch, false), dec(decoder, max_batch, false), q_local(decoder.in_a, max_batch) {}
    BranchMlpCache<S> qn, dec;
    Mat<S> q_local;
    Mat<S> cond;  ///< C x max_batch when the caller gathers a Given condition here (sized by it)
};

/// The global SDF F_g(q_g) = F(q_g + dq, f') with (dq, f') = Q(q_g [, code]) (paper eq. 4):
/// returns 1 x N, valid until the next call with this cache.
template <class S>
Eigen::Block<Mat<S>, 1, Eigen::Dynamic> global_sdf_eval(const BranchMlp<S>& query_net,
                                                        const BranchMlp<S>& decoder,
                                                        const CMatRef<S>& q_g,
                                                        const CMatRef<S>& codes,
                                                        GlobalSdfCache<S>& cache);

/// The global SDF of any Stage2Config: F(q_l', f') with q_l' and f' formed as in training
/// (cond: FreeCode C x 1, Given C x N, Predicted 0 x 0).
template <class S>
Eigen::Block<Mat<S>, 1, Eigen::Dynamic> global_sdf_eval(const BranchMlp<S>& query_net,
                                                        const BranchMlp<S>& decoder,
                                                        const CMatRef<S>& q_g,
                                                        const CMatRef<S>& codes,
                                                        const CMatRef<S>& cond,
                                                        const Stage2Config& config,
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
    /// The decoder is copied; it stays frozen unless config.train_decoder. With a FreeCode
    /// condition the code starts at zero: set `code` before the first step (with F's zero
    /// condition biases of the geometric initialisation, a zero code is a dead start -- every
    /// f-branch ReLU is off, so the code's gradient is zero).
    Stage2Trainer(BranchMlp<S> query_net, BranchMlp<S> decoder, int max_queries,
                  OptimOptions options = {}, Stage2Config config = {});

    /// One step: gradients, clipping (over every trained vector), Adam on Q [, F, the code].
    /// codes: K x N or 0 x 0. The first form is for Predicted and FreeCode conditions; the
    /// second takes a Given condition (C x N).
    /// @return the loss before the update.
    double step(const CMatRef<S>& q_g, const CMatRef<S>& t, const CMatRef<S>& codes);
    double step(const CMatRef<S>& q_g, const CMatRef<S>& t, const CMatRef<S>& codes,
                const CMatRef<S>& cond);

    /// The batch parts of the method's step (not in the paper; ours, for speed): with P > 1 parts
    /// each part's loss and gradient are computed on one thread in its own workspace, its
    /// products sequential, and the step takes their query-weighted means, the whole batch's
    /// loss and gradient up to rounding. At the default preset's sizes (width 128, 500 queries)
    /// small products split over threads run at about half the SGEMM rate; parts keep each thread
    /// on its own products (docs/NOTEBOOK.md, "The stage-2 step in batch parts").
    /// 0: one part per thread (Eigen::nbThreads(), as the products), at most one per kMinPartQueries queries; 1: the whole
    /// batch in `workspace` (its products split over the threads). Ablations always take one part. The rounding therefore depends on the thread count.
    int batch_parts = 0;
    static constexpr int kMinPartQueries = 128;
    /// The parts a step on n queries takes (see batch_parts).
    int parts_for(Eigen::Index n) const;

    Stage2Config config;
    BranchMlp<S> query_net;
    BranchMlp<S> decoder;   ///< frozen unless config.train_decoder
    Vec<S> code;            ///< FreeCode: the shared condition f' (C); size 0 otherwise
    AdamState<S> adam_query, adam_decoder, adam_code;  ///< the last two sized only when used
    std::int64_t steps = 0;
    OptimOptions options;
    double last_grad_norm = 0;
    Stage2Workspace<S> workspace;
    Vec<S> grad_query, grad_decoder, grad_code;

private:
    double split_loss_and_grad(const CMatRef<S>& q_g, const CMatRef<S>& t, const CMatRef<S>& codes, int parts);
    std::vector<Stage2Workspace<S>> part_workspaces_;  ///< sized on the first split step
    std::vector<Vec<S>> part_grads_;
    std::vector<double> part_losses_;
};

}  // namespace pcp::nn
