// Through-line carve: the inside samples of the fine grid that lie on lines crossing no wall of the
// data are made outside (not in the paper).
//
// A narrow opening of the shape (the gaps between the slats of a chair's back, a slot a few sample
// spacings wide) is below what the fitted field resolves: its zero level set spans the opening as
// one plate, and the repairs keep it, because the plug is joined to the thin parts around it. The
// visibility labels (pcp/cloud/visibility.hpp) know better only at their coarse cells, which in
// such an opening are all too near the data to be labelled. The data says more at single points:
// a point on a line that passes no input point (grown into a ball of the labels' dilation radius)
// on either side cannot be inside any closed surface through the data. On the fine grid:
//
//  1. An occupancy grid of the dilated cloud at voxels_per_cell voxels per grid cell
//     (ThroughLines).
//  2. Candidates: the inside samples (F < 0) in a free voxel that is at most max_distance x
//     sampling_scale from the data (the plugs beside it), tried from the outside in: those beside
//     an outside sample first, then those beside a candidate found on such lines, and so on (the
//     deep inside of a solid, whose lines are all blocked, is never reached).
//  3. The candidates with at least min_through_lines of `rays` directions that escape at both ends,
//     in connected pieces (26-neighbours). A piece is made outside (values negated, |F| kept, a
//     small positive where F was 0) when the walls it lays bare stand on the data: at least
//     min_wall_support of the inside samples beside it that stay inside lie in blocked voxels
//     (within the dilation radius, plus a voxel, of an input point). A gap between slats is carved
//     down to the slats' sides (most of its walls on the data). In a noisy scan the band of points
//     blocks some lines at random: a blob of the field where the shape has an opening is only
//     pitted, and the pits' walls hang in the air (abc_00994122: 7-17 % of them on the data, its
//     L2-CD x 100 0.0217 -> 0.0258 when they were carved); those pieces stay.
//
// The coarse labels' rule (VisibilityOptions::min_through_lines) at the fine grid's samples. A wall
// whose scan leaves gaps wider than the dilation on both sides of the solid would let lines
// through it; the rule asks for several such directions. Needs every sample of the lattice (a
// dense grid, as the tunnel fill); otherwise, and above max_samples, nothing is done.
#pragma once

#include "pcp/cloud/kdtree.hpp"
#include "pcp/mesh/sdf_grid.hpp"

#include <cstdint>

namespace pcp {

struct ThroughCarveOptions {
    bool enabled = true;
    int voxels_per_cell = 2;      ///< occupancy voxels per grid cell (1..8; at most 1024 along the box)
    double dilation = 0.5;        ///< ball radius around each input point, x sampling_scale (as VisibilityOptions)
    int rays = 64;                ///< directions per candidate (8..1024)
    int min_through_lines = 3;    ///< directions that must escape at both ends (1..rays)
    double max_distance = 4.0;    ///< candidates at most this x sampling_scale from the data (> 0)
    double min_wall_support = 0.5;  ///< share of a piece's bared walls that must stand on the data ([0, 1])
    std::uint64_t seed = 1;       ///< the per-sample rotations of the directions
    std::int64_t max_samples = std::int64_t(1) << 24;  ///< (R + 1)^3 above this: skipped
};

struct ThroughCarveStats {
    bool skipped = false;         ///< not a dense grid, or larger than max_samples
    std::int64_t candidates = 0;  ///< inside samples tried (free voxels within max_distance)
    int pieces = 0;               ///< connected pieces of those on lines that cross no wall
    int opened = 0;               ///< of which made outside
    std::int64_t carved = 0;      ///< samples made outside
    double seconds = 0;
};

/// Carves `grid` in place as described above (every stored copy of a sample alike). `cloud` is in the grid's frame. Throws pcp::Error on bad
/// options.
ThroughCarveStats carve_through_lines(SdfGrid& grid, const KdTree& cloud, const ThroughCarveOptions& options = {});

}  // namespace pcp
