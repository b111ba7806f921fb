// The concrete data types passed across libpcp's public API. Geometry in the input's frame is kept
// in double (scans carry large offsets that float would truncate); learning happens in float in the
// unit box. Point sets are row-major N x 3, so that their memory is also a column-major 3 x N
// "features x batch" block the networks can map without a copy.
#pragma once

#include <Eigen/Core>

#include <cstdint>
#include <map>
#include <string>

namespace pcp {

/// N x 3 points, double, in the input's own frame.
using Points = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
/// N x 3 points, float, in unit-box (or region) coordinates.
using PointsF = Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor>;
/// M x 3 triangle vertex indices into a vertex array.
using Faces = Eigen::Matrix<std::int32_t, Eigen::Dynamic, 3, Eigen::RowMajor>;

/// A point cloud as read from a file: positions plus any extra per-point scalar properties
/// (normals "nx","ny","nz", colours "red",..., "sdf", ...), each a vector of N values.
struct PointCloud {
    Points points;
    std::map<std::string, Eigen::VectorXd> properties;
};

/// A triangle mesh. Faces are counter-clockwise seen from outside (outward normals).
struct Mesh {
    Points vertices;
    Faces faces;
};

/// Axis-aligned bounding box.
struct Aabb {
    Eigen::Vector3d min = Eigen::Vector3d::Zero();
    Eigen::Vector3d max = Eigen::Vector3d::Zero();
    Eigen::Vector3d extent() const { return max - min; }
    Eigen::Vector3d center() const { return 0.5 * (min + max); }
};

}  // namespace pcp
