// Exact point-to-triangle-mesh distances through CGAL's AABB tree, behind a pimpl so that CGAL
// stays in src/detail/triangle_distance.cpp.
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

private:
    class Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace pcp::detail
