// Stage-1 and stage-2 steps, SDF evaluation and the trainers (see pcp/nn/steps.hpp): flat
// sequences of the network passes, in the order of METHOD.md §3-4.
#include "pcp/nn/steps.hpp"

#include "pcp/core/error.hpp"
#include "pcp/nn/pull_loss.hpp"

#include <omp.h>

#include <algorithm>
#include <exception>
#include <utility>

namespace pcp::nn {

// ------------------------------------------------------------------------------------------------
// Stage 1
// ------------------------------------------------------------------------------------------------

template <class S>
Stage1Workspace<S>::Stage1Workspace(const PointNetShape& e, const BranchMlpShape& d,
                                    int max_queries, int max_points)
    : enc(e, max_points), dec(d, max_queries), dL_ds(max_queries), dL_dg(d.in_a, max_queries),
      dL_df(d.in_b) {
    PCP_CHECK(d.out == 1 && d.in_a == e.point_widths.front() && d.in_b == e.cond(),
              "nn::Stage1Workspace: the decoder must map (D, C) -> 1 with D = the encoder's "
              "point dimension (" << e.point_widths.front() << ") and C = its output size ("
                                  << e.cond() << "), got in_a = " << d.in_a << ", in_b = " << d.in_b);
}

template <class S>
double Stage1Workspace<S>::loss(const PointNet<S>& E, const BranchMlp<S>& F, const CMatRef<S>& q,
                                const CMatRef<S>& t, const CMatRef<S>& points) {
    pointnet_forward(E, points, enc);
    branch_mlp_forward<S>(F, q, enc.f(), dec);
    decoder_input_grad(F, dec, false);
    const Eigen::Index n = q.cols();
    return pull_loss<S>(q, dec.out.leftCols(n), dec.g_a.leftCols(n), t, dL_ds.head(0),
                        dL_dg.leftCols(0));
}

template <class S>
double Stage1Workspace<S>::loss_and_grad(const PointNet<S>& E, const BranchMlp<S>& F,
                                         const CMatRef<S>& q, const CMatRef<S>& t,
                                         const CMatRef<S>& points, VecRef<S> dL_dE,
                                         VecRef<S> dL_dF) {
    const Eigen::Index n = q.cols();
    // Forward: f = PointNet(points) (C x 1); s = F(q, f); g = ds/dq (3 x N).
    pointnet_forward(E, points, enc);
    branch_mlp_forward<S>(F, q, enc.f(), dec);
    decoder_input_grad(F, dec, false);
    // Loss and per-query seeds lambda = dL/ds, v = dL/dg.
    const double L = pull_loss<S>(q, dec.out.leftCols(n), dec.g_a.leftCols(n), t,
                                  dL_ds.head(n), dL_dg.leftCols(n));
    // Decoder: double backprop (through s and g); encoder: dL/df = sum_i lambda_i g_f^(i).
    decoder_double_backward<S>(F, dec, q, enc.f(), dL_ds.head(n), dL_dg.leftCols(n), dL_dF, dL_df,
                               GradMode::Overwrite);
    pointnet_backward<S>(E, enc, points, dL_df, dL_dE, GradMode::Overwrite);
    return L;
}

// ------------------------------------------------------------------------------------------------
// Stage 2
// ------------------------------------------------------------------------------------------------

BranchMlpShape stage2_query_shape(const Stage2Config& config, int cond, int width, int depth,
                                  int codes, int dim) {
    return BranchMlpShape{dim, codes, width, depth, config.query_outputs(cond, dim)};
}

template <class S>
Stage2Workspace<S>::Stage2Workspace(const BranchMlpShape& qs, const BranchMlpShape& d,
                                    int max_queries, Stage2Config cfg)
    : config(cfg), qn(qs, max_queries), dec(d, max_queries), q_local(d.in_a, max_queries),
      dL_ds(max_queries), dL_dg(d.in_a, cfg.train_decoder ? max_queries : 0) {
    const int D = d.in_a;
    PCP_CHECK(d.out == 1 && d.in_b >= 1 && qs.in_a == D &&
                  cfg.query_outputs(d.in_b, D) >= 1 && qs.out == cfg.query_outputs(d.in_b, D),
              "nn::Stage2Workspace: the query network must read " << D << " coordinates and output D + C = "
                  << D + d.in_b << " values for the method, " << cfg.query_outputs(d.in_b, D)
                  << " for this configuration; got " << qs.in_a << " -> " << qs.out);
}

namespace {

/// F's condition input for the configuration (see Stage2Config).
template <class S>
CMatRef<S> stage2_condition(const Stage2Config& cfg, const BranchMlpCache<S>& qn, int C,
                            const CMatRef<S>& cond, Eigen::Index n) {
    switch (cfg.condition) {
        case QueryCondition::Predicted:
            return CMatRef<S>(qn.out.middleRows(cfg.point == QueryPoint::Identity ? 0 : qn.shape.in_a, C).leftCols(n));
        case QueryCondition::FreeCode:
            PCP_CHECK(cond.rows() == C && cond.cols() == 1,
                      "nn::stage 2: the free code must be C x 1 (C = " << C << "), got "
                                                                      << cond.rows() << "x" << cond.cols());
            return cond;
        case QueryCondition::Given:
            PCP_CHECK(cond.rows() == C && cond.cols() == n,
                      "nn::stage 2: the given condition must be C x N = " << C << "x" << n << ", got "
                                                                         << cond.rows() << "x" << cond.cols());
            return cond;
    }
    PCP_FAIL("nn::stage 2: unknown condition source");
}

/// (Q's out) -> q_l' in `q_local`; F forward at (q_l', f'); F's input-gradient sweep.
template <class S>
void stage2_forward(const Stage2Config& cfg, BranchMlpCache<S>& qn, BranchMlpCache<S>& dec,
                    Mat<S>& q_local, const BranchMlp<S>& Q, const BranchMlp<S>& F,
                    const CMatRef<S>& q_g, const CMatRef<S>& codes, const CMatRef<S>& cond,
                    bool with_grad) {
    const Eigen::Index n = q_g.cols();
    const Eigen::Index D = q_g.rows();
    branch_mlp_forward(Q, q_g, codes, qn);
    switch (cfg.point) {
        case QueryPoint::Shift: q_local.leftCols(n) = q_g + qn.out.topRows(D).leftCols(n); break;
        case QueryPoint::Identity: q_local.leftCols(n) = q_g; break;
        case QueryPoint::Direct: q_local.leftCols(n) = qn.out.topRows(D).leftCols(n); break;
    }
    branch_mlp_forward<S>(F, q_local.leftCols(n), stage2_condition<S>(cfg, qn, F.shape.in_b, cond, n), dec);
    if (with_grad) {
        // ds/df per query is needed to train a predicted f', and (as d_0b) for F's per-query
        // double backprop; a shared code's sum needs neither (decoder_shared_condition_grad).
        const bool want_b = cfg.condition == QueryCondition::Predicted ||
                            (cfg.condition == QueryCondition::Given && cfg.train_decoder);
        decoder_input_grad(F, dec, want_b);
    }
}

}  // namespace

template <class S>
double Stage2Workspace<S>::loss(const BranchMlp<S>& Q, const BranchMlp<S>& F, const CMatRef<S>& q_g,
                                const CMatRef<S>& t, const CMatRef<S>& codes) {
    return loss(Q, F, q_g, t, codes, Mat<S>());
}

template <class S>
double Stage2Workspace<S>::loss(const BranchMlp<S>& Q, const BranchMlp<S>& F, const CMatRef<S>& q_g,
                                const CMatRef<S>& t, const CMatRef<S>& codes, const CMatRef<S>& cond) {
    stage2_forward(config, qn, dec, q_local, Q, F, q_g, codes, cond, true);
    const Eigen::Index n = q_g.cols();
    return pull_loss<S>(q_g, dec.out.leftCols(n), dec.g_a.leftCols(n), t, dL_ds.head(0), dec.tan0.leftCols(0));
}

template <class S>
double Stage2Workspace<S>::loss_and_grad(const BranchMlp<S>& Q, const BranchMlp<S>& F,
                                         const CMatRef<S>& q_g, const CMatRef<S>& t,
                                         const CMatRef<S>& codes, VecRef<S> dL_dQ) {
    PCP_CHECK(config.is_method(), "nn::Stage2Workspace: this configuration needs the general "
                                  "loss_and_grad (condition, F and code gradients)");
    return loss_and_grad(Q, F, q_g, t, codes, Mat<S>(), dL_dQ, dL_ds.head(0), dL_ds.head(0));
}

template <class S>
double Stage2Workspace<S>::loss_and_grad(const BranchMlp<S>& Q, const BranchMlp<S>& F,
                                         const CMatRef<S>& q_g, const CMatRef<S>& t,
                                         const CMatRef<S>& codes, const CMatRef<S>& cond,
                                         VecRef<S> dL_dQ, VecRef<S> dL_dF, VecRef<S> dL_dcond) {
    const Eigen::Index n = q_g.cols();
    const int C = F.shape.in_b;
    const bool free_code = config.condition == QueryCondition::FreeCode;
    PCP_CHECK(dL_dF.size() == (config.train_decoder ? F.layout.size() : 0) &&
                  dL_dcond.size() == (free_code ? C : 0),
              "nn::Stage2Workspace: dL_dF must have " << (config.train_decoder ? F.layout.size() : 0)
                                                      << " entries and dL_dcond " << (free_code ? C : 0));
    stage2_forward(config, qn, dec, q_local, Q, F, q_g, codes, cond, true);
    // Pulling loss at q_g (paper eq. 5). Q needs only lambda -- g is piecewise constant in
    // (q_l', f'), so dL/dq_l' = lambda g_q and dL/df' = lambda g_f (METHOD.md §4); F's weights
    // (when trained) also need v = dL/dg.
    const double L = pull_loss<S>(q_g, dec.out.leftCols(n), dec.g_a.leftCols(n), t, dL_ds.head(n),
                                  dL_dg.leftCols(config.train_decoder ? n : 0));
    const auto lam_row = dL_ds.head(n).transpose().array();
    auto seed = qn.dL_dout.leftCols(n);
    int row = 0;
    if (config.point != QueryPoint::Identity) {  // dq or q_l' itself: dq_l'/d(rows 0..D-1) = I
        const int D = F.shape.in_a;
        seed.topRows(D) = (dec.g_a.leftCols(n).array().rowwise() * lam_row).matrix();
        row = D;
    }
    if (config.condition == QueryCondition::Predicted)
        seed.middleRows(row, C) = (dec.g_b.leftCols(n).array().rowwise() * lam_row).matrix();
    branch_mlp_backward<S>(Q, qn, q_g, codes, seed, dL_dQ, GradMode::Overwrite);
    if (config.train_decoder) {
        // F's weights through s and g; a shared code's gradient comes out of the same pass.
        decoder_double_backward<S>(F, dec, q_local.leftCols(n), stage2_condition<S>(config, qn, C, cond, n),
                                   dL_ds.head(n), dL_dg.leftCols(n), dL_dF, dL_dcond, GradMode::Overwrite);
    } else if (free_code) {
        decoder_shared_condition_grad<S>(F, dec, dL_ds.head(n), dL_dcond, GradMode::Overwrite);
    }
    return L;
}

// ------------------------------------------------------------------------------------------------
// Evaluation
// ------------------------------------------------------------------------------------------------

template <class S>
Eigen::Block<Mat<S>, 1, Eigen::Dynamic> decoder_eval(const BranchMlp<S>& F, const CMatRef<S>& q,
                                                     const CMatRef<S>& f,
                                                     BranchMlpCache<S>& cache) {
    PCP_CHECK(F.shape.out == 1, "nn::decoder_eval: needs the decoder (out == 1)");
    branch_mlp_forward(F, q, f, cache);
    return cache.out.template block<1, Eigen::Dynamic>(0, 0, 1, q.cols());
}

template <class S>
Eigen::Block<Mat<S>, 1, Eigen::Dynamic> global_sdf_eval(const BranchMlp<S>& Q,
                                                        const BranchMlp<S>& F,
                                                        const CMatRef<S>& q_g,
                                                        const CMatRef<S>& codes,
                                                        GlobalSdfCache<S>& c) {
    const Eigen::Index n = q_g.cols();
    branch_mlp_forward(Q, q_g, codes, c.qn);
    c.q_local.leftCols(n) = q_g + c.qn.out.topRows(q_g.rows()).leftCols(n);
    return decoder_eval<S>(F, c.q_local.leftCols(n), c.qn.out.bottomRows(F.shape.in_b).leftCols(n),
                           c.dec);
}

template <class S>
Eigen::Block<Mat<S>, 1, Eigen::Dynamic> global_sdf_eval(const BranchMlp<S>& Q,
                                                        const BranchMlp<S>& F,
                                                        const CMatRef<S>& q_g,
                                                        const CMatRef<S>& codes,
                                                        const CMatRef<S>& cond,
                                                        const Stage2Config& config,
                                                        GlobalSdfCache<S>& c) {
    PCP_CHECK(F.shape.out == 1, "nn::global_sdf_eval: needs the decoder (out == 1)");
    stage2_forward(config, c.qn, c.dec, c.q_local, Q, F, q_g, codes, cond, false);
    return c.dec.out.template block<1, Eigen::Dynamic>(0, 0, 1, q_g.cols());
}

// ------------------------------------------------------------------------------------------------
// Trainers
// ------------------------------------------------------------------------------------------------

template <class S>
Stage1Trainer<S>::Stage1Trainer(PointNet<S> e, BranchMlp<S> d, int max_queries, int max_points,
                                OptimOptions o)
    : encoder(std::move(e)), decoder(std::move(d)), adam_encoder(encoder.layout.size()),
      adam_decoder(decoder.layout.size()), options(o),
      workspace(encoder.shape, decoder.shape, max_queries, max_points),
      grad_encoder(encoder.layout.size()), grad_decoder(decoder.layout.size()) {}

template <class S>
double Stage1Trainer<S>::step(const CMatRef<S>& q, const CMatRef<S>& t, const CMatRef<S>& points) {
    const double L =
        workspace.loss_and_grad(encoder, decoder, q, t, points, grad_encoder, grad_decoder);
    last_grad_norm = clip_grad_norm<S>({&grad_encoder, &grad_decoder}, options.clip_norm);
    const double lr = options.lr.at(steps);
    adam_step<S>(encoder.params, grad_encoder, adam_encoder, lr, options.adam);
    adam_step<S>(decoder.params, grad_decoder, adam_decoder, lr, options.adam);
    ++steps;
    return L;
}

template <class S>
Stage2Trainer<S>::Stage2Trainer(BranchMlp<S> qn, BranchMlp<S> d, int max_queries,
                                OptimOptions o, Stage2Config cfg)
    : config(cfg), query_net(std::move(qn)), decoder(std::move(d)),
      code(Vec<S>::Zero(cfg.condition == QueryCondition::FreeCode ? decoder.shape.in_b : 0)),
      adam_query(query_net.layout.size()),
      adam_decoder(cfg.train_decoder ? decoder.layout.size() : 0), adam_code(code.size()),
      options(o), workspace(query_net.shape, decoder.shape, max_queries, cfg),
      grad_query(query_net.layout.size()),
      grad_decoder(cfg.train_decoder ? decoder.layout.size() : 0), grad_code(code.size()) {}

template <class S>
int Stage2Trainer<S>::parts_for(Eigen::Index n) const {
    if (!config.is_method() || n < 2) return 1;
    const Eigen::Index want = batch_parts > 0 ? Eigen::Index(batch_parts)
                                              : std::min<Eigen::Index>(Eigen::nbThreads(), n / kMinPartQueries);
    return int(std::clamp<Eigen::Index>(want, 1, n));
}

template <class S>
double Stage2Trainer<S>::split_loss_and_grad(const CMatRef<S>& q_g, const CMatRef<S>& t,
                                             const CMatRef<S>& codes, int parts) {
    const Eigen::Index n = q_g.cols();
    // Part p holds columns [n p / P, n (p + 1) / P): at most ceil(n / P) <= ceil(max / P) of them
    // (`workspace` is sized for the trainer's max_queries).
    const auto part_start = [n, parts](int p) { return n * p / parts; };
    const int capacity = int((std::max<Eigen::Index>(n, workspace.dL_ds.size()) + parts - 1) / parts);
    if (int(part_workspaces_.size()) < parts || part_workspaces_.front().dL_ds.size() < capacity) {
        part_workspaces_.clear();
        part_grads_.clear();
        for (int p = 0; p < parts; ++p) {
            part_workspaces_.emplace_back(query_net.shape, decoder.shape, capacity, config);
            part_grads_.emplace_back(query_net.layout.size());
        }
        part_losses_.assign(std::size_t(parts), 0.0);
    }
    std::exception_ptr error;
#pragma omp parallel for schedule(static, 1) num_threads(std::min(parts, std::max(1, Eigen::nbThreads())))
    for (int p = 0; p < parts; ++p) {
        const Eigen::Index lo = part_start(p), len = part_start(p + 1) - lo;
        try {
            const CMatRef<S> part_codes = codes.cols() == 0 ? CMatRef<S>(codes) : CMatRef<S>(codes.middleCols(lo, len));
            part_losses_[std::size_t(p)] = part_workspaces_[std::size_t(p)].loss_and_grad(
                query_net, decoder, q_g.middleCols(lo, len), t.middleCols(lo, len), part_codes,
                part_grads_[std::size_t(p)]);
        } catch (...) {
#pragma omp critical(pcp_stage2_parts_error)
            if (!error) error = std::current_exception();
        }
    }
    if (error) std::rethrow_exception(error);
    // Each part's loss and gradient are means over its queries: weighted by its share, in part order.
    double L = 0;
    for (int p = 0; p < parts; ++p) {
        const S w = S(double(part_start(p + 1) - part_start(p)) / double(n));
        L += double(w) * part_losses_[std::size_t(p)];
        if (p == 0)
            grad_query = w * part_grads_[0];
        else
            grad_query += w * part_grads_[std::size_t(p)];
    }
    return L;
}

template <class S>
double Stage2Trainer<S>::step(const CMatRef<S>& q_g, const CMatRef<S>& t,
                              const CMatRef<S>& codes) {
    PCP_CHECK(config.condition != QueryCondition::Given,
              "nn::Stage2Trainer: a Given condition must be passed to step()");
    return step(q_g, t, codes, Eigen::Map<const Mat<S>>(code.data(), code.size(), code.size() ? 1 : 0));
}

template <class S>
double Stage2Trainer<S>::step(const CMatRef<S>& q_g, const CMatRef<S>& t, const CMatRef<S>& codes,
                              const CMatRef<S>& cond) {
    double L;
    if (config.is_method()) {  // the method's path (in batch parts: the same loss and gradient)
        const int parts = parts_for(q_g.cols());
        L = parts > 1 ? split_loss_and_grad(q_g, t, codes, parts)
                      : workspace.loss_and_grad(query_net, decoder, q_g, t, codes, grad_query);
        last_grad_norm = clip_grad_norm<S>({&grad_query}, options.clip_norm);
    } else {
        L = workspace.loss_and_grad(query_net, decoder, q_g, t, codes, cond, grad_query,
                                    grad_decoder, grad_code);
        last_grad_norm = clip_grad_norm<S>({&grad_query, &grad_decoder, &grad_code}, options.clip_norm);
    }
    const double lr = options.lr.at(steps);
    adam_step<S>(query_net.params, grad_query, adam_query, lr, options.adam);
    if (config.train_decoder) adam_step<S>(decoder.params, grad_decoder, adam_decoder, lr, options.adam);
    if (code.size() > 0) adam_step<S>(code, grad_code, adam_code, lr, options.adam);
    ++steps;
    return L;
}

#define PCP_NN_INSTANTIATE_STEPS(S)                                                                \
    template struct Stage1Workspace<S>;                                                            \
    template struct Stage2Workspace<S>;                                                            \
    template class Stage1Trainer<S>;                                                               \
    template class Stage2Trainer<S>;                                                               \
    template Eigen::Block<Mat<S>, 1, Eigen::Dynamic> decoder_eval<S>(                              \
        const BranchMlp<S>&, const CMatRef<S>&, const CMatRef<S>&, BranchMlpCache<S>&);            \
    template Eigen::Block<Mat<S>, 1, Eigen::Dynamic> global_sdf_eval<S>(                           \
        const BranchMlp<S>&, const BranchMlp<S>&, const CMatRef<S>&, const CMatRef<S>&,            \
        GlobalSdfCache<S>&);                                                                       \
    template Eigen::Block<Mat<S>, 1, Eigen::Dynamic> global_sdf_eval<S>(                           \
        const BranchMlp<S>&, const BranchMlp<S>&, const CMatRef<S>&, const CMatRef<S>&,            \
        const CMatRef<S>&, const Stage2Config&, GlobalSdfCache<S>&);
PCP_NN_INSTANTIATE_STEPS(float)
PCP_NN_INSTANTIATE_STEPS(double)
#undef PCP_NN_INSTANTIATE_STEPS

}  // namespace pcp::nn
