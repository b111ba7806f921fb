// Stage-1 and stage-2 steps, SDF evaluation and the trainers (see pcp/nn/steps.hpp): flat
// sequences of the network passes, in the order of METHOD.md §3-4.
#include "pcp/nn/steps.hpp"

#include "pcp/error.hpp"
#include "pcp/nn/pull_loss.hpp"

#include <utility>

namespace pcp::nn {

// ------------------------------------------------------------------------------------------------
// Stage 1
// ------------------------------------------------------------------------------------------------

template <class S>
Stage1Workspace<S>::Stage1Workspace(const PointNetShape& e, const BranchMlpShape& d,
                                    int max_queries, int max_points)
    : enc(e, max_points), dec(d, max_queries), dL_ds(max_queries), dL_dg(3, max_queries),
      dL_df(d.in_b) {
    PCP_CHECK(d.out == 1 && d.in_a == 3 && d.in_b == e.cond(),
              "nn::Stage1Workspace: the decoder must map (3, C) -> 1 with C = the encoder's "
              "output size (" << e.cond() << "), got in_b = " << d.in_b);
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
                                         VecRef<S> dL_dF, bool test_drop_tangent) {
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
                               GradMode::Overwrite, test_drop_tangent);
    pointnet_backward<S>(E, enc, points, dL_df, dL_dE, GradMode::Overwrite);
    return L;
}

// ------------------------------------------------------------------------------------------------
// Stage 2
// ------------------------------------------------------------------------------------------------

template <class S>
Stage2Workspace<S>::Stage2Workspace(const BranchMlpShape& qs, const BranchMlpShape& d,
                                    int max_queries)
    : qn(qs, max_queries), dec(d, max_queries), q_local(3, max_queries), dL_ds(max_queries) {
    PCP_CHECK(d.out == 1 && d.in_a == 3 && d.in_b >= 1 && qs.in_a == 3 && qs.out == 3 + d.in_b,
              "nn::Stage2Workspace: the query network must output 3 + C = " << 3 + d.in_b
                                                                             << " values, got "
                                                                             << qs.out);
}

namespace {

template <class S>
void stage2_forward(Stage2Workspace<S>& w, const BranchMlp<S>& Q, const BranchMlp<S>& F,
                    const CMatRef<S>& q_g, const CMatRef<S>& codes) {
    const Eigen::Index n = q_g.cols();
    // (dq, f') = Q(q_g); q_l' = q_g + dq.
    branch_mlp_forward(Q, q_g, codes, w.qn);
    w.q_local.leftCols(n) = q_g + w.qn.out.topRows(3).leftCols(n);
    // s = F(q_l', f'); (g_q, g_f) = dF/d(q_l', f').
    branch_mlp_forward<S>(F, w.q_local.leftCols(n), w.qn.out.bottomRows(F.shape.in_b).leftCols(n),
                          w.dec);
    decoder_input_grad(F, w.dec, true);
}

}  // namespace

template <class S>
double Stage2Workspace<S>::loss(const BranchMlp<S>& Q, const BranchMlp<S>& F, const CMatRef<S>& q_g,
                                const CMatRef<S>& t, const CMatRef<S>& codes) {
    stage2_forward(*this, Q, F, q_g, codes);
    const Eigen::Index n = q_g.cols();
    return pull_loss<S>(q_g, dec.out.leftCols(n), dec.g_a.leftCols(n), t, dL_ds.head(0),
                        dec.tan0.leftCols(0));
}

template <class S>
double Stage2Workspace<S>::loss_and_grad(const BranchMlp<S>& Q, const BranchMlp<S>& F,
                                         const CMatRef<S>& q_g, const CMatRef<S>& t,
                                         const CMatRef<S>& codes, VecRef<S> dL_dQ) {
    stage2_forward(*this, Q, F, q_g, codes);
    const Eigen::Index n = q_g.cols();
    const int C = F.shape.in_b;
    // Pulling loss at q_g (paper eq. 5): only lambda is needed -- g is piecewise constant in
    // (q_l', f'), so dL/dq_l' = lambda g_q and dL/df' = lambda g_f (METHOD.md §4).
    const double L = pull_loss<S>(q_g, dec.out.leftCols(n), dec.g_a.leftCols(n), t, dL_ds.head(n),
                                  dec.tan0.leftCols(0));
    const auto lam_row = dL_ds.head(n).transpose().array();
    auto seed = qn.dL_dout.leftCols(n);
    seed.topRows(3) = (dec.g_a.leftCols(n).array().rowwise() * lam_row).matrix();
    seed.bottomRows(C) = (dec.g_b.leftCols(n).array().rowwise() * lam_row).matrix();
    // Backprop into Q only.
    branch_mlp_backward<S>(Q, qn, q_g, codes, seed, dL_dQ, GradMode::Overwrite);
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
    c.q_local.leftCols(n) = q_g + c.qn.out.topRows(3).leftCols(n);
    return decoder_eval<S>(F, c.q_local.leftCols(n), c.qn.out.bottomRows(F.shape.in_b).leftCols(n),
                           c.dec);
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
                                OptimOptions o)
    : query_net(std::move(qn)), decoder(std::move(d)), adam_query(query_net.layout.size()),
      options(o), workspace(query_net.shape, decoder.shape, max_queries),
      grad_query(query_net.layout.size()) {}

template <class S>
double Stage2Trainer<S>::step(const CMatRef<S>& q_g, const CMatRef<S>& t,
                              const CMatRef<S>& codes) {
    const double L = workspace.loss_and_grad(query_net, decoder, q_g, t, codes, grad_query);
    last_grad_norm = clip_grad_norm<S>({&grad_query}, options.clip_norm);
    adam_step<S>(query_net.params, grad_query, adam_query, options.lr.at(steps), options.adam);
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
        GlobalSdfCache<S>&);
PCP_NN_INSTANTIATE_STEPS(float)
PCP_NN_INSTANTIATE_STEPS(double)
#undef PCP_NN_INSTANTIATE_STEPS

}  // namespace pcp::nn
