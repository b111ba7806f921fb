// Normalisation of a point cloud into the unit box, and the geometric checks an input must pass.
// The unit box maps the cloud's bounding box centre to the origin and its longest edge to length 1
// (coordinates in [-0.5, 0.5]); the inverse is kept in double so that meshes go back to the
// input's own frame exactly (METHOD.md section 1, "normalise ... keep the inverse").
#pragma once

#include "pcp/core/types.hpp"

#include <string>

namespace pcp {

/// unit = (p - center) / scale; p = unit * scale + center.
struct Normalization {
    Eigen::Vector3d center = Eigen::Vector3d::Zero();
    double scale = 1.0;

    /// @param[in] points N x 3, input frame.  @return N x 3 float, unit box.
    PointsF to_unit(const Eigen::Ref<const Points>& points) const;
    /// @param[in] points N x 3, input frame.  @return N x 3 double, unit box.
    Points to_unit_double(const Eigen::Ref<const Points>& points) const;
    /// @param[in] unit N x 3 in the unit box.  @return N x 3 double, input frame.
    Points from_unit(const Eigen::Ref<const Points>& unit) const;
    /// Maps a mesh from the unit box back to the input frame (faces unchanged).
    Mesh from_unit(const Mesh& unit_mesh) const;
};

/// Bounding box of `points` (N x 3, N >= 1).
Aabb bounding_box(const Eigen::Ref<const Points>& points);

/// The normalisation that maps the bounding box of `points` to the unit box (longest edge 1).
/// Requires a non-degenerate box (see check_point_cloud).
Normalization fit_unit_box(const Eigen::Ref<const Points>& points);

/// Throws pcp::Error, naming `source` (usually the file name), unless the cloud is usable: at least
/// `min_points` points, all coordinates finite, and not all identical, collinear or coplanar.
void check_point_cloud(const Eigen::Ref<const Points>& points, const std::string& source,
                       Eigen::Index min_points);

}  // namespace pcp
