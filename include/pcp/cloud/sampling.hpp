// Query sampling (METHOD.md section 1, Neural-Pull's scheme): for each point p of the cloud,
// sigma_p = distance to its `sigma_neighbor`-th nearest other point; queries q ~ N(p, (s sigma_p)^2 I)
// for a spread factor s; the target of each query is its nearest point of the cloud. Draws come
// from per-point RNG streams derived from (seed, point index), so the queries are identical
// whatever the thread count.
#pragma once

#include "pcp/cloud/kdtree.hpp"
#include "pcp/core/types.hpp"

#include <cstdint>
#include <vector>

namespace pcp {

struct SamplingOptions {
    /// sigma_p is the distance to the sigma_neighbor-th nearest *other* point (paper: 50).
    int sigma_neighbor = 50;
    /// Spread factors s: query j of a point uses spreads[j % spreads.size()] (release: 0.5; one
    /// release version alternates 0.5 and 1.0).
    std::vector<float> spreads = {0.5f};
    /// Queries drawn around each point (paper: 40).
    int queries_per_point = 40;
    /// sigma_p is clamped below to this fraction of the cloud's bounding-box diagonal, so that
    /// clusters of duplicate points still get a non-zero spread.
    float min_sigma_fraction = 1e-5f;
    /// Extra queries drawn uniformly in the cloud's bounding box grown by uniform_margin times
    /// its longest edge on every side, as a fraction of the near-surface queries (0 = the paper's
    /// sampling). Their targets are nearest points like all others, so the pulling loss asks
    /// |F| to match the distance to the data there too: that forbids zero crossings far from
    /// the data (floating blobs, shells inside thick parts). Not in the paper: a libpcp option.
    float uniform_fraction = 0.0f;
    float uniform_margin = 0.05f;
    /// At most this many queries in all (0: no cap). A training stage draws a fixed number of
    /// queries from its pool, so a pool larger than that costs memory and buys nothing: the
    /// trainers cap it at their draws (QueryNetFitter: steps x queries_per_step; the prior: its
    /// draws per region). Under the cap the near-surface and uniform queries keep their ratio, and
    /// the near-surface ones are spread evenly over the points (point i gets
    /// floor((i + 1) K / N) - floor(i K / N) of the K).
    std::int64_t max_queries = 0;
};

/// `options` with max_queries lowered to `draws` (the queries a training stage draws from its
/// pool); a smaller cap already set is kept.
SamplingOptions capped_at_draws(SamplingOptions options, std::int64_t draws);

/// The minimum number of points sample_queries needs with these options.
Eigen::Index min_points_for(const SamplingOptions& options);

struct QuerySet {
    PointsF queries;       ///< M x 3, M = K + U with K = N * queries_per_point near-surface queries, point
                           ///< i's in rows i*qpp .. i*qpp+qpp-1, and the last U = round(uniform_fraction * K)
                           ///< uniform (under SamplingOptions::max_queries, K and U shrink alike and
                           ///< point i's rows are floor(i K / N) .. floor((i + 1) K / N) - 1)
    PointsF targets;       ///< M x 3, nearest cloud point of each query
    IndexVector target_ids;  ///< M, index of the target in the cloud
    Eigen::VectorXf sigma;   ///< N, sigma_p of each cloud point
};

/// sigma_p for every point of the tree's cloud (the distance to its sigma_neighbor-th other point,
/// clamped below as described in SamplingOptions).
Eigen::VectorXf point_sigmas(const KdTree& tree, const SamplingOptions& options);

/// Draws the query set around the points of `tree` (its own cloud). OpenMP-parallel; the result
/// depends only on the cloud, the options and `seed`.
QuerySet sample_queries(const KdTree& tree, const SamplingOptions& options, std::uint64_t seed);

}  // namespace pcp
