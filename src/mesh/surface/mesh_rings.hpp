// The mesh structures that the surface passes share (internal): one-rings, connected components,
// vertex normals, the nearest vertex of a point.
#pragma once

#include "pcp/cloud/kdtree.hpp"
#include "pcp/core/types.hpp"

#include <algorithm>
#include <cstdint>
#include <limits>
#include <numeric>
#include <vector>

namespace pcp::detail {

/// Vertex -> neighbouring vertices (through edges of faces), compressed rows.
struct OneRing {
    std::vector<std::int64_t> start;  ///< V + 1
    std::vector<std::int32_t> ids;

    explicit OneRing(const Mesh& mesh) {
        const Eigen::Index V = mesh.vertices.rows();
        std::vector<std::vector<std::int32_t>> adj(static_cast<std::size_t>(V));
        for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f)
            for (int k = 0; k < 3; ++k) {
                const std::int32_t a = mesh.faces(f, k), b = mesh.faces(f, (k + 1) % 3);
                if (a == b) continue;
                adj[static_cast<std::size_t>(a)].push_back(b);
                adj[static_cast<std::size_t>(b)].push_back(a);
            }
        start.assign(static_cast<std::size_t>(V) + 1, 0);
        for (Eigen::Index v = 0; v < V; ++v) {
            auto& a = adj[static_cast<std::size_t>(v)];
            std::sort(a.begin(), a.end());
            a.erase(std::unique(a.begin(), a.end()), a.end());
            start[static_cast<std::size_t>(v) + 1] = start[static_cast<std::size_t>(v)] + static_cast<std::int64_t>(a.size());
        }
        ids.reserve(static_cast<std::size_t>(start.back()));
        for (const auto& a : adj) ids.insert(ids.end(), a.begin(), a.end());
    }
};

inline std::int32_t find_root(std::vector<std::int32_t>& parent, std::int32_t a) {
    while (parent[static_cast<std::size_t>(a)] != a) a = parent[static_cast<std::size_t>(a)] = parent[static_cast<std::size_t>(parent[static_cast<std::size_t>(a)])];
    return a;
}

/// The connected components of a mesh (vertices joined by faces): each vertex's root (the
/// component's smallest vertex; -1 where no face uses it) and, at each root, the component's vertex
/// count and bounding box; `largest`, the root with the most vertices (the first of equals).
struct Components {
    std::vector<std::int32_t> root;
    std::vector<std::int64_t> count;
    std::vector<Eigen::Vector3d> lo, hi;
    Eigen::Index largest = -1;

    explicit Components(const Mesh& mesh) {
        const Eigen::Index V = mesh.vertices.rows();
        std::vector<std::int32_t> parent(static_cast<std::size_t>(V));
        std::iota(parent.begin(), parent.end(), 0);
        for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f)
            for (int k = 1; k < 3; ++k) {
                const std::int32_t a = find_root(parent, mesh.faces(f, 0)), b = find_root(parent, mesh.faces(f, k));
                if (a != b) parent[static_cast<std::size_t>(std::max(a, b))] = std::min(a, b);
            }
        root.assign(static_cast<std::size_t>(V), -1);
        for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f)
            for (int k = 0; k < 3; ++k) root[static_cast<std::size_t>(mesh.faces(f, k))] = 0;
        const double inf = std::numeric_limits<double>::infinity();
        count.assign(static_cast<std::size_t>(V), 0);
        lo.assign(static_cast<std::size_t>(V), Eigen::Vector3d::Constant(inf));
        hi.assign(static_cast<std::size_t>(V), Eigen::Vector3d::Constant(-inf));
        for (Eigen::Index v = 0; v < V; ++v) {
            if (root[static_cast<std::size_t>(v)] < 0) continue;
            const std::int32_t r = find_root(parent, static_cast<std::int32_t>(v));
            root[static_cast<std::size_t>(v)] = r;
            ++count[static_cast<std::size_t>(r)];
            lo[static_cast<std::size_t>(r)] = lo[static_cast<std::size_t>(r)].cwiseMin(mesh.vertices.row(v).transpose());
            hi[static_cast<std::size_t>(r)] = hi[static_cast<std::size_t>(r)].cwiseMax(mesh.vertices.row(v).transpose());
        }
        for (Eigen::Index v = 0; v < V; ++v)
            if (count[static_cast<std::size_t>(v)] > 0 && (largest < 0 || count[static_cast<std::size_t>(v)] > count[static_cast<std::size_t>(largest)]))
                largest = v;
    }
    double diagonal(Eigen::Index r) const { return (hi[static_cast<std::size_t>(r)] - lo[static_cast<std::size_t>(r)]).norm(); }
};

