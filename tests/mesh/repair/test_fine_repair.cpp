// Tests for pcp/mesh/repair/fine_repair.hpp: a membrane thinner than a cell across a torus's hole (no data
// on it) is flipped away and the mesh is the torus (genus 1); a plate whose data has a hole keeps
// the surface the field closes the hole with; a correct field is unchanged; disabled and oversized
// grids are left alone; bad options throw.
#include "mc_test_util.hpp"
#include "pcp/cloud/shapes.hpp"
#include "pcp/core/error.hpp"
#include "pcp/mesh/repair/fine_repair.hpp"
#include "pcp/mesh/grid/marching_cubes.hpp"
#include "pcp/mesh/grid/mesh_check.hpp"
#include "mesh/grid/grid_samples.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace pcp_test;

namespace {

/// Torus around the z axis (not rotated, so that its hole is the disk x^2 + y^2 < (R - r)^2 at z = 0).
ScalarSdf flat_torus(double R, double r) {
    return [=](const Eigen::Vector3d& p) { return std::hypot(std::hypot(p.x(), p.y()) - R, p.z()) - r; };
}

pcp::SdfGrid grid_of(const ScalarSdf& f, int resolution) {
    return pcp::evaluate_sdf_grid(batch(f), cube_grid(resolution), pcp::SdfGridOptions{});  // coarse-to-fine band
}

Eigen::Index vertices_in_hole(const pcp::Mesh& m, double radius) {
    Eigen::Index n = 0;
    for (Eigen::Index v = 0; v < m.vertices.rows(); ++v)
        if (std::hypot(m.vertices(v, 0), m.vertices(v, 1)) < radius && std::abs(m.vertices(v, 2)) < 0.05) ++n;
    return n;
}

}  // namespace

TEST_CASE("fine repair: a membrane thinner than a cell across a torus's hole is flipped away", "[fine_repair]") {
    const double R = 0.3, r = 0.1;
    const ScalarSdf torus = flat_torus(R, r);
    // A negative disk of half-thickness 0.004 (the cells are 0.0125) spanning the hole.
    const ScalarSdf membrane = [](const Eigen::Vector3d& p) { return std::max(std::abs(p.z()) - 0.004, std::hypot(p.x(), p.y()) - 0.25); };
    const ScalarSdf field = [&](const Eigen::Vector3d& p) { return std::min(torus(p), membrane(p)); };
    const pcp::KdTree tree(pcp::sample_torus(8000, R, r, 7).points.cast<float>());

    pcp::SdfGrid grid = grid_of(field, 96);
    const pcp::Mesh before = pcp::marching_cubes(grid);
    REQUIRE(vertices_in_hole(before, 0.1) > 0);  // the membrane is meshed
    const pcp::FineRepairStats st = pcp::repair_fine_grid(grid, tree);
    const pcp::Mesh after = pcp::marching_cubes(grid);
    INFO("components " << st.components << ", flipped " << st.flipped_components << " (" << st.flipped_samples
                       << " samples), tau " << st.tau);
    CHECK(st.flipped_components >= 1);
    CHECK(vertices_in_hole(after, 0.15) == 0);
    const pcp::MeshTopology t = pcp::mesh_topology(after);
    CHECK(t.closed_manifold_oriented());
    CHECK(t.euler() == 0);  // genus 1

    // The torus alone is left exactly as it is.
    pcp::SdfGrid clean = grid_of(torus, 96);
    const std::vector<float> values = clean.values;
    const pcp::FineRepairStats none = pcp::repair_fine_grid(clean, tree);
    CHECK(none.flipped_components == 0);
    CHECK((clean.values == values));  // not decomposed: a failure would print both lattices
}

