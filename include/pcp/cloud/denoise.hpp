// Optional denoising of the input cloud before reconstruction (not in the paper): each point is
// projected onto the least-squares plane of its k nearest neighbours (their centroid and the
// eigenvector of their covariance with the smallest eigenvalue), `passes` times. On the noisy ABC
// scans this halves the error of the reconstruction and raises its normal consistency; on the
// clean bunny it thins the ears and costs accuracy (measured in docs/BENCHMARKS.md). So it is off
// unless asked for: `pcp_reconstruct --denoise PASSES`, or `--denoise auto`, which denoises only a
// cloud whose noise_ratio exceeds a threshold (ABC scans 0.39-0.45, noisy bunny 0.34, gargoyle
// scan 0.12, bunny 0.06, fandisk 0.01).
#pragma once

#include "pcp/core/types.hpp"

namespace pcp {

struct DenoiseOptions {
    int passes = 0;               ///< 0 = off (the identity), unless automatic
    int neighbors = 20;           ///< k, including the point itself (3..256, and at most the number of points)
    bool automatic = false;       ///< passes = auto_passes if noise_ratio > auto_threshold, else 0
    double auto_threshold = 0.25;
    int auto_passes = 3;
};

/// How far the cloud is from locally flat: the median over its points of sqrt(l0 / (l0 + l1 + l2)),
/// l0 <= l1 <= l2 the eigenvalues of the covariance of the point's k nearest neighbours. About 0
/// for a clean smooth surface, below 1/sqrt(3) ~ 0.577 for isotropic noise (0.45 measured with 20
/// neighbours: a small sample underestimates l0).
double noise_ratio(const Eigen::Ref<const Points>& points, int neighbors = 20);

/// The passes `options` asks for on `points` (resolves automatic).
int denoise_passes(const Eigen::Ref<const Points>& points, const DenoiseOptions& options);

/// The denoised copy of `points` (N x 3, input frame; the projection is computed in double, the
/// neighbour search in the cloud's unit box). Throws pcp::Error on bad options or fewer points than
/// neighbours.
Points denoise_points(const Eigen::Ref<const Points>& points, const DenoiseOptions& options);

}  // namespace pcp
