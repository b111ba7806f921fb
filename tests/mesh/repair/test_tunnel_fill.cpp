// Tests for pcp/mesh/repair/tunnel_fill.hpp: a passage a cell wide through a slab is plugged (genus 1 ->
// 0) while a wide hole stays open (a torus keeps genus 1); a groove and a dent that go nowhere are
// left alone; a sparse grid is skipped; off does nothing.
#include "mc_test_util.hpp"
#include "pcp/mesh/grid/marching_cubes.hpp"
#include "pcp/mesh/grid/mesh_check.hpp"
#include "pcp/eval/diagnose.hpp"
#include "pcp/mesh/repair/tunnel_fill.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace pcp_test;

namespace {

// A slab 0.3 thick, 0.8 wide, with a drilled cylinder of radius r along z through it.
ScalarSdf drilled_slab(double r) {
    const ScalarSdf slab = box_sdf(Eigen::Vector3d::Zero(), Eigen::Vector3d(0.4, 0.4, 0.15));
    return [=](const Eigen::Vector3d& p) { return std::max(slab(p), r - std::hypot(p.x(), p.y())); };
}

std::int64_t genus(const pcp::Mesh& m) { return (2 - topology(m).euler()) / 2; }

}  // namespace

TEST_CASE("tunnel fill: a passage a cell wide is plugged, a wide hole stays open", "[tunnel_fill]") {
    // 64 cells over 1.2: cell 0.01875. A radius of 0.012 is a passage 1.3 cells across.
    pcp::SdfGrid narrow = dense_grid(drilled_slab(0.012), 64);
    REQUIRE(genus(pcp::marching_cubes(narrow)) == 1);
    const pcp::TunnelFillStats st = pcp::fill_tunnels(narrow);
    CHECK_FALSE(st.skipped);
    CHECK(st.plugged == 1);
    CHECK(st.plugged_samples > 0);
    const pcp::Mesh plugged = pcp::marching_cubes(narrow);
    CHECK(genus(plugged) == 0);
    CHECK(topology(plugged).closed_manifold_oriented());

    // A hole 0.2 across (ten cells) is data, not a pinch: untouched.
    pcp::SdfGrid wide = dense_grid(drilled_slab(0.1), 64);
    const std::vector<float> before = wide.values;
    CHECK(pcp::fill_tunnels(wide).plugged == 0);
    CHECK((wide.values == before));  // not decomposed: a failure would print both lattices
    CHECK(genus(pcp::marching_cubes(wide)) == 1);

    // The same for a torus's hole.
    pcp::SdfGrid torus = dense_grid(torus_sdf(Eigen::Vector3d::Zero(), 0.3, 0.1), 64);
    const std::vector<float> torus_before = torus.values;
    CHECK(pcp::fill_tunnels(torus).plugged == 0);
    CHECK((torus.values == torus_before));  // not decomposed: a failure would print both lattices
}

TEST_CASE("tunnel fill: a narrow groove and a blind hole are left alone", "[tunnel_fill]") {
    const ScalarSdf slab = box_sdf(Eigen::Vector3d::Zero(), Eigen::Vector3d(0.4, 0.4, 0.15));
    // A groove 1.5 cells wide across the top face, and a blind hole of radius 0.012 from the bottom.
    const ScalarSdf grooved = [=](const Eigen::Vector3d& p) {
        const double groove = std::max(std::abs(p.x()) - 0.014, 0.05 - p.z());
        const double blind = std::max(std::hypot(p.x() - 0.2, p.y() - 0.2) - 0.012, p.z() + 0.05);
        return std::max(slab(p), -std::min(groove, blind));
    };
    pcp::SdfGrid grid = dense_grid(grooved, 64);
    REQUIRE(genus(pcp::marching_cubes(grid)) == 0);
    const std::vector<float> before = grid.values;
    const pcp::TunnelFillStats st = pcp::fill_tunnels(grid);
    CHECK(st.candidates > 0);  // the closing does reach into them
    CHECK(st.plugged == 0);
    CHECK((grid.values == before));  // not decomposed: a failure would print both lattices
}

TEST_CASE("tunnel fill: off, or a sparse grid, changes nothing", "[tunnel_fill]") {
    pcp::SdfGrid grid = dense_grid(drilled_slab(0.012), 32);
    const std::vector<float> before = grid.values;
    pcp::TunnelFillOptions off;
    off.enabled = false;
    CHECK(pcp::fill_tunnels(grid, off).plugged == 0);
    CHECK((grid.values == before));  // not decomposed: a failure would print both lattices
    pcp::TunnelFillOptions small;
    small.max_samples = 1000;
    CHECK(pcp::fill_tunnels(grid, small).skipped);
    CHECK((grid.values == before));  // not decomposed: a failure would print both lattices

    pcp::SdfGridOptions o;
    o.band = pcp::NarrowBand::Coarse;
    pcp::SdfGrid sparse = pcp::evaluate_sdf_grid(batch(drilled_slab(0.012)), cube_grid(64), o);
    CHECK(pcp::fill_tunnels(sparse).skipped);
}