/// `mesh` with only the components whose root `keep_root` marks, unused vertices dropped (vertices
/// and faces in their order). `removed_faces` (optional) receives the faces removed.
inline Mesh keep_components(const Mesh& mesh, const Components& c, const std::vector<char>& keep_root, std::int64_t* removed_faces = nullptr) {
    const Eigen::Index V = mesh.vertices.rows();
    std::vector<std::int32_t> remap(static_cast<std::size_t>(V), -1);
    std::int32_t nv = 0;
    for (Eigen::Index v = 0; v < V; ++v) {
        const std::int32_t r = c.root[static_cast<std::size_t>(v)];
        if (r >= 0 && keep_root[static_cast<std::size_t>(r)]) remap[static_cast<std::size_t>(v)] = nv++;
    }
    Mesh out;
    out.vertices.resize(nv, 3);
    for (Eigen::Index v = 0; v < V; ++v)
        if (remap[static_cast<std::size_t>(v)] >= 0) out.vertices.row(remap[static_cast<std::size_t>(v)]) = mesh.vertices.row(v);
    std::vector<Eigen::Index> kept;
    for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f)
        if (remap[static_cast<std::size_t>(mesh.faces(f, 0))] >= 0) kept.push_back(f);
    if (removed_faces) *removed_faces = mesh.faces.rows() - static_cast<std::int64_t>(kept.size());
    out.faces.resize(static_cast<Eigen::Index>(kept.size()), 3);
    for (std::size_t i = 0; i < kept.size(); ++i)
        for (int k = 0; k < 3; ++k) out.faces(static_cast<Eigen::Index>(i), k) = remap[static_cast<std::size_t>(mesh.faces(kept[i], k))];
    return out;
}

/// Area-weighted vertex normals, averaged once over the one-ring, unit length (zero where undefined).
inline Points vertex_normals(const Mesh& mesh, const OneRing& ring) {
    const Eigen::Index V = mesh.vertices.rows();
    Points n = Points::Zero(V, 3);
    for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
        const Eigen::RowVector3d a = mesh.vertices.row(mesh.faces(f, 0)), b = mesh.vertices.row(mesh.faces(f, 1)),
                                 c = mesh.vertices.row(mesh.faces(f, 2));
        const Eigen::RowVector3d fn = (b - a).cross(c - a);  // twice the area times the unit normal
        for (int k = 0; k < 3; ++k) n.row(mesh.faces(f, k)) += fn;
    }
    Points s = n;
#pragma omp parallel for schedule(static)
    for (Eigen::Index v = 0; v < V; ++v)
        for (std::int64_t e = ring.start[static_cast<std::size_t>(v)]; e < ring.start[static_cast<std::size_t>(v) + 1]; ++e)
            s.row(v) += n.row(ring.ids[static_cast<std::size_t>(e)]);
    for (Eigen::Index v = 0; v < V; ++v) {
        const double len = s.row(v).norm();
        s.row(v) = len > 0 ? Eigen::RowVector3d(s.row(v) / len) : Eigen::RowVector3d::Zero();
    }
    return s;
}

/// For each point, the mesh vertex nearest to it (the recentring's assignment, and the fit's for
/// the far-side cut).
inline IndexVector nearest_vertex(const Mesh& mesh, const PointsF& points) {
    return KdTree(mesh.vertices.cast<float>()).nearest(points);
}

}  // namespace pcp::detail
