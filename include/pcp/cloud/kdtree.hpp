// KdTree: exact nearest-neighbour queries over a 3D float point set (unit-box coordinates), with
// batched versions parallelised with OpenMP. nanoflann stays behind a pimpl, out of public headers.
// The tree owns a copy of its points, so it has no lifetime ties to the caller's arrays.
#pragma once

#include "pcp/core/types.hpp"

#include <cstdint>
#include <memory>

namespace pcp {

/// N x k neighbour indices (row-major: one query per row).
using NeighborIndices = Eigen::Matrix<std::int32_t, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
/// N x k neighbour distances (Euclidean, not squared).
using NeighborDistances = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using IndexVector = Eigen::Matrix<std::int32_t, Eigen::Dynamic, 1>;

class KdTree {
public:
    /// Builds the tree over a copy of `points` (N x 3, N >= 1, N < 2^31).
    explicit KdTree(const Eigen::Ref<const PointsF>& points);
    ~KdTree();
    KdTree(KdTree&&) noexcept;
    KdTree& operator=(KdTree&&) noexcept;
    KdTree(const KdTree&) = delete;
    KdTree& operator=(const KdTree&) = delete;

    Eigen::Index size() const;
    const PointsF& points() const;

    /// Index of the nearest point to `q`; its distance in `*distance` if given.
    std::int32_t nearest_point(const Eigen::Vector3f& q, float* distance = nullptr) const;

    /// Nearest point index for each row of `queries` (M x 3); distances in `*distances` if given.
    /// OpenMP-parallel over queries.
    IndexVector nearest(const Eigen::Ref<const PointsF>& queries,
                        Eigen::VectorXf* distances = nullptr) const;

    /// The k nearest points (sorted by distance) of each row of `queries`: indices and distances,
    /// M x k each. k must be in [1, size()]. OpenMP-parallel over queries.
    void knn(const Eigen::Ref<const PointsF>& queries, int k, NeighborIndices& indices,
             NeighborDistances& distances) const;

    /// Distance from each row of `queries` to its k-th nearest point (k = 1: the nearest).
    Eigen::VectorXf kth_distance(const Eigen::Ref<const PointsF>& queries, int k) const;

    /// pcp::sampling_scale of this tree, measured on the first call and kept (thread-safe).
    double sampling_scale() const;

private:
    class Impl;
    std::unique_ptr<Impl> impl_;
};

/// A sampling scale of the tree's cloud: the median over its points of the distance to their 10th
/// nearest other point (about 3.7 x the nearest-neighbour spacing of an even sampling; duplicates
/// and the denoiser's collapsed pairs do not shrink it). 0 for fewer than 2 points.
double sampling_scale(const KdTree& tree);

}  // namespace pcp
