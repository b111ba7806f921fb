// Tests for pcp/normalize.hpp: unit-box fit, exact inverse, and the degenerate-input checks.
#include "pcp/core/error.hpp"
#include "pcp/cloud/normalize.hpp"
#include "pcp/core/rng.hpp"

#include <catch2/catch.hpp>

#include <limits>

namespace {
pcp::Points random_points(Eigen::Index n, std::uint64_t seed, double scale, const Eigen::Vector3d& offset) {
    pcp::Rng rng(seed);
    pcp::Points p(n, 3);
    for (Eigen::Index i = 0; i < n; ++i)
        for (int c = 0; c < 3; ++c) p(i, c) = offset(c) + scale * (rng.uniform() - 0.5) * (c + 1);
    return p;
}
}  // namespace

TEST_CASE("normalize: the unit box has longest edge 1 and centre 0", "[normalize]") {
    const pcp::Points p = random_points(1000, 3, 7.0, {1e5, -2e4, 3.0});
    const pcp::Normalization n = pcp::fit_unit_box(p);
    const pcp::Points u = n.to_unit_double(p);
    const pcp::Aabb box = pcp::bounding_box(u);
    CHECK(box.extent().maxCoeff() == Approx(1.0).epsilon(1e-12));
    CHECK(box.center().norm() < 1e-9);
    const pcp::PointsF uf = n.to_unit(p);
    CHECK(uf.cwiseAbs().maxCoeff() <= 0.5f + 1e-6f);
}

TEST_CASE("normalize: the inverse is exact to 1e-12 relative, far from the origin too", "[normalize]") {
    const pcp::Points p = random_points(1000, 4, 50.0, {6.4e6, 4.3e5, -120.0});  // UTM-like offsets
    const pcp::Normalization n = pcp::fit_unit_box(p);
    const pcp::Points back = n.from_unit(n.to_unit_double(p));
    const double rel = (back - p).cwiseAbs().maxCoeff() / p.cwiseAbs().maxCoeff();
    CHECK(rel < 1e-12);
    pcp::Mesh mesh{n.to_unit_double(p), pcp::Faces(0, 3)};
    CHECK((n.from_unit(mesh).vertices - p).cwiseAbs().maxCoeff() / p.cwiseAbs().maxCoeff() < 1e-12);
}

TEST_CASE("normalize: degenerate clouds are refused with the reason", "[normalize]") {
    const Eigen::Index n = 100;
    pcp::Points identical = pcp::Points::Constant(n, 3, 2.5);
    CHECK_THROWS_WITH(pcp::check_point_cloud(identical, "a.ply", 51), Catch::Contains("a.ply") && Catch::Contains("identical"));

    pcp::Points line(n, 3);
    for (Eigen::Index i = 0; i < n; ++i) line.row(i) = Eigen::RowVector3d(1, 2, 3) * static_cast<double>(i) + Eigen::RowVector3d(5, 5, 5);
    CHECK_THROWS_WITH(pcp::check_point_cloud(line, "b.xyz", 51), Catch::Contains("b.xyz") && Catch::Contains("line"));

    // A tilted plane: its axis-aligned box is not degenerate, but the cloud is.
    pcp::Points plane = random_points(n, 5, 1.0, {0, 0, 0});
    for (Eigen::Index i = 0; i < n; ++i) plane(i, 2) = 0.3 * plane(i, 0) - 0.7 * plane(i, 1) + 2.0;
    CHECK_THROWS_WITH(pcp::check_point_cloud(plane, "c.ply", 51), Catch::Contains("c.ply") && Catch::Contains("plane"));

    const pcp::Points good = random_points(n, 6, 1.0, {0, 0, 0});
    CHECK_NOTHROW(pcp::check_point_cloud(good, "d.ply", 51));
    CHECK_THROWS_WITH(pcp::check_point_cloud(good.topRows(50), "e.ply", 51),
                      Catch::Contains("e.ply") && Catch::Contains("50 points") && Catch::Contains("at least 51"));
    pcp::Points bad = good;
    bad(17, 1) = std::numeric_limits<double>::quiet_NaN();
    CHECK_THROWS_WITH(pcp::check_point_cloud(bad, "f.ply", 51), Catch::Contains("point 17") && Catch::Contains("non-finite"));
    bad(17, 1) = std::numeric_limits<double>::infinity();
    CHECK_THROWS_WITH(pcp::check_point_cloud(bad, "f.ply", 51), Catch::Contains("non-finite"));
}
