// Tests for pcp/mesh/repair/thin_level.hpp: the level near the data and its fade; a sheet whose field has
// no inside, which the grid's samples miss at the fixed offset, is raised until marching cubes finds
// it as one closed slab (another grid of the lattice shifted alike on request); the surface of a solid (its inside negative) is not raised; bad arguments.
#include "mc_test_util.hpp"
#include "pcp/cloud/kdtree.hpp"
#include "pcp/cloud/shapes.hpp"
#include "pcp/core/error.hpp"
#include "pcp/mesh/grid/marching_cubes.hpp"
#include "pcp/mesh/repair/thin_level.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace pcp_test;

namespace {

// Points on the square |x|, |y| <= 0.3 at height z, 0.01 apart.
pcp::PointsF sheet_points(double z) {
    const int n = 61;
    pcp::PointsF p(n * n, 3);
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) p.row(i * n + j) << float(-0.3 + 0.01 * i), float(-0.3 + 0.01 * j), float(z);
    return p;
}

}  // namespace

TEST_CASE("thin level: the offset near the data, fading to nothing at twice the radius", "[mesh][thin_level]") {
    const pcp::KdTree cloud(sheet_points(0.0));
    const pcp::ThinLevel level(cloud, 0.002f, 0.02f);
    CHECK(level(Eigen::Vector3f(0.1f, 0.1f, 0.0f)) == 0.002f);
    CHECK(level(Eigen::Vector3f(0.1f, 0.1f, 0.02f)) == Approx(0.002).epsilon(1e-5));
    CHECK(level(Eigen::Vector3f(0.1f, 0.1f, 0.03f)) == Approx(0.001).epsilon(1e-4));
    CHECK(level(Eigen::Vector3f(0.1f, 0.1f, 0.05f)) == 0.0f);
    const pcp::ThinLevel off(cloud, 0.0f, 0.0f);
    CHECK(off(Eigen::Vector3f(0.1f, 0.1f, 0.0f)) == 0.0f);
}

TEST_CASE("thin level: a sheet with no inside is raised until the grid's samples hold it", "[mesh][thin_level]") {
    // The grid: 32 cells over [-0.6, 0.6]^3 (cell 0.0375), lattice planes at z = 0 and 0.0375; the
    // sheet halfway between them. Its field F = 0.6 |z - z0| + 0.001 has no inside; at the fixed
    // offset the slab it gives is 0.0017 deep and both lattice planes lie outside it.
    const double cell = 1.2 / 32, z0 = 0.5 * cell;
    const pcp::KdTree cloud(sheet_points(z0));
    pcp::ThinLevel level(cloud, 0.002f, 0.02f);
    const ScalarSdf field = [&](const Eigen::Vector3d& p) { return 0.6 * std::abs(p.z() - z0) + 0.001 - level(p.cast<float>()); };
    pcp::SdfGrid grid = dense_grid(field, 32);
    CHECK(pcp::marching_cubes(grid).faces.rows() == 0);
    pcp::SdfGrid copy = grid;  // as the shell centring keeps one from before the fills
    level.shift_like_raise(copy);  // before the raise: nothing
    CHECK(copy.values == grid.values);
    const std::int64_t raised = level.raise_where_thin(grid, static_cast<float>(cell));
    CHECK(raised == cloud.size());
    CHECK(copy.values != grid.values);
    level.shift_like_raise(copy);  // after it: shifted alike
    CHECK(copy.values == grid.values);
    // The level on the sheet: the offset plus the field one cell away (0.0235, less the faded
    // offset there), which puts both lattice planes inside.
    const float on_sheet = level(Eigen::Vector3f(0.0f, 0.0f, float(z0)));
    CHECK(on_sheet == Approx(0.0253).margin(0.001));
    CHECK(level(Eigen::Vector3f(0.0f, 0.0f, 0.3f)) == 0.0f);
    const pcp::Mesh slab = pcp::marching_cubes(grid);
    REQUIRE(slab.faces.rows() > 0);
    const MeshTopology topo = topology(slab);
    CHECK(topo.closed_manifold_oriented());
    CHECK(topo.euler() == 2);  // one closed slab, no holes
    // It spans the sheet and hugs it.
    CHECK(slab.vertices.col(0).minCoeff() < -0.29);
    CHECK(slab.vertices.col(0).maxCoeff() > 0.29);
    CHECK((slab.vertices.col(2).array() - z0).abs().maxCoeff() < 1.5 * cell);
}

TEST_CASE("thin level: nothing is raised when fewer than min_share of the points would be", "[mesh][thin_level]") {
    // The sheet above plus as many points far above it (the field 0.2 there: not thin): half raised.
    const double cell = 1.2 / 32, z0 = 0.5 * cell;
    const pcp::PointsF sheet = sheet_points(z0), above = sheet_points(0.35);
    pcp::PointsF both(sheet.rows() + above.rows(), 3);
    both << sheet, above;
    const pcp::KdTree cloud(both);
    pcp::ThinLevel level(cloud, 0.002f, 0.02f);
    const ScalarSdf field = [&](const Eigen::Vector3d& p) { return 0.6 * std::abs(p.z() - z0) + 0.001 - level(p.cast<float>()); };
    pcp::SdfGrid grid = dense_grid(field, 32);
    const pcp::SdfGrid before = grid;
    CHECK(level.raise_where_thin(grid, static_cast<float>(cell), 3, 0.6) == 0);
    CHECK(grid.values == before.values);
    pcp::SdfGrid copy = before;
    level.shift_like_raise(copy);  // nothing raised: nothing shifted
    CHECK(copy.values == before.values);
    CHECK(level(Eigen::Vector3f(0.0f, 0.0f, float(z0))) == 0.002f);
    CHECK(level.raise_where_thin(grid, static_cast<float>(cell), 3, 0.4) == sheet.rows());
}

TEST_CASE("thin level: the surface of a solid is not raised", "[mesh][thin_level]") {
    const pcp::PointCloud sphere = pcp::sample_sphere(4000, 0.3, Eigen::Vector3d::Zero(), 5);
    const pcp::KdTree cloud(sphere.points.cast<float>());
    pcp::ThinLevel level(cloud, 0.002f, 0.02f);
    const ScalarSdf field = [&](const Eigen::Vector3d& p) { return p.norm() - 0.3 - level(p.cast<float>()); };
    pcp::SdfGrid grid = dense_grid(field, 32);
    const pcp::SdfGrid before = grid;
    CHECK(level.raise_where_thin(grid, float(1.2 / 32)) == 0);
    CHECK(grid.values == before.values);
    CHECK(level(Eigen::Vector3f(0.3f, 0.0f, 0.0f)) == Approx(0.002f).margin(1e-6));
}

TEST_CASE("thin level: bad arguments are refused", "[mesh][thin_level]") {
    const pcp::KdTree cloud(sheet_points(0.0));
    CHECK_THROWS_AS(pcp::ThinLevel(cloud, -0.001f, 0.02f), pcp::Error);
    CHECK_THROWS_AS(pcp::ThinLevel(cloud, 0.002f, std::nanf("")), pcp::Error);
    pcp::ThinLevel level(cloud, 0.002f, 0.02f);
    pcp::SdfGrid grid = dense_grid([](const Eigen::Vector3d& p) { return p.norm() - 0.3; }, 8);
    CHECK_THROWS_AS(level.raise_where_thin(grid, 0.0f), pcp::Error);
}
