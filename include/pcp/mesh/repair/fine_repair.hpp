// Fine sign repair: the sign repair's rule (sign_repair.hpp) applied once more to the stored samples
// of the fine grid, for the regions too thin for its coarse grid (not in the paper).
//
// A membrane across a through-hole, or a thin bubble of the other sign under a surface, is a region
// of one sign a cell or two thick. The coarse grid (64^3 by default) steps over it, so the sign
// repair never sees it, and marching cubes meshes its two faces: the hole comes out closed, or the
// surface doubled. Here, on the fine grid's stored samples:
//
//  1. A sample is near the data when an input point lies within tau = max(near_k x scale,
//     near_cells x the cell diagonal) (scale: the median distance from the input points to their
//     10th nearest point, as in surface_fit.hpp).
//  2. Connected components (6-neighbours) of samples of one sign that are not near the data.
//     A component that holds a sample next to an unstored one or on the grid's faces is anchored
//     (it reaches space the band did not sample: the outside, a thick interior) and never flipped.
//  3. Each other component counts its neighbour pairs with near samples (n) and with away samples of
//     the other sign (a): the pairs where its boundary is a zero crossing away from the data. When
//     a > max_unsupported x (a + n) the component's sign is wrong: its values are negated (|F|
//     unchanged), so the sheets around it vanish and the region joins its neighbours.
//
// Runs on grids of at most max_samples lattice points ((R + 1)^3; it uses about 6 bytes per point);
// larger grids are left as they are (stats.skipped).
#pragma once

#include "pcp/cloud/kdtree.hpp"
#include "pcp/mesh/grid/sdf_grid.hpp"

#include <cstdint>

namespace pcp {

struct FineRepairOptions {
    bool enabled = true;
    double near_k = 0.8;           ///< tau in units of the sampling scale (0.8: about 3 spacings of an even sampling)
    double near_cells = 2.0;       ///< tau is at least this many cell diagonals
    double max_unsupported = 0.5;  ///< flip a component when more than this fraction of its boundary is away from data
    std::int64_t max_samples = std::int64_t(1) << 25;  ///< (R + 1)^3 above this: skipped (R = 128: 2.1e6)
};

struct FineRepairStats {
    bool skipped = false;               ///< the grid was larger than max_samples
    int components = 0;                 ///< regions of one sign away from the data, not anchored
    int flipped_components = 0;
    std::int64_t flipped_samples = 0;
    double tau = 0;
};

/// Negates the values of `grid`'s stored samples in the components described above, in place.
/// `cloud` is in the grid's frame (the unit box). Throws pcp::Error for bad options.
FineRepairStats repair_fine_grid(SdfGrid& grid, const KdTree& cloud, const FineRepairOptions& options = {});

}  // namespace pcp