TEST_CASE("fine repair: a plate whose data has a hole keeps the surface across it", "[fine_repair]") {
    // A plate of half-thickness 0.03 (about 5 cells: its inside is stored and not anchored), data
    // on its two broad faces but for a disk of radius 0.1 on the top one.
    const double h = 0.03;
    const ScalarSdf plate = [&](const Eigen::Vector3d& p) {
        const Eigen::Vector3d q = p.cwiseAbs() - Eigen::Vector3d(0.35, 0.35, h);
        return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
    };
    std::vector<Eigen::RowVector3f> pts;
    for (int side = 0; side < 2; ++side)
        for (int i = 0; i <= 70; ++i)
            for (int j = 0; j <= 70; ++j) {
                const double x = -0.35 + 0.01 * i, y = -0.35 + 0.01 * j;
                if (side == 1 && std::hypot(x, y) < 0.1) continue;
                pts.emplace_back(float(x), float(y), float(side ? h : -h));
            }
    pcp::PointsF cloud(static_cast<Eigen::Index>(pts.size()), 3);
    for (std::size_t i = 0; i < pts.size(); ++i) cloud.row(static_cast<Eigen::Index>(i)) = pts[i];
    pcp::SdfGrid grid = grid_of(plate, 96);
    const std::vector<float> values = grid.values;
    const pcp::FineRepairStats st = pcp::repair_fine_grid(grid, pcp::KdTree(cloud));
    INFO("components " << st.components << ", flipped " << st.flipped_components);
    CHECK(st.flipped_components == 0);
    CHECK((grid.values == values));  // not decomposed: a failure would print both lattices
    const pcp::Mesh m = pcp::marching_cubes(grid);
    CHECK(pcp::is_closed_and_oriented(m));
}

TEST_CASE("fine repair: disabled or oversized grids are left alone, bad options throw", "[fine_repair]") {
    const ScalarSdf field = [](const Eigen::Vector3d& p) {
        return std::min(p.norm() - 0.3, std::max(std::abs(p.z()) - 0.004, std::hypot(p.x(), p.y()) - 0.5));
    };
    const pcp::KdTree tree(pcp::sample_sphere(3000, 0.3, Eigen::Vector3d::Zero(), 2).points.cast<float>());
    pcp::SdfGrid grid = grid_of(field, 48);
    const std::vector<float> values = grid.values;
    pcp::FineRepairOptions off;
    off.enabled = false;
    CHECK(pcp::repair_fine_grid(grid, tree, off).flipped_components == 0);
    pcp::FineRepairOptions small;
    small.max_samples = 1000;
    CHECK(pcp::repair_fine_grid(grid, tree, small).skipped);
    CHECK((grid.values == values));  // not decomposed: a failure would print both lattices
    pcp::FineRepairOptions bad;
    bad.max_unsupported = 1.0;
    CHECK_THROWS_AS(pcp::repair_fine_grid(grid, tree, bad), pcp::Error);
    bad = {};
    bad.near_k = 0;
    CHECK_THROWS_AS(pcp::repair_fine_grid(grid, tree, bad), pcp::Error);
}

TEST_CASE("fine repair: the near-data mask stamped equals a nearest query per lattice point", "[fine_repair]") {
    // A noisy sphere's points and a lattice off the unit cube's axes: every lattice point's verdict
    // (within tau of a point or not) is the same by stamping as by the tree, for radii from below a
    // cell to several cells.
    pcp::PointCloud cloud = pcp::sample_sphere(3000, 0.35, Eigen::Vector3d(0.03, -0.02, 0.01), 7);
    const pcp::KdTree tree(cloud.points.cast<float>());
    pcp::GridSpec spec;
    spec.resolution = 40;
    spec.box.min = Eigen::Vector3d(-0.51, -0.47, -0.53);
    spec.box.max = Eigen::Vector3d(0.49, 0.55, 0.5);
    const std::int64_t n1 = spec.resolution + 1;
    std::vector<std::int64_t> all(static_cast<std::size_t>(n1 * n1 * n1));
    for (std::size_t g = 0; g < all.size(); ++g) all[g] = static_cast<std::int64_t>(g);
    for (const double tau : {0.004, 0.0123, 0.05, 0.11}) {
        const auto by_tree = pcp::detail::lattice_near_data(spec, all, tree, tau, 0);
        const auto stamped = pcp::detail::lattice_near_data(spec, all, tree, tau, std::int64_t(1) << 40);
        REQUIRE(stamped.size() == by_tree.size());
        std::int64_t differ = 0, near = 0;
        for (std::size_t g = 0; g < all.size(); ++g) {
            differ += stamped[g] != by_tree[g];
            near += by_tree[g];
        }
        INFO("tau " << tau << ": " << near << " near by the tree");
        CHECK(near > 0);
        CHECK(differ == 0);
    }
}
