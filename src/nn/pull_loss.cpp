// Pulling loss forward/backward (see pcp/nn/pull_loss.hpp), one pass over the queries with
// fixed-size 3-vectors (any other dimension, e.g. the plane demonstration's 2, with dynamic
// vectors). The loss sum is accumulated in double.
#include "pcp/nn/pull_loss.hpp"

#include "pcp/core/error.hpp"

#include <cmath>

namespace pcp::nn {

namespace {

/// 3D, the pipeline's hot path: fixed-size 3-vectors.
template <class S>
double pull_loss_3d(const CMatRef<S>& q, const CMatRef<S>& s, const CMatRef<S>& g, const CMatRef<S>& t, VecRef<S> dL_ds,
                    MatRef<S> dL_dg) {
    using V3 = Eigen::Matrix<S, 3, 1>;
    const Eigen::Index n = q.cols();
    const bool want_lambda = dL_ds.size() > 0;
    const bool want_v = dL_dg.cols() > 0;
    const S inv_n = S(1) / S(n);
    double total = 0.0;
    for (Eigen::Index i = 0; i < n; ++i) {
        const V3 gi = g.col(i);
        const S si = s(0, i);
        const S gnorm = std::sqrt(gi.squaredNorm() + S(kPullGradEps));
        const V3 ghat = gi / gnorm;
        const V3 diff = q.col(i) - si * ghat - t.col(i);
        const S dist = diff.norm();
        total += double(dist);
        // e = (p - t)/|p - t|; at p == t the loss is at its minimum and 0 is a subgradient.
        const V3 e = dist > S(0) ? V3(diff / dist) : V3::Zero();
        const S e_dot_ghat = e.dot(ghat);
        if (want_lambda) dL_ds(i) = -inv_n * e_dot_ghat;
        // head<3>: a fixed-size destination (the caller checked 3 rows), so that GCC does not see
        // an 8-float packet path over a 3-vector (-Warray-bounds at -O3).
        if (want_v) dL_dg.col(i).template head<3>() = (-inv_n * si / gnorm) * (e - e_dot_ghat * ghat);
    }
    return total / double(n);
}

/// Any other dimension (the plane demonstration's 2): the same with dynamic vectors.
template <class S>
double pull_loss_any(const CMatRef<S>& q, const CMatRef<S>& s, const CMatRef<S>& g, const CMatRef<S>& t, VecRef<S> dL_ds,
                     MatRef<S> dL_dg) {
    using V = Eigen::Matrix<S, Eigen::Dynamic, 1>;
    const Eigen::Index n = q.cols(), d = q.rows();
    const bool want_lambda = dL_ds.size() > 0;
    const bool want_v = dL_dg.cols() > 0;
    const S inv_n = S(1) / S(n);
    double total = 0.0;
    V ghat(d), diff(d), e(d);
    for (Eigen::Index i = 0; i < n; ++i) {
        const S si = s(0, i);
        const S gnorm = std::sqrt(g.col(i).squaredNorm() + S(kPullGradEps));
        ghat = g.col(i) / gnorm;
        diff = q.col(i) - si * ghat - t.col(i);
        const S dist = diff.norm();
        total += double(dist);
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
    // Small fixed-size vectors in any dimension but 3 trip GCC 12's -Warray-bounds at -O3 inside
    // Eigen's packet path (a false positive), and 2D is never the hot path: dynamic ones there.
    return d == 3 ? pull_loss_3d<S>(q, s, g, t, dL_ds, dL_dg) : pull_loss_any<S>(q, s, g, t, dL_ds, dL_dg);
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
