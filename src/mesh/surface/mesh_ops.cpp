// Offsets along the vertex normals, and trims of faces and components (see
// include/pcp/mesh/surface/mesh_ops.hpp).
#include "pcp/mesh/surface/mesh_ops.hpp"

#include "pcp/core/error.hpp"
#include "mesh/surface/mesh_rings.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <vector>

namespace pcp {

using detail::Components;
using detail::OneRing;
using detail::keep_components;
using detail::vertex_normals;

Mesh offset_along_normals(const Mesh& mesh, double distance) {
    PCP_CHECK(std::isfinite(distance), "offset along normals: the distance must be finite");
    if (distance == 0.0) return mesh;
    return offset_along_normals(mesh, Eigen::VectorXd::Constant(mesh.vertices.rows(), distance));
}

Mesh offset_along_normals(const Mesh& mesh, const Eigen::VectorXd& distances) {
    PCP_CHECK(distances.size() == mesh.vertices.rows(), "offset along normals: " << distances.size()
                                                        << " distances for " << mesh.vertices.rows() << " vertices");
    PCP_CHECK(distances.allFinite(), "offset along normals: the distances must be finite");
    Mesh out = mesh;
    if (mesh.faces.rows() == 0) return out;
    for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f)
        for (int k = 0; k < 3; ++k)
            PCP_CHECK(mesh.faces(f, k) >= 0 && mesh.faces(f, k) < mesh.vertices.rows(),
                      "offset along normals: face " << f << " indexes vertex " << mesh.faces(f, k) << " of "
                                                    << mesh.vertices.rows());
    const OneRing ring(mesh);
    out.vertices.array() += vertex_normals(mesh, ring).array().colwise() * distances.array();
    return out;
}

Points mesh_vertex_normals(const Mesh& mesh) { return vertex_normals(mesh, OneRing(mesh)); }

Mesh trim_unsupported_faces(const Mesh& unit_mesh, const KdTree& cloud, double radius, std::int64_t* removed) {
    PCP_CHECK(radius > 0 && std::isfinite(radius), "trim_unsupported_faces: radius must be > 0, got " << radius);
    const Eigen::Index F = unit_mesh.faces.rows(), V = unit_mesh.vertices.rows();
    PCP_CHECK(F == 0 || (unit_mesh.faces.minCoeff() >= 0 && unit_mesh.faces.maxCoeff() < V),
              "trim_unsupported_faces: a face index is out of range");
    PointsF centroids(F, 3);
    for (Eigen::Index f = 0; f < F; ++f)
        centroids.row(f) = ((unit_mesh.vertices.row(unit_mesh.faces(f, 0)) + unit_mesh.vertices.row(unit_mesh.faces(f, 1)) +
                             unit_mesh.vertices.row(unit_mesh.faces(f, 2))) /
                            3.0)
                               .cast<float>();
    Eigen::VectorXf distance(F);
    if (F > 0) cloud.nearest(centroids, &distance);
    std::vector<int> new_index(static_cast<std::size_t>(V), -1);
    std::vector<Eigen::Index> kept_faces;
    for (Eigen::Index f = 0; f < F; ++f)
        if (static_cast<double>(distance(f)) <= radius) kept_faces.push_back(f);
    Mesh out;
    int next = 0;
    for (Eigen::Index f : kept_faces)
        for (int c = 0; c < 3; ++c) {
            int& id = new_index[static_cast<std::size_t>(unit_mesh.faces(f, c))];
            if (id < 0) id = next++;
        }
    out.vertices.resize(next, 3);
    for (Eigen::Index v = 0; v < V; ++v)
        if (new_index[static_cast<std::size_t>(v)] >= 0) out.vertices.row(new_index[static_cast<std::size_t>(v)]) = unit_mesh.vertices.row(v);
    out.faces.resize(static_cast<Eigen::Index>(kept_faces.size()), 3);
    for (std::size_t k = 0; k < kept_faces.size(); ++k)
        for (int c = 0; c < 3; ++c)
            out.faces(static_cast<Eigen::Index>(k), c) = new_index[static_cast<std::size_t>(unit_mesh.faces(kept_faces[k], c))];
    if (removed) *removed = F - static_cast<std::int64_t>(kept_faces.size());
    return out;
}

Mesh remove_small_components(const Mesh& mesh, double min_diagonal, std::int64_t* removed) {
    PCP_CHECK(min_diagonal >= 0 && std::isfinite(min_diagonal), "remove_small_components: min_diagonal must be finite and >= 0, got " << min_diagonal);
    const Eigen::Index V = mesh.vertices.rows(), F = mesh.faces.rows();
    PCP_CHECK(F == 0 || (mesh.faces.minCoeff() >= 0 && mesh.faces.maxCoeff() < V), "remove_small_components: a face index is out of range");
    const Components comp(mesh);
    std::vector<char> keep_root(static_cast<std::size_t>(V), 1);
    std::int64_t n_removed = 0;
    for (Eigen::Index v = 0; v < V; ++v)
        if (comp.count[static_cast<std::size_t>(v)] > 0 && v != comp.largest && comp.diagonal(v) < min_diagonal) {
            keep_root[static_cast<std::size_t>(v)] = 0;
            ++n_removed;
        }
    if (removed) *removed = n_removed;
    return n_removed == 0 ? mesh : keep_components(mesh, comp, keep_root);
}

}  // namespace pcp
