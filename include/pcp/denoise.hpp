// Optional denoising of the input cloud before reconstruction (not in the paper): each point is
// projected onto the least-squares plane of its k nearest neighbours (their centroid and the
// eigenvector of their covariance with the smallest eigenvalue), `passes` times. On the noisy ABC
// scans this halves the error of the reconstruction and raises its normal consistency (measured
// in docs/BENCHMARKS.md); on clean data it rounds sharp edges, so it is off unless asked for
// (`pcp_reconstruct --denoise PASSES`).
#pragma once

#include "pcp/types.hpp"

namespace pcp {

struct DenoiseOptions {
    int passes = 0;      ///< 0 = off (the identity)
    int neighbors = 20;  ///< k, including the point itself (3..256, and at most the number of points)
};

/// The denoised copy of `points` (N x 3, input frame; the projection is computed in double, the
/// neighbour search in the cloud's unit box). Throws pcp::Error on bad options or fewer points than
/// neighbours.
Points denoise_points(const Eigen::Ref<const Points>& points, const DenoiseOptions& options);

}  // namespace pcp
