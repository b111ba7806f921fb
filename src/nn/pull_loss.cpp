// Pulling loss forward/backward (see pcp/nn/pull_loss.hpp), one pass over the queries with
// fixed-size vectors of the points' dimension (3; 2 for the plane demonstration; any other
// dimension with dynamic vectors). The loss sum is accumulated in double.
#include "pcp/nn/pull_loss.hpp"

#include "pcp/core/error.hpp"

#include <cmath>

namespace pcp::nn {

namespace {

/// The loss over n queries of dimension D (a fixed size, or Eigen::Dynamic with `dim` rows).
template <class S, int D>
double pull_loss_dim(const CMatRef<S>& q, const CMatRef<S>& s, const CMatRef<S>& g,
                     const CMatRef<S>& t, VecRef<S> dL_ds, MatRef<S> dL_dg, Eigen::Index dim) {
    using V = Eigen::Matrix<S, D, 1>;
    const Eigen::Index n = q.cols();
    const bool want_lambda = dL_ds.size() > 0;
    const bool want_v = dL_dg.cols() > 0;
    const S inv_n = S(1) / S(n);
    double total = 0.0;
    V gi(dim), ghat(dim), diff(dim), e(dim);
    for (Eigen::Index i = 0; i < n; ++i) {
        gi = g.col(i);
        const S si = s(0, i);
        const S gnorm = std::sqrt(gi.squaredNorm() + S(kPullGradEps));
        ghat = gi / gnorm;
        diff = q.col(i) - si * ghat - t.col(i);
        const S dist = diff.norm();
        total += double(dist);
        // e = (p - t)/|p - t|; at p == t the loss is at its minimum and 0 is a subgradient.
        if (dist > S(0))
            e = diff / dist;
        else
            e.setZero();
        const S e_dot_ghat = e.dot(ghat);
        if (want_lambda) dL_ds(i) = -inv_n * e_dot_ghat;
        if (want_v) dL_dg.col(i) = (-inv_n * si / gnorm) * (e - e_dot_ghat * ghat);
    }
    return total / double(n);
}

}  // namespace

template <class S>
double pull_loss(const CMatRef<S>& q, const CMatRef<S>& s, const CMatRef<S>& g,
                 const CMatRef<S>& t, VecRef<S> dL_ds, MatRef<S> dL_dg) {
    const Eigen::Index n = q.cols(), d = q.rows();
    PCP_CHECK(n >= 1 && d >= 1 && s.rows() == 1 && s.cols() == n && g.rows() == d &&
                  g.cols() == n && t.rows() == d && t.cols() == n,
              "nn::pull_loss: expected q, g, t D x N and s 1 x N; got q "
                  << q.rows() << "x" << q.cols() << ", s " << s.rows() << "x" << s.cols()
                  << ", g " << g.rows() << "x" << g.cols() << ", t " << t.rows() << "x"
                  << t.cols());
    PCP_CHECK(dL_ds.size() == 0 || dL_ds.size() == n, "nn::pull_loss: dL_ds must have N entries");
    PCP_CHECK(dL_dg.cols() == 0 || (dL_dg.rows() == d && dL_dg.cols() == n),
              "nn::pull_loss: dL_dg must be D x N, like q");
    if (d == 3) return pull_loss_dim<S, 3>(q, s, g, t, dL_ds, dL_dg, d);
    if (d == 2) return pull_loss_dim<S, 2>(q, s, g, t, dL_ds, dL_dg, d);
    return pull_loss_dim<S, Eigen::Dynamic>(q, s, g, t, dL_ds, dL_dg, d);
}

template <class S>
void pull_points(MatRef<S> p, const CMatRef<S>& q, const CMatRef<S>& s, const CMatRef<S>& g) {
    const Eigen::Index n = q.cols();
    const Eigen::Index d = q.rows();
    PCP_CHECK(d >= 1 && p.rows() == d && p.cols() == n && g.rows() == d && g.cols() == n &&
                  s.rows() == 1 && s.cols() == n,
              "nn::pull_points: expected p, q, g D x N and s 1 x N");
    for (Eigen::Index i = 0; i < n; ++i) {
        const S gnorm = std::sqrt(g.col(i).squaredNorm() + S(kPullGradEps));
        p.col(i) = q.col(i) - (s(0, i) / gnorm) * g.col(i);
    }
}

template double pull_loss<float>(const CMatRef<float>&, const CMatRef<float>&,
                                 const CMatRef<float>&, const CMatRef<float>&, VecRef<float>,
                                 MatRef<float>);
template double pull_loss<double>(const CMatRef<double>&, const CMatRef<double>&,
                                  const CMatRef<double>&, const CMatRef<double>&, VecRef<double>,
                                  MatRef<double>);
template void pull_points<float>(MatRef<float>, const CMatRef<float>&, const CMatRef<float>&,
                                 const CMatRef<float>&);
template void pull_points<double>(MatRef<double>, const CMatRef<double>&, const CMatRef<double>&,
                                  const CMatRef<double>&);

}  // namespace pcp::nn
