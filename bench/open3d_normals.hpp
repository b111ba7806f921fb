// Open3D's normals as its users compute them, shared by the benchmark tools pcp_poisson_open3d and
// pcp_orient_open3d (not part of the library): PCA on the `neighbours` nearest points, oriented by
// orient_normals_consistent_tangent_plane(orient_k).
#pragma once

#include "pcp/core/error.hpp"
#include "pcp/core/types.hpp"

#include <open3d/geometry/KDTreeSearchParam.h>
#include <open3d/geometry/PointCloud.h>

#include <string>

namespace pcp_bench {

/// The points of `points` (N x 3) as an Open3D cloud with oriented normals; `name` for messages.
inline open3d::geometry::PointCloud open3d_oriented_cloud(const pcp::Points& points, int neighbours, int orient_k,
                                                          const std::string& name) {
    PCP_CHECK(points.rows() > neighbours, name << ": " << points.rows() << " points, fewer than the " << neighbours << " neighbours");
    open3d::geometry::PointCloud pc;
    pc.points_.reserve(static_cast<std::size_t>(points.rows()));
    for (Eigen::Index i = 0; i < points.rows(); ++i) pc.points_.emplace_back(points.row(i).transpose());
    pc.EstimateNormals(open3d::geometry::KDTreeSearchParamKNN(neighbours));
    pc.OrientNormalsConsistentTangentPlane(static_cast<std::size_t>(orient_k));
    return pc;
}

}  // namespace pcp_bench
