// Mesh checks (see pcp/mesh/grid/mesh_check.hpp).
#include "pcp/mesh/grid/mesh_check.hpp"

#include "pcp/core/error.hpp"

#include <algorithm>
#include <map>
#include <utility>
#include <vector>

namespace pcp {

MeshTopology mesh_topology(const Mesh& mesh) {
    MeshTopology t;
    t.V = mesh.vertices.rows();
    t.F = mesh.faces.rows();
    std::map<std::pair<std::int32_t, std::int32_t>, int> directed;
    std::vector<bool> used(static_cast<std::size_t>(t.V), false);
    for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
        const std::int32_t a = mesh.faces(f, 0), b = mesh.faces(f, 1), c = mesh.faces(f, 2);
        for (std::int32_t v : {a, b, c})
            PCP_CHECK(v >= 0 && v < t.V, "mesh topology: face " << f << " indexes vertex " << v << " of " << t.V);
        if (a == b || b == c || a == c) ++t.degenerate_faces;
        for (std::int32_t v : {a, b, c}) used[static_cast<std::size_t>(v)] = true;
        ++directed[{a, b}];
        ++directed[{b, c}];
        ++directed[{c, a}];
    }
    std::map<std::pair<std::int32_t, std::int32_t>, int> undirected;
    for (const auto& [e, n] : directed) {
        if (n > 1) ++t.repeated_directed_edges;
        undirected[{std::min(e.first, e.second), std::max(e.first, e.second)}] += n;
    }
    t.E = static_cast<std::int64_t>(undirected.size());
    for (const auto& [e, n] : undirected)
        if (n != 2) ++t.edges_not_in_two_faces;
    for (bool u : used)
        if (!u) ++t.unused_vertices;
    return t;
}

bool is_closed_and_oriented(const Mesh& mesh) {
    if (mesh.faces.rows() == 0) return false;
    const MeshTopology t = mesh_topology(mesh);
    return t.edges_not_in_two_faces == 0 && t.repeated_directed_edges == 0;
}

}  // namespace pcp
