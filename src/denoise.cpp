// Plane-projection denoising (see include/pcp/denoise.hpp).
#include "pcp/denoise.hpp"

#include "pcp/error.hpp"
#include "pcp/kdtree.hpp"
#include "pcp/normalize.hpp"

#include <Eigen/Eigenvalues>

namespace pcp {

Points denoise_points(const Eigen::Ref<const Points>& points, const DenoiseOptions& options) {
    PCP_CHECK(options.passes >= 0, "denoise: passes must be >= 0 (got " << options.passes << ")");
    PCP_CHECK(options.neighbors >= 3 && options.neighbors <= 256,
              "denoise: neighbors must be in [3, 256] (got " << options.neighbors << ")");
    Points current = points;
    if (options.passes == 0) return current;
    PCP_CHECK(points.rows() >= options.neighbors,
              "denoise: " << points.rows() << " points, fewer than the " << options.neighbors << " neighbours asked for");
    const int k = options.neighbors;
    for (int pass = 0; pass < options.passes; ++pass) {
        const Normalization unit = fit_unit_box(current);
        const PointsF unit_points = unit.to_unit(current);
        const KdTree tree(unit_points);
        NeighborIndices neighbors;
        NeighborDistances distances;
        tree.knn(unit_points, k, neighbors, distances);
        Points next(current.rows(), 3);
#pragma omp parallel for schedule(static)
        for (Eigen::Index i = 0; i < current.rows(); ++i) {
            Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
            for (int j = 0; j < k; ++j) centroid += current.row(neighbors(i, j)).transpose();
            centroid /= k;
            Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
            for (int j = 0; j < k; ++j) {
                const Eigen::Vector3d d = current.row(neighbors(i, j)).transpose() - centroid;
                covariance += d * d.transpose();
            }
            const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(covariance);
            const Eigen::Vector3d normal = eigen.eigenvectors().col(0);  // smallest eigenvalue first
            const Eigen::Vector3d p = current.row(i).transpose();
            next.row(i) = (p - normal * normal.dot(p - centroid)).transpose();
        }
        current = std::move(next);
    }
    return current;
}

}  // namespace pcp
