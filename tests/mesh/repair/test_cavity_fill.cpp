// Tests for pcp/mesh/repair/cavity_fill.hpp: a hollow sphere (a shell of "inside" around a positive core)
// is filled, leaving one sphere; a torus's hole and an open cup stay outside; a pinhole through the
// shell does not let the outside in; a pocket the visibility labels see from outside stays; a hollow
// wall perforated by wide tunnels is filled where the labels say inside (more open than the limit
// when its openings lie on the data), an island of inside labels in the open is not; a sparse grid
// is skipped; bad options throw.
#include "mc_test_util.hpp"
#include "pcp/cloud/kdtree.hpp"
#include "pcp/cloud/visibility.hpp"
#include "pcp/core/error.hpp"
#include "pcp/mesh/repair/cavity_fill.hpp"
#include "pcp/reconstruct.hpp"
#include "pcp/mesh/grid/marching_cubes.hpp"
#include "pcp/mesh/grid/mesh_check.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <functional>

using namespace pcp_test;

namespace {

/// A sphere of radius R whose field is a shell: negative only between R - t and R.
ScalarSdf hollow_sphere(double R, double t) {
    return [=](const Eigen::Vector3d& p) { return std::max(p.norm() - R, (R - t) - p.norm()); };
}

/// Visibility labels on 24^3 cells of 0.05 over the test grids' box [-0.6, 0.6]^3: label(centre).
pcp::VisibilityLabels labels_over_cube(const std::function<int(const Eigen::Vector3d&)>& label) {
    pcp::VisibilityLabels labels;
    labels.origin = Eigen::Vector3d::Constant(-0.6);
    labels.cell = 0.05;
    labels.dims = Eigen::Vector3i::Constant(24);
    labels.label.assign(24 * 24 * 24, 0);
    for (int k = 0; k < 24; ++k)
        for (int j = 0; j < 24; ++j)
            for (int i = 0; i < 24; ++i) labels.label[labels.index(i, j, k)] = static_cast<std::int8_t>(label(labels.center(i, j, k)));
    return labels;
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
    CHECK((torus.values == before));  // not decomposed: a failure would print both lattices
    // A cup: a sphere shell cut open at the top (wide opening).
    const ScalarSdf shell = hollow_sphere(0.4, 0.06);
    const ScalarSdf cup = [=](const Eigen::Vector3d& p) { return std::max(shell(p), p.z() - 0.2); };
    pcp::SdfGrid cup_grid = dense_grid(cup, 64);
    CHECK(pcp::fill_cavities(cup_grid).cavity_samples == 0);
}

TEST_CASE("cavity fill: a through-hole's pocket that the visibility labels see from outside stays open", "[cavity_fill]") {
    // A slab with a through-hole along z (radius 0.15) whose field in the hole has a band of small
    // positive values (as where the sign repair flipped a plug the fit put there): the outside front
    // stops at the band, the middle of the hole is a pocket walled on most of its boundary.
    const ScalarSdf slab = box_sdf(Eigen::Vector3d::Zero(), Eigen::Vector3d(0.4, 0.4, 0.3));
    const ScalarSdf holed = [=](const Eigen::Vector3d& p) {
        const double r = std::hypot(p.x(), p.y());
        const double f = std::max(slab(p), 0.15 - r);
        const double z = std::abs(p.z());
        return (f > 0 && r < 0.15 && z > 0.12 && z < 0.18) ? std::min(f, 0.004) : f;
    };
    const pcp::SdfGrid original = dense_grid(holed, 64);
    REQUIRE(topology(pcp::marching_cubes(original)).euler() == 0);
    // Without labels the pocket is a cavity: filled, the hole closed.
    pcp::SdfGrid closed = original;
    const pcp::CavityFillStats filled = pcp::fill_cavities(closed);
    CHECK(filled.cavities == 1);
    CHECK(topology(pcp::marching_cubes(closed)).euler() == 2);
    // Labels: outside in the middle of the hole, inside in the slab away from the hole.
    pcp::VisibilityLabels labels = labels_over_cube([&](const Eigen::Vector3d& c) {
        const double r = std::hypot(c.x(), c.y());
        if (r < 0.1 && std::abs(c.z()) < 0.25) return 1;
        if (r > 0.2 && holed(c) < -0.05) return -1;
        return 0;
    });
    pcp::SdfGrid open = original;
    const pcp::CavityFillStats kept = pcp::fill_cavities(open, {}, &labels);
    CHECK(kept.cavities == 0);
    CHECK(open.values == original.values);
    CHECK(topology(pcp::marching_cubes(open)).euler() == 0);
    // min_label_votes = 0 ignores the labels; a pocket labelled inside is still a cavity.
    pcp::SdfGrid ignored = original;
    pcp::CavityFillOptions no_votes;
    no_votes.min_label_votes = 0;
    CHECK(pcp::fill_cavities(ignored, no_votes, &labels).cavities == 1);
    for (auto& l : labels.label) l = static_cast<std::int8_t>(-std::abs(l));
    pcp::SdfGrid inside = original;
    CHECK(pcp::fill_cavities(inside, {}, &labels).cavities == 1);
}

TEST_CASE("cavity fill: a hollow solid perforated by wide tunnels is filled where the visibility labels say inside", "[cavity_fill]") {
    // A ball of radius 0.4 whose field is a shell 0.06 thick (a noisy scan's hollow fit), pierced
    // along x and along y by tunnels of radius 0.14 (7.5 cells at 64^3 over 1.2, delta 2 cells): the
    // outside front gets into the core through them.
    const ScalarSdf shell = hollow_sphere(0.4, 0.06);
    const ScalarSdf pierced = [=](const Eigen::Vector3d& p) {
        const double along_x = std::hypot(p.y(), p.z()) - 0.14, along_y = std::hypot(p.x(), p.z()) - 0.14;
        return std::max(shell(p), -std::min(along_x, along_y));
    };
    const pcp::SdfGrid original = dense_grid(pierced, 64);
    const int euler_before = topology(pcp::marching_cubes(original)).euler();
    REQUIRE(euler_before < 0);  // one surface with handles: the tunnels join the outer and inner sheets
    // Without labels the core is outside: nothing is filled.
    pcp::SdfGrid unlabelled = original;
    CHECK(pcp::fill_cavities(unlabelled).cavity_samples == 0);
    // Labels: inside in the core (cells whose centre is within 0.3 of the centre), outside beyond 0.5.
    const pcp::VisibilityLabels labels = labels_over_cube([](const Eigen::Vector3d& c) {
        return c.norm() < 0.3 ? -1 : c.norm() > 0.5 ? 1 : 0;
    });
    pcp::SdfGrid labelled = original;
    pcp::CavityFillOptions noisy;  // what pcp::reconstruct uses on a denoised cloud
    noisy.max_open = pcp::NoisyCloudOptions().cavity_max_open;
    const pcp::CavityFillStats st = pcp::fill_cavities(labelled, noisy, &labels);
    CHECK(st.cavities == 1);
    CHECK(st.labelled_cavities == 1);
    const pcp::Mesh m = pcp::marching_cubes(labelled);
    CHECK(topology(m).euler() == 2);  // one closed surface: the outer sheet with four dimples
    CHECK(topology(m).closed_manifold_oriented());
    CHECK(m.vertices.rowwise().norm().maxCoeff() < 0.41);
    // The same pocket with labelled_max_open below its openness is left alone.
    pcp::SdfGrid strict = original;
    pcp::CavityFillOptions closed_only;
    closed_only.labelled_max_open = 0;
    closed_only.max_open = 0;
    CHECK(pcp::fill_cavities(strict, closed_only, &labels).cavity_samples == 0);
    // An island of inside labels in the open, around no wall of the field: nothing is filled there.
    const ScalarSdf small_ball = sphere_sdf(Eigen::Vector3d(-0.3, -0.3, -0.3), 0.15);
    pcp::SdfGrid ball = dense_grid(small_ball, 64);
    const std::vector<float> ball_before = ball.values;
    const pcp::VisibilityLabels island = labels_over_cube([](const Eigen::Vector3d& c) {
        return (c - Eigen::Vector3d(0.3, 0.3, 0.3)).norm() < 0.12 ? -1 : 0;
    });
    CHECK(pcp::fill_cavities(ball, {}, &island).cavity_samples == 0);
    CHECK((ball.values == ball_before));  // not decomposed: a failure would print both lattices
}

TEST_CASE("cavity fill: a pocket labelled inside and too open is filled when its openings lie on the data", "[cavity_fill]") {
    // A ball of radius 0.4 whose field is a thin shell (0.03, 1.6 cells at 64^3 over 1.2) holed
    // along x and y (radius 0.1): the hollow, perforated wall of a fit gone wrong, with the
    // labels inside in the core. Every pocket counts as too open here (limits 0).
    const ScalarSdf shell = hollow_sphere(0.4, 0.03);
    const ScalarSdf holed = [=](const Eigen::Vector3d& p) {
        const double along_x = std::hypot(p.y(), p.z()) - 0.1, along_y = std::hypot(p.x(), p.z()) - 0.1;
        return std::max(shell(p), -std::min(along_x, along_y));
    };
    const pcp::SdfGrid original = dense_grid(holed, 64);
    const pcp::VisibilityLabels labels = labels_over_cube([](const Eigen::Vector3d& c) {
        return c.norm() < 0.34 ? -1 : c.norm() > 0.46 ? 1 : 0;
    });
    pcp::CavityFillOptions too_open;
    too_open.labelled_max_open = 0;
    too_open.max_open = 0;
    // Points on the ball's true surface, over the holes too (the wall is there, the field perforated
    // it), or without the holes' disks (real holes: the data stops at their rims).
    auto surface_points = [](bool over_holes) {
        std::vector<Eigen::Vector3f> kept;
        const int n = 1000;
        for (int i = 0; i < n; ++i) {  // a Fibonacci sphere of radius 0.4
            const double z = 1.0 - (2.0 * i + 1.0) / n, r = std::sqrt(1.0 - z * z), phi = 2.39996322972865332 * i;
            const Eigen::Vector3d p = 0.4 * Eigen::Vector3d(r * std::cos(phi), r * std::sin(phi), z);
            if (!over_holes && (std::hypot(p.y(), p.z()) < 0.12 || std::hypot(p.x(), p.z()) < 0.12)) continue;
            kept.push_back(p.cast<float>());
        }
        pcp::PointsF points(static_cast<Eigen::Index>(kept.size()), 3);
        for (std::size_t i = 0; i < kept.size(); ++i) points.row(Eigen::Index(i)) = kept[i].transpose();
        return points;
    };
    const pcp::KdTree perforated_wall(surface_points(true)), real_holes(surface_points(false));
    pcp::SdfGrid without_data = original;
    CHECK(pcp::fill_cavities(without_data, too_open, &labels).cavity_samples == 0);
    pcp::SdfGrid on_data = original;
    const pcp::CavityFillStats supported = pcp::fill_cavities(on_data, too_open, &labels, &perforated_wall);
    CHECK(supported.cavities == 1);
    CHECK(supported.supported_cavities == 1);
    const pcp::Mesh filled = pcp::marching_cubes(on_data);
    CHECK(topology(filled).euler() == 2);  // one closed surface
    CHECK(filled.vertices.rowwise().norm().minCoeff() > 0.3);
    pcp::SdfGrid holes = original;
    CHECK(pcp::fill_cavities(holes, too_open, &labels, &real_holes).cavity_samples == 0);
    pcp::CavityFillOptions never = too_open;
    never.supported_openings = 2.0;
    pcp::SdfGrid switched_off = original;
    CHECK(pcp::fill_cavities(switched_off, never, &labels, &perforated_wall).cavity_samples == 0);
}

TEST_CASE("cavity fill: sparse grids are skipped, disabled is the identity, bad options throw", "[cavity_fill]") {
    pcp::SdfGrid sparse = pcp::evaluate_sdf_grid(batch(hollow_sphere(0.4, 0.06)), cube_grid(64));  // narrow band
    const std::vector<float> before = sparse.values;
    CHECK(pcp::fill_cavities(sparse).skipped);
    CHECK((sparse.values == before));  // not decomposed: a failure would print both lattices
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
    bad.min_label_votes = -1;
    CHECK_THROWS_AS(pcp::fill_cavities(grid, bad), pcp::Error);
    bad = {};
    bad.labelled_max_open = 2;
    CHECK_THROWS_AS(pcp::fill_cavities(grid, bad), pcp::Error);
    bad = {};
    bad.support_k = 0;
    CHECK_THROWS_AS(pcp::fill_cavities(grid, bad), pcp::Error);
    bad = {};
    bad.supported_openings = -1;
    CHECK_THROWS_AS(pcp::fill_cavities(grid, bad), pcp::Error);
}
