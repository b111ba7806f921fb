// Recentring: a noisy scan's mesh moved onto the middle of its points' noise (not in the paper).
#pragma once

#include "pcp/cloud/kdtree.hpp"
#include "pcp/core/types.hpp"

#include <cstdint>

namespace pcp {

/// Recentring onto the noise's middle (not in the paper), run on the marching-cubes mesh before the
/// fit (pcp::reconstruct: on the meshes of noisy, denoised clouds). On noisy scans the zero set
/// sits systematically inside the data: the denoiser, the shell centring and the fit's own-side
/// mode all lean away from the far side of a thin part, and the fit's kernel is narrower than the
/// noise, so it cannot see a bias of a few tenths of a spacing (pcp_eval --diagnose: 0.0017-0.0051
/// inside the ground truth on 7 of the 11 noisy shared cases, while the raw points lie on it or
/// outside it: median signed distance -0.0001 to +0.0021 on the four measured). Per pass:
///  1. every input point is assigned to its nearest mesh vertex and gets its signed offset along
///     that vertex's normal (positive: outside); offsets beyond clip_k x the noise's spread (1.4826
///     x the offsets' median absolute deviation from their median) are not counted (parts the
///     mesh misses, outliers);
///  2. per vertex, the offsets' sum and count are averaged over the mesh by rounds of one-ring
///     averaging, as many as make the window about window_k x the sampling scale wide
///     (2 (window_k scale / mean edge)^2 rounds, at most 400), so that hundreds of points enter
///     each mean: noise averages out and a bias common to a region is left;
///  3. every vertex with a count moves along its normal by the window's mean offset m, in full
///     while |m| <= max_move_k x the spread, fading linearly to no move at twice that: the bias is
///     a fraction of the noise (on a thin noisy plate 99 % of the moves are under 0.7 spreads),
///     a mean offset beyond it is a sheet away from the data (an inner sheet or a membrane across
///     a bore: a noisy scan with a bore went 0.031 -> 0.062 in L2-CD x 100 when those moved in full).
/// Each point counts for the surface it is nearest to, so the far side of a thin part stays with
/// its own side. Topology is unchanged (vertices move, faces stay).
struct RecentreOptions {
    bool enabled = false;   ///< pcp::reconstruct: clean clouds' meshes (NoisyCloudOptions::recentre for the clouds it denoised)
    double window_k = 2.0;  ///< the averaging window's width in units of the sampling scale (> 0)
    int passes = 2;         ///< assignment + move rounds, in [1, 20]
    double clip_k = 2.5;    ///< offsets beyond this x the robust spread are not counted (> 0)
    double max_move_k = 0.5;  ///< moves fade from this x the spread to none at twice it (> 0)
};

struct RecentreStats {
    bool applied = false;   ///< the stage ran (pcp::reconstruct fills it)
    double spread = 0;      ///< the last pass's spread of the offsets (1.4826 x their MAD, unit-box units)
    double mean_move = 0;   ///< the mean signed move along the normals, summed over the passes (unit-box units; + outward)
    int rounds = 0;         ///< averaging rounds per pass
};

/// The mesh recentred onto `cloud` (see RecentreOptions). `unit_mesh` and `cloud` in the same frame
/// (the unit box). Throws pcp::Error for bad options or a face index out of range.
Mesh recentre_on_points(const Mesh& unit_mesh, const KdTree& cloud, const RecentreOptions& options = {},
                        RecentreStats* stats = nullptr);

}  // namespace pcp
