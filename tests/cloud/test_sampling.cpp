// Tests for pcp/sampling.hpp: the query statistics of METHOD.md section 1 and determinism.
#include "pcp/cloud/kdtree.hpp"
#include "pcp/core/rng.hpp"
#include "pcp/cloud/sampling.hpp"
#include "pcp/cloud/shapes.hpp"
#include "pcp/core/error.hpp"

#include <catch2/catch.hpp>

#include <omp.h>

TEST_CASE("sampling: offsets are N(0, (k sigma)^2) per axis", "[sampling]") {
    const pcp::PointCloud sphere = pcp::sample_sphere(2000, 0.4, Eigen::Vector3d::Zero(), 7);
    const pcp::KdTree tree(sphere.points.cast<float>());
    pcp::SamplingOptions opts;
    opts.queries_per_point = 100;
    const pcp::QuerySet set = pcp::sample_queries(tree, opts, 42);
    REQUIRE(set.queries.rows() == 200000);
    // Normalised offsets (q - p) / (k sigma_p) must be standard normal on each axis.
    double sum[3] = {0, 0, 0}, sum2[3] = {0, 0, 0};
    const Eigen::Index per = opts.queries_per_point;
    for (Eigen::Index r = 0; r < set.queries.rows(); ++r) {
        const Eigen::Index i = r / per;
        const double sd = opts.spreads[0] * set.sigma(i);
        for (int c = 0; c < 3; ++c) {
            const double z = (set.queries(r, c) - tree.points()(i, c)) / sd;
            sum[c] += z;
            sum2[c] += z * z;
        }
    }
    const double m = static_cast<double>(set.queries.rows());
    for (int c = 0; c < 3; ++c) {
        const double mean = sum[c] / m, stddev = std::sqrt(sum2[c] / m - mean * mean);
        CHECK(std::abs(mean) < 0.02);           // mean offset within 2% of sigma of zero
        CHECK(std::abs(stddev - 1.0) < 0.05);   // standard deviation within 5% of k sigma
    }
    // sigma is the distance to the 50th other point.
    const Eigen::VectorXf d51 = tree.kth_distance(tree.points(), 51);
    CHECK(set.sigma.isApprox(d51));
}

TEST_CASE("sampling: targets are the nearest cloud points", "[sampling]") {
    const pcp::PointCloud torus = pcp::sample_torus(1500, 0.3, 0.1, 8);
    const pcp::KdTree tree(torus.points.cast<float>());
    pcp::SamplingOptions opts;
    opts.queries_per_point = 5;
    const pcp::QuerySet set = pcp::sample_queries(tree, opts, 1);
    for (Eigen::Index r = 0; r < set.queries.rows(); r += 37) {
        float best = std::numeric_limits<float>::max();
        for (Eigen::Index i = 0; i < tree.size(); ++i) best = std::min(best, (tree.points().row(i) - set.queries.row(r)).norm());
        REQUIRE((set.targets.row(r) - set.queries.row(r)).norm() == Approx(best).margin(1e-6));
        REQUIRE(set.targets.row(r) == tree.points().row(set.target_ids(r)));
    }
}

TEST_CASE("sampling: identical queries with 1 and 2 threads, different with another seed", "[sampling]") {
    const pcp::PointCloud sphere = pcp::sample_sphere(3000, 0.4, Eigen::Vector3d::Zero(), 9);
    const pcp::KdTree tree(sphere.points.cast<float>());
    pcp::SamplingOptions opts;
    opts.spreads = {0.5f, 1.0f};
    const int saved = omp_get_max_threads();
    omp_set_num_threads(1);
    const pcp::QuerySet one = pcp::sample_queries(tree, opts, 5);
    omp_set_num_threads(2);
    const pcp::QuerySet two = pcp::sample_queries(tree, opts, 5);
    omp_set_num_threads(saved);
    CHECK(one.queries == two.queries);
    CHECK(one.target_ids == two.target_ids);
    const pcp::QuerySet other = pcp::sample_queries(tree, opts, 6);
    CHECK(other.queries != one.queries);
}

TEST_CASE("sampling: duplicates get a non-zero spread and too few points are refused", "[sampling]") {
    pcp::PointCloud sphere = pcp::sample_sphere(200, 0.4, Eigen::Vector3d::Zero(), 10);
    sphere.points.topRows(80).rowwise() = sphere.points.row(0);
    const pcp::KdTree tree(sphere.points.cast<float>());
    const pcp::QuerySet set = pcp::sample_queries(tree, {}, 3);
    CHECK(set.sigma.minCoeff() > 0.0f);
    CHECK(set.queries.allFinite());
    const pcp::KdTree small(sphere.points.topRows(50).cast<float>());
    CHECK_THROWS_WITH(pcp::sample_queries(small, {}, 3), Catch::Contains("at least 51"));
}

