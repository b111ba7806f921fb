// Checks of extracted meshes, for the pipeline's report, the evaluation and the tests: edge
// counts, orientation consistency, Euler characteristic.
#pragma once

#include "pcp/core/types.hpp"

#include <cstdint>

namespace pcp {

struct MeshTopology {
    std::int64_t V = 0, E = 0, F = 0;             ///< vertices, undirected edges, faces
    std::int64_t edges_not_in_two_faces = 0;      ///< undirected edges used by != 2 faces (boundary, non-manifold)
    std::int64_t repeated_directed_edges = 0;     ///< directed edges used twice (inconsistent orientation)
    std::int64_t degenerate_faces = 0;            ///< faces repeating a vertex index
    std::int64_t unused_vertices = 0;
    std::int64_t euler() const { return V - E + F; }
    /// Closed, manifold along edges, consistently oriented, no degenerate face or unused vertex.
    bool closed_manifold_oriented() const {
        return edges_not_in_two_faces == 0 && repeated_directed_edges == 0 && degenerate_faces == 0 &&
               unused_vertices == 0;
    }
};

/// Counts the topology of `mesh` (faces index its vertices).
MeshTopology mesh_topology(const Mesh& mesh);

/// True if `mesh` has faces and every undirected edge belongs to exactly two faces, traversed in
/// opposite directions (closed, manifold along edges, consistently oriented).
bool is_closed_and_oriented(const Mesh& mesh);

}  // namespace pcp
