// Gaussian query sampling around the cloud's points with per-point spreads (METHOD.md section 1).
// The per-point RNG stream makes every query a function of (seed, point index, query index) only.
#include "pcp/cloud/sampling.hpp"

#include "pcp/core/error.hpp"
#include "pcp/core/rng.hpp"

#include <algorithm>
#include <cmath>

namespace pcp {

namespace {
void check_options(const SamplingOptions& o) {
    PCP_CHECK(o.sigma_neighbor >= 1, "sampling: sigma_neighbor must be >= 1");
    PCP_CHECK(o.queries_per_point >= 1, "sampling: queries_per_point must be >= 1");
    PCP_CHECK(!o.spreads.empty(), "sampling: at least one spread factor is needed");
    for (float s : o.spreads) PCP_CHECK(s > 0.0f && std::isfinite(s), "sampling: spread factors must be > 0");
    PCP_CHECK(o.min_sigma_fraction >= 0.0f, "sampling: min_sigma_fraction must be >= 0");
}
}  // namespace

Eigen::Index min_points_for(const SamplingOptions& options) { return options.sigma_neighbor + 1; }

SamplingOptions capped_at_draws(SamplingOptions options, std::int64_t draws) {
    options.max_queries = options.max_queries > 0 ? std::min(options.max_queries, draws) : draws;
    return options;
}

Eigen::VectorXf point_sigmas(const KdTree& tree, const SamplingOptions& options) {
    check_options(options);
    PCP_CHECK(tree.size() >= min_points_for(options),
              "sampling: " << tree.size() << " points, but at least " << min_points_for(options)
                           << " are needed");
    // k = sigma_neighbor + 1 because each point is its own nearest neighbour.
    Eigen::VectorXf sigma = tree.kth_distance(tree.points(), options.sigma_neighbor + 1);
    const PointsF& pts = tree.points();
    const float diagonal = (pts.colwise().maxCoeff() - pts.colwise().minCoeff()).norm();
    const float floor = options.min_sigma_fraction * diagonal;
    sigma = sigma.cwiseMax(floor);
    return sigma;
}

QuerySet sample_queries(const KdTree& tree, const SamplingOptions& options, std::uint64_t seed) {
    QuerySet set;
    set.sigma = point_sigmas(tree, options);
    const PointsF& pts = tree.points();
    const Eigen::Index n = pts.rows();
    PCP_CHECK(options.uniform_fraction >= 0.0f && options.uniform_margin >= 0.0f,
              "query sampling: uniform_fraction and uniform_margin must be >= 0");
    PCP_CHECK(options.max_queries >= 0, "query sampling: max_queries must be >= 0");
    Eigen::Index near = n * options.queries_per_point;
    auto uniform = static_cast<Eigen::Index>(std::llround(static_cast<double>(options.uniform_fraction) * static_cast<double>(near)));
    if (options.max_queries > 0 && near + uniform > options.max_queries) {  // the same ratio, fewer of both
        const double scale = static_cast<double>(options.max_queries) / static_cast<double>(near + uniform);
        near = std::max<Eigen::Index>(1, static_cast<Eigen::Index>(std::floor(static_cast<double>(near) * scale)));
        uniform = std::max<Eigen::Index>(0, static_cast<Eigen::Index>(options.max_queries) - near);
    }
    const Eigen::Index m = near + uniform;
    set.queries.resize(m, 3);
    const auto n_spreads = static_cast<Eigen::Index>(options.spreads.size());
    // Point i's queries are rows first(i) .. first(i + 1) - 1: queries_per_point each without a
    // cap, an even share of `near` under one.
    const auto first = [&](Eigen::Index i) {
        return static_cast<Eigen::Index>(static_cast<std::int64_t>(i) * static_cast<std::int64_t>(near) / static_cast<std::int64_t>(n));
    };
#pragma omp parallel for schedule(static, 256)
    for (Eigen::Index i = 0; i < n; ++i) {
        Rng rng(seed, static_cast<std::uint64_t>(i));
        const Eigen::Index begin = first(i), count = first(i + 1) - begin;
        for (Eigen::Index j = 0; j < count; ++j) {
            const float sd = options.spreads[static_cast<std::size_t>(j % n_spreads)] * set.sigma(i);
            const Eigen::Index row = begin + j;
            for (int c = 0; c < 3; ++c)
                set.queries(row, c) = pts(i, c) + sd * static_cast<float>(rng.normal());
        }
    }
    if (uniform > 0) {
        const Eigen::RowVector3f lo = pts.colwise().minCoeff(), hi = pts.colwise().maxCoeff();
        const float grow = options.uniform_margin * (hi - lo).maxCoeff();
        const Eigen::RowVector3f base = lo.array() - grow, size = (hi - lo).array() + 2 * grow;
        constexpr std::uint64_t kUniformStreams = 1ull << 62;  // disjoint from the per-point streams
#pragma omp parallel for schedule(static, 4096)
        for (Eigen::Index k = 0; k < uniform; ++k) {
            Rng rng(seed, kUniformStreams + static_cast<std::uint64_t>(k));
            for (int c = 0; c < 3; ++c)
                set.queries(near + k, c) = base(c) + size(c) * static_cast<float>(rng.uniform());
        }
    }
    set.target_ids = tree.nearest(set.queries);
    set.targets.resize(m, 3);
#pragma omp parallel for schedule(static, 4096)
    for (Eigen::Index r = 0; r < m; ++r) set.targets.row(r) = pts.row(set.target_ids(r));
    return set;
}

}  // namespace pcp
