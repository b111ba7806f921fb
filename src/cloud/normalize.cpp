// Unit-box normalisation with an exact double inverse, and the input checks of issue "bad input":
// too few points, non-finite coordinates, and degenerate (identical / collinear / coplanar) clouds,
// detected from the eigenvalues of the covariance so that tilted lines and planes are caught too.
#include "pcp/cloud/normalize.hpp"

#include "pcp/core/error.hpp"

#include <Eigen/Eigenvalues>

namespace pcp {

PointsF Normalization::to_unit(const Eigen::Ref<const Points>& points) const {
    return to_unit_double(points).cast<float>();
}

Points Normalization::to_unit_double(const Eigen::Ref<const Points>& points) const {
    const double inv = 1.0 / scale;
    return ((points.rowwise() - center.transpose()) * inv);
}

Points Normalization::from_unit(const Eigen::Ref<const Points>& unit) const {
    return (unit * scale).rowwise() + center.transpose();
}

Mesh Normalization::from_unit(const Mesh& unit_mesh) const {
    return Mesh{from_unit(unit_mesh.vertices), unit_mesh.faces};
}

Aabb bounding_box(const Eigen::Ref<const Points>& points) {
    PCP_CHECK(points.rows() > 0, "bounding box of an empty point set");
    Aabb box;
    box.min = points.colwise().minCoeff().transpose();
    box.max = points.colwise().maxCoeff().transpose();
    return box;
}

Normalization fit_unit_box(const Eigen::Ref<const Points>& points) {
    const Aabb box = bounding_box(points);
    const double longest = box.extent().maxCoeff();
    PCP_CHECK(longest > 0.0 && std::isfinite(longest),
              "cannot normalise a point set whose bounding box is empty");
    Normalization n;
    n.center = box.center();
    n.scale = longest;
    return n;
}

void check_point_cloud(const Eigen::Ref<const Points>& points, const std::string& source,
                       Eigen::Index min_points) {
    const Eigen::Index n = points.rows();
    PCP_CHECK(n > 0, source << ": no points");
    for (Eigen::Index i = 0; i < n; ++i)
        PCP_CHECK(points.row(i).allFinite(),
                  source << ": point " << i << " has a non-finite coordinate (NaN or Inf)");
    PCP_CHECK(n >= min_points, source << ": " << n << " points, but at least " << min_points
                                      << " are needed (the query spread uses each point's "
                                      << (min_points - 1) << "th neighbour)");
    const Eigen::RowVector3d mean = points.colwise().mean();
    const Eigen::Matrix3d cov = (points.rowwise() - mean).transpose() * (points.rowwise() - mean) /
                                static_cast<double>(n);
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov, Eigen::EigenvaluesOnly);
    const Eigen::Vector3d lambda = eig.eigenvalues();  // ascending
    // Relative thresholds on variances: 1e-10 ~ a thickness below 1e-5 of the cloud's size:
    // above the rounding of coordinates stored with 6 decimals, below any real scan's noise.
    PCP_CHECK(lambda(2) > 1e-300 && lambda(2) > 1e-20 * mean.squaredNorm(),
              source << ": all points are identical (degenerate bounding box)");
    PCP_CHECK(lambda(1) > 1e-10 * lambda(2),
              source << ": all points lie on a line (degenerate: a surface needs a 3D cloud)");
    PCP_CHECK(lambda(0) > 1e-10 * lambda(2),
              source << ": all points lie in a plane (degenerate: a closed surface needs a 3D cloud)");
}

}  // namespace pcp
