// Exact point-to-triangle-mesh distances through CGAL's AABB tree, behind a pimpl so that CGAL
// stays in src/core/triangle_distance.cpp.
#pragma once

#include "pcp/core/types.hpp"

#include <memory>

namespace pcp::detail {

class TriangleDistance {
public:
    explicit TriangleDistance(const Mesh& mesh);
    ~TriangleDistance();
    /// Distance from each row of `points` (N x 3) to the nearest triangle. Thread-safe, parallel.
    Eigen::VectorXd distances(const Eigen::Ref<const Points>& points) const;
    /// The unit normal of the triangle nearest to each row of `points` (N x 3), by its vertex order
    /// (outward for counter-clockwise faces). Thread-safe, parallel.
    Points nearest_face_normals(const Eigen::Ref<const Points>& points) const;
    /// The index (into the mesh's faces) of the triangle nearest to each row of `points`, and in
    /// `closest` (N x 3) the nearest point on it. Thread-safe, parallel.
    Eigen::VectorXi nearest_faces(const Eigen::Ref<const Points>& points, Points& closest) const;

private:
    class Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace pcp::detail
