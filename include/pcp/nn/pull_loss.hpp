// The Neural-Pull pulling cost of METHOD.md §3 and its per-query derivatives (§4):
//   p = q - s g / |g|,  |g| = sqrt(sum g^2 + 1e-12),  L = mean_i |p_i - t_i|_2,
//   lambda_i = dL/ds_i = -(1/N) e . g_hat,   v_i = dL/dg_i = -(1/N)(s/|g|)(I - g_hat g_hat^T) e,
// with e = (p - t)/|p - t| (e = 0 where p == t exactly: the subgradient 0, no NaN) and
// g_hat = g/|g|. Stage 1 uses both lambda and v; stage 2 only lambda. Points have D = 3 coordinates
// (D = 2 in the plane demonstration, pcp/demo/demo2d.hpp); every D x N below is 3 x N in 3D.
#pragma once

#include "pcp/nn/common.hpp"

namespace pcp::nn {

/// The epsilon inside |g| (METHOD.md §3, from the release).
constexpr double kPullGradEps = 1e-12;

/// Pulling loss and its derivatives.
/// @param[in]  q      D x N queries (stage 1: region coordinates; stage 2: q_g).
/// @param[in]  s      1 x N signed distances F(...).
/// @param[in]  g      D x N gradients dF/dq (stage 2: at q_l').
/// @param[in]  t      D x N targets (nearest input point of each query).
/// @param[out] dL_ds  N: lambda (size 0 to skip).
/// @param[out] dL_dg  D x N: v (0 columns to skip, e.g. in stage 2).
/// @return L (accumulated in double).
template <class S>
double pull_loss(const CMatRef<S>& q, const CMatRef<S>& s, const CMatRef<S>& g,
                 const CMatRef<S>& t, VecRef<S> dL_ds, MatRef<S> dL_dg);

/// The pulled points p = q - s g/|g| (D x N), e.g. for inspection.
template <class S>
void pull_points(MatRef<S> p, const CMatRef<S>& q, const CMatRef<S>& s, const CMatRef<S>& g);

}  // namespace pcp::nn
