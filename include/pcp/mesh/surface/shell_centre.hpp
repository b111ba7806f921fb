// Shell centring: the surface of a noisy scan put in the middle of its noise band (not in the paper).
//
// On a noisy scan the fitted field is a hollow shell (cavity_fill.hpp): negative in a layer as
// thick as the noise band, positive again behind it. The cavity fill negates the enclosed hollow,
// so marching cubes meshes the shell's outer wall only -- the outer edge of the noise band, not its
// middle: a noisy scan's mesh lay 0.025 outside the ground truth before the surface fit and 0.011
// after it, against a noise band whose mean is on the surface (docs/NOTEBOOK.md, "Shell
// centring"). The surface fit
// cannot undo a bias that large: the nearest input points of a vertex on the outer edge are the
// outer half of the band.
//
// The grid before the cavity fill still holds the shell's inner wall. For each vertex of the mesh
// (unit normal n, outward) walk inward along -n, up to max_thickness, through the field as it was
// before the fill; where it first turns positive, at depth t, is the inner wall. It counts only if
// what lies behind it is a hollow the fills closed: negative in the final field and positive before
// the fill all the way from t to 2t. Then the vertex moves to the middle of the wall, by -t/2
// along n (the moves are averaged over the one-ring twice, unmoved vertices counting 0, so no step
// appears where moved and unmoved parts meet). A vertex whose walk reaches real outside (the other
// side of a thin part), a pocket shallower than the wall (a bubble in a solid part) or no wall
// within max_thickness is not moved: thin plates keep their surface.
#pragma once

#include "pcp/cloud/kdtree.hpp"
#include "pcp/core/types.hpp"
#include "pcp/mesh/grid/sdf_grid.hpp"

#include <cstdint>

namespace pcp {

struct ShellCentreOptions {
    /// Applied by pcp::reconstruct to denoised (noisy) clouds whose cavity fill filled something;
    /// on clean clouds the outer wall lies on the data and the inner one is the field's own error.
    bool enabled = true;
    /// Walls thicker than this, in units of the cloud's sampling scale (pcp::sampling_scale: the
    /// median distance to the 10th nearest point), are left as they are. 4 left 42 % of a noisy
    /// scan's outer wall unmoved; 8 and 16 moved 96-98 % to the same result.
    double max_thickness_k = 8.0;
};

struct ShellCentreStats {
    bool applied = false;         ///< the step ran (a noisy cloud whose cavity fill filled samples)
    std::int64_t moved = 0;       ///< vertices moved to the middle of their wall
    double mean_move = 0;         ///< mean distance moved by those vertices (unit-box units)
};

/// `mesh` (unit box) meshed from `after` (the dense fine grid after every fill and repair);
/// `before` is the same grid before the cavity fill (same spec and blocks). Each vertex is moved as
/// described above; `max_thickness` is in unit-box units. Faces unchanged. Throws pcp::Error when
/// the grids differ in spec or blocks, or for max_thickness <= 0.
Mesh centre_in_shells(const Mesh& mesh, const SdfGrid& before, const SdfGrid& after, const KdTree& cloud, double max_thickness,
                      ShellCentreStats* stats = nullptr);

}  // namespace pcp
