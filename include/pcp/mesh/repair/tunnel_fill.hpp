// Tunnel fill: passages through the solid narrower than the grid can resolve are plugged (not in
// the paper).
//
// Where the fitted field is bumpy (sharp edges, the rim of a hole, the root of a thin part), its
// zero set can pinch through a wall in a passage a cell or two wide: marching cubes meshes a small
// handle there, and a shape of genus 1 comes out with genus 60 (the built-in shape;
// docs/NOTEBOOK.md, "Tunnel fill"). A passage that narrow is below the data's resolution as well
// (the default grid's cell is about one sample spacing of a 20k-point object), so nothing in the
// input supports
// it. On the dense fine grid:
//
//  1. The morphological closing of the inside samples (F < 0) by one cell (dilation then erosion
//     with the 3 x 3 x 3 cube): the outside samples it adds are where the outside is at most two
//     cells across between inside samples: passages, dents and the inner corners of creases.
//  2. Their connected components (26-neighbours). Each is scored by how adding it changes the
//     Euler characteristic of the solid (the union of the closed cells of the inside samples):
//     chi(solid + A) - chi(solid) = chi(A) - chi(A meets solid), counted on the cells of the cubical
//     complex. A dent or a crease filled adds a contractible piece along a contractible contact:
//     no change. A plug across a passage meets the solid along a ring: +1 (one handle fewer).
//  3. Components with a positive change are made inside (their values negated, |F| kept, as small
//     negative where F was 0): the handles vanish, everything else stays as the field put it.
//     A component that would close off a pocket (a cavity is +1 too) is plugged as well; the cavity
//     fill after it (cavity_fill.hpp) then fills the pocket.
//
// Needs every sample of the lattice (a dense grid, as the cavity fill); otherwise, and above
// max_samples, nothing is done (stats.skipped).
#pragma once

#include "pcp/mesh/grid/sdf_grid.hpp"

#include <cstdint>

namespace pcp {

struct TunnelFillOptions {
    bool enabled = true;
    std::int64_t max_samples = std::int64_t(1) << 24;  ///< (R + 1)^3 above this: skipped (R = 128: 2.1e6)
};

struct TunnelFillStats {
    bool skipped = false;             ///< not a dense grid, or larger than max_samples
    int candidates = 0;               ///< components of the samples the closing adds
    int plugged = 0;                  ///< of which plugged (the solid's Euler characteristic rises)
    std::int64_t plugged_samples = 0; ///< lattice samples made inside
};

/// Plugs the narrow passages of `grid` described above, in place (every stored copy of a sample).
TunnelFillStats fill_tunnels(SdfGrid& grid, const TunnelFillOptions& options = {});

/// The Euler characteristic of the solid the rules above reason on: the union of the closed cubes
/// (one cell wide) around the inside samples (F < 0) of a dense grid (components - handles +
/// cavities). marching_cubes with McAmbiguity::JoinInside meshes its boundary, whose Euler
/// characteristic is twice this. Throws if `grid` is not dense.
int solid_euler_characteristic(const SdfGrid& grid);

}  // namespace pcp
