// Tests for pcp/mesh/tunnel_fill.hpp: a passage a cell wide through a slab is plugged (genus 1 ->
// 0) while a wide hole stays open (a torus keeps genus 1); a groove and a dent that go nowhere are
// left alone; a sparse grid is skipped; off does nothing. The bridge cut (its dual): an arch a cell
// thick is cut, a thick arch, a thin neck between two blocks and a thin fin are kept.
#include "mc_test_util.hpp"
#include "pcp/mesh/marching_cubes.hpp"
#include "pcp/mesh/mesh_check.hpp"
#include "pcp/eval/diagnose.hpp"
#include "pcp/mesh/tunnel_fill.hpp"

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

namespace {

// A slab (top face at z = 0) with a ring of minor radius r in the xz-plane, centred on the top face,
// major radius 0.15: the half above the slab is an arch joining two spots of the top face.
ScalarSdf slab_with_arch(double r) {
    const ScalarSdf slab = box_sdf(Eigen::Vector3d(0, 0, -0.15), Eigen::Vector3d(0.4, 0.4, 0.15));
    return [=](const Eigen::Vector3d& p) {
        const double ring = std::hypot(std::hypot(p.x(), p.z()) - 0.15, p.y()) - r;
        return std::min(slab(p), ring);
    };
}

}  // namespace

TEST_CASE("bridge cut: an arch a cell thick is cut, a thick arch, a thin neck and a thin fin are kept", "[tunnel_fill]") {
    pcp::TunnelFillOptions on;
    on.cut_bridges = true;
    // 64 cells over 1.2: cell 0.01875. An arch of radius 0.012 is 1.3 cells across: a handle.
    pcp::SdfGrid thin = dense_grid(slab_with_arch(0.012), 64);
    REQUIRE(genus(pcp::marching_cubes(thin)) == 1);
    CHECK(pcp::fill_tunnels(thin).plugged == 0);  // nothing for the tunnel fill: no passage through the solid is that narrow
    const pcp::BridgeCutStats st = pcp::cut_bridges(thin, on);
    CHECK_FALSE(st.skipped);
    CHECK(st.cut >= 1);
    CHECK(st.cut_samples > 0);
    const pcp::Mesh cut = pcp::marching_cubes(thin);
    CHECK(genus(cut) == 0);
    CHECK(topology(cut).closed_manifold_oriented());

    // An arch 0.08 thick (four cells) is data: untouched.
    pcp::SdfGrid thick = dense_grid(slab_with_arch(0.04), 64);
    const std::vector<float> thick_before = thick.values;
    CHECK(pcp::cut_bridges(thick, on).cut == 0);
    CHECK((thick.values == thick_before));  // not decomposed: a failure would print both lattices

    // Two blocks joined by a rod as thin: cutting it would split the solid, so it stays (a leg, a
    // wrist), though it scores like a bridge.
    const ScalarSdf a = box_sdf(Eigen::Vector3d(-0.25, 0, 0), Eigen::Vector3d(0.15, 0.15, 0.15));
    const ScalarSdf b = box_sdf(Eigen::Vector3d(0.25, 0, 0), Eigen::Vector3d(0.15, 0.15, 0.15));
    const ScalarSdf dumbbell = [=](const Eigen::Vector3d& p) {
        const double rod = std::max(std::hypot(p.y(), p.z()) - 0.012, std::abs(p.x()) - 0.2);
        return std::min({a(p), b(p), rod});
    };
    pcp::SdfGrid neck = dense_grid(dumbbell, 64);
    REQUIRE(pcp::mesh_components(pcp::marching_cubes(neck)).size() == 1);
    const std::vector<float> neck_before = neck.values;
    const pcp::BridgeCutStats neck_st = pcp::cut_bridges(neck, on);
    CHECK(neck_st.candidates > 0);  // the closing does take the rod
    CHECK(neck_st.cut == 0);
    CHECK((neck.values == neck_before));  // not decomposed: a failure would print both lattices

    // A fin 1.5 cells thick standing on the slab: cutting into it would make a hole, so it stays.
    const ScalarSdf slab = box_sdf(Eigen::Vector3d(0, 0, -0.15), Eigen::Vector3d(0.4, 0.4, 0.15));
    const ScalarSdf fin = box_sdf(Eigen::Vector3d(0, 0, 0.1), Eigen::Vector3d(0.25, 0.014, 0.1));
    pcp::SdfGrid finned = dense_grid([=](const Eigen::Vector3d& p) { return std::min(slab(p), fin(p)); }, 64);
    const std::vector<float> fin_before = finned.values;
    CHECK(pcp::cut_bridges(finned, on).cut == 0);
    CHECK((finned.values == fin_before));  // not decomposed: a failure would print both lattices

    // Off (the default) does nothing.
    pcp::SdfGrid again = dense_grid(slab_with_arch(0.012), 64);
    const std::vector<float> again_before = again.values;
    CHECK_FALSE(pcp::TunnelFillOptions().cut_bridges);
    CHECK(pcp::cut_bridges(again).cut == 0);
    CHECK((again.values == again_before));  // not decomposed: a failure would print both lattices
}
