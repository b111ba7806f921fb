// Plane-projection denoising (see include/pcp/denoise.hpp).
#include "pcp/cloud/denoise.hpp"

#include "pcp/core/error.hpp"
#include "pcp/cloud/kdtree.hpp"
#include "pcp/cloud/normalize.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <vector>

namespace pcp {
namespace {

void check_neighbors(Eigen::Index n, int neighbors) {
    PCP_CHECK(neighbors >= 3 && neighbors <= 256, "denoise: neighbors must be in [3, 256] (got " << neighbors << ")");
    PCP_CHECK(n >= neighbors, "denoise: " << n << " points, fewer than the " << neighbors << " neighbours asked for");
}

/// For every point: the centroid of its k nearest neighbours and the eigen-decomposition of their
/// covariance (eigenvalues ascending), passed to `visit(i, centroid, solver)`.
template <class Visit>
void for_each_neighbourhood(const Points& points, int k, Visit visit) {
    const PointsF unit_points = fit_unit_box(points).to_unit(points);
    const KdTree tree(unit_points);
    NeighborIndices neighbors;
    NeighborDistances distances;
    tree.knn(unit_points, k, neighbors, distances);
#pragma omp parallel for schedule(static)
    for (Eigen::Index i = 0; i < points.rows(); ++i) {
        Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
        for (int j = 0; j < k; ++j) centroid += points.row(neighbors(i, j)).transpose();
        centroid /= k;
        Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
        for (int j = 0; j < k; ++j) {
            const Eigen::Vector3d d = points.row(neighbors(i, j)).transpose() - centroid;
            covariance += d * d.transpose();
        }
        visit(i, centroid, Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(covariance));
    }
}

}  // namespace

double noise_ratio(const Eigen::Ref<const Points>& points, int neighbors) {
    check_neighbors(points.rows(), neighbors);
    std::vector<double> ratio(static_cast<std::size_t>(points.rows()));
    for_each_neighbourhood(Points(points), neighbors, [&](Eigen::Index i, const Eigen::Vector3d&, const auto& eigen) {
        const Eigen::Vector3d l = eigen.eigenvalues().cwiseMax(0.0);
        ratio[std::size_t(i)] = l.sum() > 0 ? std::sqrt(l(0) / l.sum()) : 0.0;
    });
    std::nth_element(ratio.begin(), ratio.begin() + ratio.size() / 2, ratio.end());
    return ratio[ratio.size() / 2];
}

int denoise_passes(const Eigen::Ref<const Points>& points, const DenoiseOptions& options) {
    PCP_CHECK(options.passes >= 0 && options.auto_passes >= 0,
              "denoise: passes must be >= 0 (got " << options.passes << ", auto " << options.auto_passes << ")");
    if (!options.automatic) return options.passes;
    return noise_ratio(points, options.neighbors) > options.auto_threshold ? options.auto_passes : 0;
}

Points denoise_points(const Eigen::Ref<const Points>& points, const DenoiseOptions& options) {
    PCP_CHECK(options.neighbors >= 3 && options.neighbors <= 256,
              "denoise: neighbors must be in [3, 256] (got " << options.neighbors << ")");
    if (!options.automatic && options.passes == 0) return points;
    check_neighbors(points.rows(), options.neighbors);
    const int passes = denoise_passes(points, options);
    Points current = points;
    for (int pass = 0; pass < passes; ++pass) {
        Points next(current.rows(), 3);
        for_each_neighbourhood(current, options.neighbors, [&](Eigen::Index i, const Eigen::Vector3d& centroid, const auto& eigen) {
            const Eigen::Vector3d normal = eigen.eigenvectors().col(0);  // smallest eigenvalue first
            const Eigen::Vector3d p = current.row(i).transpose();
            next.row(i) = (p - normal * normal.dot(p - centroid)).transpose();
        });
        current = std::move(next);
    }
    return current;
}

}  // namespace pcp
