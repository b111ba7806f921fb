// Tests for pcp/regions.hpp: the grid split and the four normalisation variants.
#include "pcp/core/error.hpp"
#include "pcp/cloud/regions.hpp"
#include "pcp/cloud/shapes.hpp"

#include <catch2/catch.hpp>

#include <set>

TEST_CASE("regions: every kept point is in exactly one region, in its own cell", "[regions]") {
    const pcp::PointCloud shape = pcp::sample_default_shape(20000, 0.0, 3);
    const pcp::PointsF unit = (shape.points / 1.1).cast<float>();
    for (int grid : {1, 4, 6, 8}) {
        pcp::RegionOptions opts;
        opts.grid = grid;
        opts.min_points = 1;
        const std::vector<pcp::Region> regions = pcp::split_into_regions(unit, opts);
        std::set<std::int32_t> seen;
        for (const pcp::Region& r : regions)
            for (Eigen::Index i = 0; i < r.point_ids.size(); ++i) REQUIRE(seen.insert(r.point_ids(i)).second);
        CHECK(static_cast<Eigen::Index>(seen.size()) == unit.rows());
        if (grid == 1) CHECK(regions.size() == 1);
        CHECK(regions.size() <= static_cast<std::size_t>(grid * grid * grid));
    }
}

TEST_CASE("regions: normalisation variants put regions where the paper says", "[regions]") {
    const pcp::PointCloud shape = pcp::sample_default_shape(20000, 0.0, 4);
    const pcp::PointsF unit = (shape.points / 1.1).cast<float>();
    for (const char* name : {"none", "center", "scale", "both"}) {
        pcp::RegionOptions opts;
        opts.normalization = pcp::parse_region_normalization(name);
        CHECK(pcp::to_string(opts.normalization) == name);
        const std::vector<pcp::Region> regions = pcp::split_into_regions(unit, opts);
        REQUIRE(!regions.empty());
        for (const pcp::Region& r : regions) {
            REQUIRE(r.point_ids.size() >= opts.min_points);
            const pcp::PointsF local = pcp::region_points(unit, r);
            const Eigen::Vector3f lo = local.colwise().minCoeff(), hi = local.colwise().maxCoeff();
            const bool centred = std::string(name) == "center" || std::string(name) == "both";
            const bool scaled = std::string(name) == "scale" || std::string(name) == "both";
            if (centred) REQUIRE((0.5f * (lo + hi)).norm() < 1e-5f);
            if (scaled) REQUIRE((hi - lo).maxCoeff() == Approx(1.0f).epsilon(1e-5));
            if (!scaled) REQUIRE(r.scale == 1.0f);
            if (!centred) REQUIRE(r.center.isZero());
            // Round trip region <-> unit coordinates.
            REQUIRE((r.from_region(local) - pcp::PointsF(unit(r.point_ids, Eigen::all))).cwiseAbs().maxCoeff() < 1e-6f);
        }
    }
    CHECK_THROWS_WITH(pcp::parse_region_normalization("diagonal"), Catch::Contains("diagonal"));
}

TEST_CASE("regions: sparse cells are dropped, bad grids refused", "[regions]") {
    const pcp::PointCloud sphere = pcp::sample_sphere(3000, 0.5, Eigen::Vector3d::Zero(), 5);
    const pcp::PointsF unit = sphere.points.cast<float>();
    pcp::RegionOptions opts;
    opts.grid = 8;
    opts.min_points = 51;
    for (const pcp::Region& r : pcp::split_into_regions(unit, opts)) CHECK(r.point_ids.size() >= 51);
    opts.grid = 0;
    CHECK_THROWS_WITH(pcp::split_into_regions(unit, opts), Catch::Contains("grid"));
}
