// Pulling loss forward/backward (see pcp/nn/pull_loss.hpp), one pass over the queries with
// fixed-size 3-vectors. The loss sum is accumulated in double.
#include "pcp/nn/pull_loss.hpp"

#include "pcp/core/error.hpp"

#include <cmath>

namespace pcp::nn {

template <class S>
double pull_loss(const CMatRef<S>& q, const CMatRef<S>& s, const CMatRef<S>& g,
                 const CMatRef<S>& t, VecRef<S> dL_ds, MatRef<S> dL_dg) {
    const Eigen::Index n = q.cols();
    PCP_CHECK(n >= 1 && q.rows() == 3 && s.rows() == 1 && s.cols() == n && g.rows() == 3 &&
                  g.cols() == n && t.rows() == 3 && t.cols() == n,
              "nn::pull_loss: expected q, g, t 3 x N and s 1 x N; got q "
                  << q.rows() << "x" << q.cols() << ", s " << s.rows() << "x" << s.cols()
                  << ", g " << g.rows() << "x" << g.cols() << ", t " << t.rows() << "x"
                  << t.cols());
    const bool want_lambda = dL_ds.size() > 0;
    const bool want_v = dL_dg.cols() > 0;
    PCP_CHECK(!want_lambda || dL_ds.size() == n, "nn::pull_loss: dL_ds must have N entries");
    PCP_CHECK(!want_v || (dL_dg.rows() == 3 && dL_dg.cols() == n),
              "nn::pull_loss: dL_dg must be 3 x N");
    using V3 = Eigen::Matrix<S, 3, 1>;
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
        if (want_v) dL_dg.col(i) = (-inv_n * si / gnorm) * (e - e_dot_ghat * ghat);
    }
    return total / double(n);
}

template <class S>
void pull_points(MatRef<S> p, const CMatRef<S>& q, const CMatRef<S>& s, const CMatRef<S>& g) {
    const Eigen::Index n = q.cols();
    PCP_CHECK(p.rows() == 3 && p.cols() == n && q.rows() == 3 && g.rows() == 3 &&
                  g.cols() == n && s.rows() == 1 && s.cols() == n,
              "nn::pull_points: expected p, q, g 3 x N and s 1 x N");
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
