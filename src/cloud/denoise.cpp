// Denoising by the neighbours' plane: projection onto it, or the mode of the heights along its
// normal (see include/pcp/cloud/denoise.hpp).
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
/// covariance (eigenvalues ascending), passed with the neighbours' indices to
/// `visit(i, centroid, solver, ids)`.
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
        visit(i, centroid, Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(covariance), neighbors.row(i));
    }
}

/// The median (the upper one of an even count) of x, reordered.
double median(std::vector<double>& x) {
    const auto mid = x.begin() + static_cast<std::ptrdiff_t>(x.size() / 2);
    std::nth_element(x.begin(), mid, x.end());
    return *mid;
}

/// The median of |x - median(x)| (x is overwritten).
double median_absolute_deviation(std::vector<double>& x) {
    const double m = median(x);
    for (double& v : x) v = std::abs(v - m);
    return median(x);
}

}  // namespace

double noise_ratio(const Eigen::Ref<const Points>& points, int neighbors) {
    check_neighbors(points.rows(), neighbors);
    std::vector<double> ratio(static_cast<std::size_t>(points.rows()));
    for_each_neighbourhood(Points(points), neighbors, [&](Eigen::Index i, const Eigen::Vector3d&, const auto& eigen, const auto&) {
        const Eigen::Vector3d l = eigen.eigenvalues().cwiseMax(0.0);
        ratio[std::size_t(i)] = l.sum() > 0 ? std::sqrt(l(0) / l.sum()) : 0.0;
    });
    return median(ratio);
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
    PCP_CHECK(options.mode_width >= 0 && std::isfinite(options.mode_width),
              "denoise: mode_width must be finite and >= 0 (got " << options.mode_width << ")");
    const int passes = denoise_passes(points, options);
    const int k = options.neighbors;
    Points current = points;
    for (int pass = 0; pass < passes; ++pass) {
        Points next(current.rows(), 3);
        if (options.mode_width == 0) {
            for_each_neighbourhood(current, k, [&](Eigen::Index i, const Eigen::Vector3d& centroid, const auto& eigen, const auto&) {
                const Eigen::Vector3d normal = eigen.eigenvectors().col(0);  // smallest eigenvalue first
                const Eigen::Vector3d p = current.row(i).transpose();
                next.row(i) = (p - normal * normal.dot(p - centroid)).transpose();
            });
            current = std::move(next);
            continue;
        }
        // The neighbours' heights above each point along its plane's normal, and their spread.
        Points normals(current.rows(), 3);
        Eigen::MatrixXf heights(k, current.rows());
        std::vector<double> spread(static_cast<std::size_t>(current.rows()));
        for_each_neighbourhood(current, k, [&](Eigen::Index i, const Eigen::Vector3d&, const auto& eigen, const auto& ids) {
            const Eigen::Vector3d normal = eigen.eigenvectors().col(0);
            normals.row(i) = normal.transpose();
            const Eigen::RowVector3d p = current.row(i);
            thread_local std::vector<double> h;  // one buffer per OpenMP worker, not one per point
            h.resize(static_cast<std::size_t>(k));
            for (int j = 0; j < k; ++j) {
                h[std::size_t(j)] = (current.row(ids(j)) - p).dot(normal.transpose());
                heights(j, i) = static_cast<float>(h[std::size_t(j)]);
            }
            spread[std::size_t(i)] = 1.4826 * median_absolute_deviation(h);
        });
        const double sigma = options.mode_width * median(spread);
        if (!(sigma > 0)) return current;  // no spread across the planes: nothing to denoise
#pragma omp parallel for schedule(static)
        for (Eigen::Index i = 0; i < current.rows(); ++i) {
            double m = 0;  // mean shift from the point's own height
            for (int round = 0; round < 20; ++round) {
                double sw = 0, sh = 0;
                for (int j = 0; j < k; ++j) {
                    const double h = heights(j, i), z = (h - m) / sigma;
                    const double w = std::exp(-0.5 * z * z);
                    sw += w;
                    sh += w * h;
                }
                const double step = sh / sw - m;  // the point itself (h = 0) keeps sw > 0
                m += step;
                if (std::abs(step) < 1e-4 * sigma) break;
            }
            next.row(i) = current.row(i) + m * normals.row(i);
        }
        current = std::move(next);
    }
    return current;
}

}  // namespace pcp