TEST_CASE("sampling: uniform queries fill the grown box, keep nearest targets and are deterministic", "[sampling]") {
    const pcp::PointCloud torus = pcp::sample_torus(2000, 0.3, 0.1, 11);
    const pcp::KdTree tree(torus.points.cast<float>());
    pcp::SamplingOptions opts;
    opts.queries_per_point = 10;
    opts.uniform_fraction = 0.25f;
    opts.uniform_margin = 0.1f;
    const pcp::QuerySet set = pcp::sample_queries(tree, opts, 4);
    const Eigen::Index near = 2000 * 10, uniform = 5000;
    REQUIRE(set.queries.rows() == near + uniform);
    const Eigen::RowVector3f lo = tree.points().colwise().minCoeff(), hi = tree.points().colwise().maxCoeff();
    const float grow = 0.1f * (hi - lo).maxCoeff();
    const pcp::PointsF u = set.queries.bottomRows(uniform);
    CHECK(((u.rowwise() - (lo.array() - grow).matrix()).array() >= 0.0f).all());
    CHECK(((-u).rowwise() + (hi.array() + grow).matrix()).array().minCoeff() >= 0.0f);
    // Uniform: each half of the box along x holds about half of the queries (binomial sd ~ 35).
    const float mid = 0.5f * (lo(0) + hi(0));
    const auto left = (u.col(0).array() < mid).count();
    CHECK(std::abs(static_cast<double>(left) - 2500.0) < 200.0);
    // The near-surface queries are those of the plain sampling, unchanged by the extra ones.
    pcp::SamplingOptions plain = opts;
    plain.uniform_fraction = 0.0f;
    CHECK(pcp::sample_queries(tree, plain, 4).queries == set.queries.topRows(near));
    for (Eigen::Index r = near; r < set.queries.rows(); r += 97) {
        float best = std::numeric_limits<float>::max();
        for (Eigen::Index i = 0; i < tree.size(); ++i) best = std::min(best, (tree.points().row(i) - set.queries.row(r)).norm());
        REQUIRE((set.targets.row(r) - set.queries.row(r)).norm() == Approx(best).margin(1e-6));
    }
    CHECK(pcp::sample_queries(tree, opts, 4).queries == set.queries);
    opts.uniform_fraction = -0.1f;
    CHECK_THROWS_WITH(pcp::sample_queries(tree, opts, 4), Catch::Contains("uniform_fraction"));
}

TEST_CASE("sampling: max_queries caps the pool, keeps the uniform ratio and spreads the rest evenly over the points",
          "[sampling]") {
    const pcp::PointCloud sphere = pcp::sample_sphere(3000, 0.4, Eigen::Vector3d::Zero(), 11);
    const pcp::KdTree tree(sphere.points.cast<float>());
    pcp::SamplingOptions opts;
    opts.queries_per_point = 40;
    opts.uniform_fraction = 0.25f;
    const pcp::QuerySet full = pcp::sample_queries(tree, opts, 5);
    REQUIRE(full.queries.rows() == 3000 * 40 + 30000);
    // A cap above the pool changes nothing.
    opts.max_queries = full.queries.rows();
    CHECK(pcp::sample_queries(tree, opts, 5).queries == full.queries);
    // A cap below it: exactly max_queries, the near / uniform ratio kept (4 : 1), every point's
    // share floor or ceil of 8000 / 3000, each near query drawn around its own point, the first
    // queries of each point's stream the same as without the cap.
    opts.max_queries = 10000;
    const pcp::QuerySet capped = pcp::sample_queries(tree, opts, 5);
    REQUIRE(capped.queries.rows() == 10000);
    REQUIRE(capped.targets.rows() == 10000);
    const Eigen::Index near = 8000;
    Eigen::Index row = 0;
    for (Eigen::Index i = 0; i < 3000; ++i) {
        const Eigen::Index count = (i + 1) * near / 3000 - i * near / 3000;
        REQUIRE((count == 2 || count == 3));
        for (Eigen::Index j = 0; j < count; ++j, ++row) {
            CHECK(capped.queries.row(row) == full.queries.row(i * 40 + j));
            CHECK((capped.queries.row(row) - tree.points().row(i)).norm() < 6 * opts.spreads[0] * capped.sigma(i));
        }
    }
    CHECK(row == near);
    // The uniform queries lie in the grown box and keep nearest targets.
    const Eigen::RowVector3f lo = tree.points().colwise().minCoeff(), hi = tree.points().colwise().maxCoeff();
    const float grow = opts.uniform_margin * (hi - lo).maxCoeff() + 1e-6f;
    for (Eigen::Index r = near; r < capped.queries.rows(); ++r) {
        CHECK((capped.queries.row(r).array() >= lo.array() - grow).all());
        CHECK((capped.queries.row(r).array() <= hi.array() + grow).all());
    }
    const pcp::IndexVector ids = tree.nearest(capped.queries);
    CHECK(ids == capped.target_ids);
    // A cap below the number of points: some points get none, the total is still the cap.
    opts.max_queries = 1000;
    CHECK(pcp::sample_queries(tree, opts, 5).queries.rows() == 1000);
    opts.max_queries = -1;
    CHECK_THROWS_AS(pcp::sample_queries(tree, opts, 5), pcp::Error);
}
