// Optional denoising of the input cloud before reconstruction (not in the paper): each point is
// projected onto the least-squares plane of its k nearest neighbours (their centroid and the
// eigenvector of their covariance with the smallest eigenvalue), `passes` times. On noisy scans
// this halves the error of the reconstruction and raises its normal consistency; on a clean cloud
// it wears down thin parts (a statue's ears) and costs accuracy (docs/NOTEBOOK.md, "Denoising noisy
// clouds"). So it is off unless asked for: `pcp_reconstruct --denoise PASSES`, or `--denoise
// auto`, which denoises only a cloud whose noise_ratio exceeds a threshold (noisy scans measured
// 0.34-0.45, a raw scan of a statue 0.12, clean statues 0.06, a clean CAD part 0.01).
#pragma once

#include "pcp/core/types.hpp"

namespace pcp {

struct DenoiseOptions {
    int passes = 0;               ///< 0 = off (the identity), unless automatic
    int neighbors = 20;           ///< k, including the point itself (3..256, and at most the number of points)
    bool automatic = false;       ///< passes = auto_passes if noise_ratio > auto_threshold, else 0
    double auto_threshold = 0.25;
    int auto_passes = 3;          ///< (the default preset: 2, with the own-side mode; presets.cpp)
    /// The move along the plane's normal (not in the paper). 0: onto the neighbours' plane, which
    /// on a part thinner than the neighbourhood also fits the other side's points and pulls both
    /// sides toward the middle (a noisy plate 0.056 thick: the denoised cloud 0.0047 inside
    /// the ground truth where the input is 0.0014 outside). > 0: to the mode of the neighbours'
    /// heights along that normal nearest to the point's own height (mean shift from the point,
    /// Gaussian kernel of width mode_width x sigma, sigma the cloud's noise: the median over its
    /// points of the heights' median absolute deviation x 1.4826), so the other side's points,
    /// a thickness away, carry little weight. The `default` preset uses 2 (src/pipeline/presets.cpp):
    /// measured over three seeds on the 11 noisy shared cases (docs/NOTEBOOK.md, "The own-side
    /// denoiser as the default"). 0 here, so that the function's default is the plain projection.
    double mode_width = 0.0;
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
