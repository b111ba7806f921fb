// Marching cubes over a sparse SDF grid (sdf_grid.hpp): the zero level set as an indexed triangle
// mesh with one vertex per crossed grid edge, shared between neighbouring cubes and blocks (METHOD.md
// §1 "marching cubes at the zero level set"). The case table is generated in code (src/mc_cases.*);
// the rare cube whose polygon cannot be triangulated from its crossings alone without risking an
// edge shared with the next cube also gets a vertex at that polygon's centre.
// The mesh is closed and manifold wherever the level set is closed inside the grid, and every
// triangle is counter-clockwise seen from the positive (outside) side.
#pragma once

#include "pcp/mesh/grid/sdf_grid.hpp"
#include "pcp/core/types.hpp"

namespace pcp {

/// How a face whose diagonal corners share a sign (an ambiguous face) is cut. Both rules look only
/// at the face's own four values, so the two cubes sharing it agree and the mesh stays watertight.
enum class McAmbiguity {
    AsymptoticDecider,  ///< join the inside corners when the bilinear saddle is inside (< 0); a cube
                        ///< with a joined face may need a centre vertex (none on the smooth test shapes;
                        ///< 1.6 % of the vertices on a white-noise field)
    SeparateInside,     ///< always separate the inside corners (a fixed sign convention): never a
                        ///< centre vertex, exactly one vertex per crossed grid edge
    JoinInside,         ///< always join the inside corners, on every ambiguous face and, in a cube
                        ///< whose only inside corners are the two ends of a body diagonal, through
                        ///< its interior (a tube): the mesh bounds the union of the closed cubes
                        ///< around the inside samples (26-connected inside, 6-connected outside),
                        ///< the solid whose topology the grid repairs reason on (tunnel_fill.hpp,
                        ///< cavity_fill.hpp); its Euler characteristic is twice that solid's
};

struct MarchingCubesOptions {
    McAmbiguity ambiguity = McAmbiguity::AsymptoticDecider;
};

/// Extracts the zero level set from the stored blocks of `grid` (OpenMP over blocks); for another
/// level, evaluate the field minus that level (pcp::reconstruct does, ReconstructOptions::iso).
/// A sample is inside when its value < 0. Vertices lie on grid edges, placed by linear
/// interpolation (plus the rare polygon centres, the mean of their polygon's vertices, listed
/// last), and are ordered by their grid edge (so the result does not depend on the
/// thread count or on which blocks were stored, as long as the cubes crossed are).
/// @return vertices V x 3 (unit-box coordinates, as the grid), faces F x 3, counter-clockwise seen
///         from outside (normals point towards positive SDF). Empty if the level set misses the grid.
Mesh marching_cubes(const SdfGrid& grid, const MarchingCubesOptions& options = {});

}  // namespace pcp
