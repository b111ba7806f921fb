// Tests for pcp/kdtree.hpp against brute force.
#include "pcp/cloud/kdtree.hpp"
#include "pcp/core/rng.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <numeric>
#include <vector>

#include <omp.h>

namespace {
pcp::PointsF random_cloud(Eigen::Index n, std::uint64_t seed) {
    pcp::Rng rng(seed);
    pcp::PointsF p(n, 3);
    for (Eigen::Index i = 0; i < n; ++i)
        for (int c = 0; c < 3; ++c) p(i, c) = static_cast<float>(rng.uniform() - 0.5);
    return p;
}
}  // namespace

TEST_CASE("kdtree: k nearest neighbours equal brute force on 10,000 points", "[kdtree]") {
    const pcp::PointsF cloud = random_cloud(10000, 11);
    const pcp::PointsF queries = random_cloud(200, 12) * 1.2f;
    const pcp::KdTree tree(cloud);
    const int k = 16;
    pcp::NeighborIndices idx;
    pcp::NeighborDistances dist;
    tree.knn(queries, k, idx, dist);
    const Eigen::VectorXf kth = tree.kth_distance(queries, k);
    Eigen::VectorXf nearest_dist;
    const pcp::IndexVector nearest = tree.nearest(queries, &nearest_dist);
    for (Eigen::Index q = 0; q < queries.rows(); ++q) {
        std::vector<float> d2(static_cast<std::size_t>(cloud.rows()));
        for (Eigen::Index i = 0; i < cloud.rows(); ++i) d2[static_cast<std::size_t>(i)] = (cloud.row(i) - queries.row(q)).squaredNorm();
        std::vector<int> order(d2.size());
        std::iota(order.begin(), order.end(), 0);
        std::partial_sort(order.begin(), order.begin() + k, order.end(), [&](int a, int b) { return d2[static_cast<std::size_t>(a)] < d2[static_cast<std::size_t>(b)]; });
        for (int j = 0; j < k; ++j) {
            const float brute = std::sqrt(d2[static_cast<std::size_t>(order[static_cast<std::size_t>(j)])]);
            REQUIRE(dist(q, j) == Approx(brute).margin(1e-6));
            // Indices agree unless two points are at (numerically) the same distance.
            if (idx(q, j) != order[static_cast<std::size_t>(j)])
                REQUIRE(std::sqrt(d2[static_cast<std::size_t>(idx(q, j))]) == Approx(brute).margin(1e-6));
        }
        REQUIRE(kth(q) == Approx(dist(q, k - 1)).margin(1e-7));
        REQUIRE(nearest_dist(q) == Approx(dist(q, 0)).margin(1e-7));
        REQUIRE((cloud.row(nearest(q)) - queries.row(q)).norm() == Approx(dist(q, 0)).margin(1e-6));
        float single_dist = -1.0f;
        REQUIRE(tree.nearest_point(Eigen::Vector3f(queries.row(q).transpose()), &single_dist) == nearest(q));
        REQUIRE(single_dist == Approx(nearest_dist(q)).margin(1e-7));
    }
}

TEST_CASE("kdtree: results do not depend on the thread count", "[kdtree]") {
    const pcp::PointsF cloud = random_cloud(5000, 21);
    const pcp::KdTree tree(cloud);
    const int saved = omp_get_max_threads();
    omp_set_num_threads(1);
    const pcp::IndexVector one = tree.nearest(cloud * 0.9f);
    omp_set_num_threads(2);
    const pcp::IndexVector two = tree.nearest(cloud * 0.9f);
    omp_set_num_threads(saved);
    CHECK((one.array() == two.array()).all());
}

TEST_CASE("kdtree: duplicate points and bad k", "[kdtree]") {
    pcp::PointsF cloud = random_cloud(100, 31);
    cloud.topRows(60).rowwise() = cloud.row(0);  // 60 copies of one point
    const pcp::KdTree tree(cloud);
    const Eigen::VectorXf d = tree.kth_distance(cloud.topRows(1), 51);
    CHECK(d(0) == 0.0f);
    CHECK(d.allFinite());
    pcp::NeighborIndices idx;
    pcp::NeighborDistances dist;
    CHECK_THROWS_WITH(tree.knn(cloud, 101, idx, dist), Catch::Contains("k = 101"));
    CHECK_THROWS_WITH(tree.knn(cloud, 0, idx, dist), Catch::Contains("k = 0"));
}
