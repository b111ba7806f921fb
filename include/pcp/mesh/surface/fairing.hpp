// Fairing: where no data lies under the mesh, the smoothest surface that joins the supported rest
// (not in the paper).
#pragma once

#include "pcp/cloud/kdtree.hpp"
#include "pcp/core/types.hpp"

#include <cstdint>

namespace pcp {

/// Fairing where there is no data (not in the paper), run last on the meshes of objects. Where no
/// input point lies under the surface, its shape is the fitted field's guess: on the shared cases
/// crumpled sheets and ragged rims at the scans' borders (the end of a barely scanned bore, the
/// open edges of a statue's scan; docs/NOTEBOOK.md, "Fairing where there is no data"). Every
/// vertex with fewer than support_count input points within support_k x the sampling scale (the
/// surface fit's
/// support radius) is placed instead as the smoothest surface that joins the supported rest: the solution of
/// L A^-1 L x = 0 on those vertices with the supported ones fixed, L the cotangent Laplacian and A
/// the vertex areas (the thin-plate energy), so that the patch continues its border's position and
/// slope. Measured against it: the membrane L x = 0 flattens the patches
/// (worse on the shared cases), and the graph Laplacian (uniform weights) depends on the
/// triangles' shapes (a raw marching-cubes sphere's unsupported cap came out twice as flat). A
/// patch of free vertices that touches no supported vertex has nothing to join and stays where it
/// is (the surface fit removes such components before). Topology is unchanged (vertices move,
/// faces stay). Cost: a sparse Cholesky factorisation over the free vertices (0.1 s for 10,000).
struct FairOptions {
    bool enabled = true;     ///< pcp::reconstruct runs it on every mesh but the scene mode's (which trims those faces)
    double support_k = 0.8;  ///< a vertex is supported with support_count input points within this x the sampling scale (> 0)
    /// Input points a supported vertex needs within that radius (>= 1; an even sampling puts about
    /// 6 there). One stray point of a noisy scan's spread is not data under the surface: with 1,
    /// the strays scattered inside a barely scanned bore held the field's guess of its wall in
    /// place, a bulge into the bore (docs/NOTEBOOK.md, "Two points under a supported vertex").
    int support_count = 2;
    /// A patch is left as it was if a vertex of its solution leaves the box of the patch's vertices
    /// and their one-rings grown by this x the box's diagonal (>= 0; an ill-conditioned solve, never
    /// seen at 128 cells on the shared cases).
    double guard = 0.5;
};

struct FairStats {
    std::int64_t free_vertices = 0;  ///< vertices placed by the fairing
    std::int64_t patches = 0;        ///< connected patches of them
    std::int64_t unanchored = 0;     ///< unsupported vertices left in place: their patch touches no supported vertex
    std::int64_t reverted = 0;       ///< patches left as they were by the guard (FairOptions::guard); not in patches
    double mean_move = 0;            ///< mean distance the placed vertices moved (unit-box units)
    bool failed = false;             ///< the sparse solve failed (not seen on any shared case): the mesh was left as it was
};

/// The mesh faired where it has no data under it (see FairOptions). `unit_mesh` and `cloud` in the
/// same frame (the unit box). Throws pcp::Error for bad options, a face index out of range or a
/// vertex that is not finite.
Mesh fair_unsupported(const Mesh& unit_mesh, const KdTree& cloud, const FairOptions& options = {}, FairStats* stats = nullptr);

}  // namespace pcp
