// Tests for pcp/mesh/cavity_fill.hpp: a hollow sphere (a shell of "inside" around a positive core)
// is filled, leaving one sphere; a torus's hole and an open cup stay outside; a pinhole through the
// shell does not let the outside in; a sparse grid is skipped; bad options throw.
#include "mc_test_util.hpp"
#include "pcp/core/error.hpp"
#include "pcp/mesh/cavity_fill.hpp"
#include "pcp/mesh/marching_cubes.hpp"
#include "pcp/mesh/mesh_check.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace pcp_test;

namespace {

/// A sphere of radius R whose field is a shell: negative only between R - t and R.
ScalarSdf hollow_sphere(double R, double t) {
    return [=](const Eigen::Vector3d& p) { return std::max(p.norm() - R, (R - t) - p.norm()); };
}

}  // namespace

TEST_CASE("cavity fill: a hollow sphere's core is filled", "[cavity_fill]") {
    pcp::SdfGrid grid = dense_grid(hollow_sphere(0.4, 0.06), 64);
    REQUIRE(topology(pcp::marching_cubes(grid)).euler() == 4);  // outer and inner sheet
    const pcp::CavityFillStats st = pcp::fill_cavities(grid);
    CHECK_FALSE(st.skipped);
    CHECK(st.cavities == 1);
    CHECK(st.cavity_samples > 0);
    const pcp::Mesh m = pcp::marching_cubes(grid);
    CHECK(topology(m).euler() == 2);
    CHECK(topology(m).closed_manifold_oriented());
    // The outer sheet is where it was.
    const Eigen::VectorXd r = m.vertices.rowwise().norm();
    CHECK(r.minCoeff() > 0.39);
    CHECK(r.maxCoeff() < 0.41);
}

TEST_CASE("cavity fill: a pinhole through the shell does not let the outside in", "[cavity_fill]") {
    // A tunnel of radius 0.025 (1.3 cells at 64^3 over 1.2) from the core to the outside.
    const ScalarSdf shell = hollow_sphere(0.4, 0.08);
    const ScalarSdf pierced = [=](const Eigen::Vector3d& p) {
        const double tunnel = std::max(std::hypot(p.y(), p.z()) - 0.025, -p.x());
        return std::max(shell(p), -tunnel);
    };
    pcp::SdfGrid grid = dense_grid(pierced, 64);
    const pcp::SdfGrid untouched = grid;
    const pcp::CavityFillStats st = pcp::fill_cavities(grid);
    CHECK(st.cavities >= 1);
    const pcp::Mesh m = pcp::marching_cubes(grid);
    CHECK(m.vertices.rowwise().norm().minCoeff() > 0.36);  // no inner sheet left
    // A pocket is filled only when it is closed enough: with no opening allowed, the tunnel keeps it.
    pcp::SdfGrid strict = untouched;
    pcp::CavityFillOptions closed_only;
    closed_only.max_open = 0;
    const pcp::CavityFillStats kept = pcp::fill_cavities(strict, closed_only);
    CHECK(kept.pockets >= 1);
    CHECK(pcp::marching_cubes(strict).vertices.rowwise().norm().minCoeff() < 0.36);  // the inner sheet stays
    // Without the core threshold the tunnel is a way in: the core counts as outside.
    pcp::SdfGrid leaky = untouched;
    pcp::CavityFillOptions thin;
    thin.core_cells = 0.1;
    CHECK(pcp::fill_cavities(leaky, thin).cavity_samples == 0);
}

TEST_CASE("cavity fill: a torus's hole and an open cup stay outside", "[cavity_fill]") {
    pcp::SdfGrid torus = dense_grid(torus_sdf(Eigen::Vector3d::Zero(), 0.3, 0.1), 64);
    const std::vector<float> before = torus.values;
    CHECK(pcp::fill_cavities(torus).cavity_samples == 0);
    CHECK(torus.values == before);
    // A cup: a sphere shell cut open at the top (wide opening).
    const ScalarSdf shell = hollow_sphere(0.4, 0.06);
    const ScalarSdf cup = [=](const Eigen::Vector3d& p) { return std::max(shell(p), p.z() - 0.2); };
    pcp::SdfGrid cup_grid = dense_grid(cup, 64);
    CHECK(pcp::fill_cavities(cup_grid).cavity_samples == 0);
}

TEST_CASE("cavity fill: sparse grids are skipped, disabled is the identity, bad options throw", "[cavity_fill]") {
    pcp::SdfGrid sparse = pcp::evaluate_sdf_grid(batch(hollow_sphere(0.4, 0.06)), cube_grid(64));  // narrow band
    const std::vector<float> before = sparse.values;
    CHECK(pcp::fill_cavities(sparse).skipped);
    CHECK(sparse.values == before);
    pcp::SdfGrid grid = dense_grid(hollow_sphere(0.4, 0.06), 32);
    pcp::CavityFillOptions off;
    off.enabled = false;
    CHECK(pcp::fill_cavities(grid, off).cavity_samples == 0);
    pcp::CavityFillOptions small;
    small.max_samples = 1000;
    CHECK(pcp::fill_cavities(grid, small).skipped);
    pcp::CavityFillOptions bad;
    bad.core_cells = 0;
    CHECK_THROWS_AS(pcp::fill_cavities(grid, bad), pcp::Error);
    bad = {};
    bad.max_open = 1.5;
    CHECK_THROWS_AS(pcp::fill_cavities(grid, bad), pcp::Error);
    bad = {};
    bad.noisy_max_open = -0.1;
    CHECK_THROWS_AS(pcp::fill_cavities(grid, bad), pcp::Error);
}
