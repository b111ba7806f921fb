// Tests for pcp/mesh/through_carve.hpp: a plate that the field spans across the gaps between four
// slats is carved back into the slats (the points lie on the slats only); a solid box and a sphere
// scanned with a hole in its top keep every inside sample; a field too fat around a sphere's points
// is not pitted where the bared walls would hang in the air; off, and a sparse grid, change nothing;
// bad options throw.
#include "mc_test_util.hpp"
#include "pcp/cloud/kdtree.hpp"
#include "pcp/cloud/shapes.hpp"
#include "pcp/core/error.hpp"
#include "pcp/core/rng.hpp"
#include "pcp/mesh/marching_cubes.hpp"
#include "pcp/mesh/through_carve.hpp"

#include <catch2/catch.hpp>

#include <array>
#include <cmath>
#include <vector>

using namespace pcp_test;

namespace {

/// Axis-aligned boxes by centre and half sizes.
struct Box {
    Eigen::Vector3d c, h;
};

/// `n` points uniform over the union of the boxes' surfaces (each box's six faces by area).
pcp::PointsF sample_boxes(const std::vector<Box>& boxes, int n, std::uint64_t seed) {
    struct Face {
        const Box* box;
        int axis;
        double side, area;
    };
    std::vector<Face> faces;
    double total = 0;
    for (const Box& b : boxes)
        for (int a = 0; a < 3; ++a)
            for (double s : {-1.0, 1.0}) {
                const double area = 4.0 * b.h((a + 1) % 3) * b.h((a + 2) % 3);
                faces.push_back({&b, a, s, area});
                total += area;
            }
    pcp::Rng rng(seed);
    pcp::PointsF p(n, 3);
    for (int i = 0; i < n; ++i) {
        double u = rng.uniform() * total;
        std::size_t f = 0;
        while (f + 1 < faces.size() && u > faces[f].area) u -= faces[f++].area;
        const Face& face = faces[f];
        Eigen::Vector3d x;
        for (int a = 0; a < 3; ++a) x(a) = face.box->c(a) + face.box->h(a) * (2.0 * rng.uniform() - 1.0);
        x(face.axis) = face.box->c(face.axis) + face.side * face.box->h(face.axis);
        p.row(i) = x.cast<float>().transpose();
    }
    return p;
}

double aligned_box_sdf(const Box& b, const Eigen::Vector3d& p) {
    const Eigen::Vector3d q = (p - b.c).cwiseAbs() - b.h;
    return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

/// Four slats 0.1 wide, 0.06 thick, 0.08 apart, and the plate that spans them.
const std::vector<Box> kSlats = {{Eigen::Vector3d(-0.27, 0, 0), Eigen::Vector3d(0.05, 0.3, 0.03)},
                                 {Eigen::Vector3d(-0.09, 0, 0), Eigen::Vector3d(0.05, 0.3, 0.03)},
                                 {Eigen::Vector3d(0.09, 0, 0), Eigen::Vector3d(0.05, 0.3, 0.03)},
                                 {Eigen::Vector3d(0.27, 0, 0), Eigen::Vector3d(0.05, 0.3, 0.03)}};
const Box kPlate{Eigen::Vector3d::Zero(), Eigen::Vector3d(0.32, 0.3, 0.03)};

pcp::SdfGrid plate_grid() {
    return dense_grid([](const Eigen::Vector3d& p) { return aligned_box_sdf(kPlate, p); }, 64);
}

}  // namespace

TEST_CASE("through carve: a plate spanning the gaps between slats is carved back into the slats", "[through_carve]") {
    const pcp::KdTree tree(sample_boxes(kSlats, 12000, 3));
    pcp::SdfGrid grid = plate_grid();
    // 64 cells over 1.2: sample 32 is the centre (x = y = z = 0), the middle of the middle gap;
    // sample 37 (x = 0.09375) lies inside the slat at 0.09.
    REQUIRE(grid.value(32, 32, 32) < 0);
    REQUIRE(grid.value(37, 32, 32) < 0);
    REQUIRE(topology(pcp::marching_cubes(grid)).euler() == 2);

    const pcp::ThroughCarveStats st = pcp::carve_through_lines(grid, tree);
    CHECK(st.carved > 0);
    CHECK(st.candidates >= st.carved);
    CHECK(grid.value(32, 32, 32) > 0);
    CHECK(grid.value(37, 32, 32) < 0);
    // Nothing of the plate is left in the gaps (farther than 0.03, 1.6 cells, from every slat).
    int left_in_gaps = 0;
    for (int k = 0; k <= 64; ++k)
        for (int j = 0; j <= 64; ++j)
            for (int i = 0; i <= 64; ++i) {
                if (!(grid.value(i, j, k) < 0)) continue;
                const Eigen::Vector3d p = grid.spec.sample_position(i, j, k);
                double d = 1e9;
                for (const Box& b : kSlats) d = std::min(d, aligned_box_sdf(b, p));
                if (d > 0.03) {
                    ++left_in_gaps;
                    UNSCOPED_INFO("left at " << p.transpose() << ", " << d << " from the slats");
                }
            }
    CHECK(left_in_gaps == 0);
    const pcp::Mesh mesh = pcp::marching_cubes(grid);
    CHECK(topology(mesh).closed_manifold_oriented());
    CHECK(topology(mesh).euler() == 8);  // four separate slats
}

TEST_CASE("through carve: a solid box and a sphere scanned with a hole keep their inside", "[through_carve]") {
    const Box solid{Eigen::Vector3d(0.02, -0.01, 0.03), Eigen::Vector3d(0.3, 0.25, 0.2)};
    const pcp::KdTree box_tree(sample_boxes({solid}, 12000, 5));
    pcp::SdfGrid box_grid = dense_grid([&](const Eigen::Vector3d& p) { return aligned_box_sdf(solid, p); }, 64);
    const std::vector<float> box_before = box_grid.values;
    const pcp::ThroughCarveStats box_st = pcp::carve_through_lines(box_grid, box_tree);
    CHECK(box_st.candidates > 0);
    CHECK(box_st.carved == 0);
    CHECK((box_grid.values == box_before));  // not decomposed: a failure would print both lattices

    // A sphere of radius 0.35 without its cap above z = 0.25 (a hole 0.49 across): the inside sees
    // out through the hole, but every line through it meets the sphere's other side.
    pcp::PointsF all = pcp::sample_sphere(12000, 0.35, Eigen::Vector3d::Zero(), 9).points.cast<float>();
    std::vector<Eigen::Index> kept;
    for (Eigen::Index i = 0; i < all.rows(); ++i)
        if (all(i, 2) < 0.25f) kept.push_back(i);
    pcp::PointsF open(static_cast<Eigen::Index>(kept.size()), 3);
    for (std::size_t i = 0; i < kept.size(); ++i) open.row(static_cast<Eigen::Index>(i)) = all.row(kept[i]);
    const pcp::KdTree sphere_tree(open);
    pcp::SdfGrid sphere_grid = dense_grid(sphere_sdf(Eigen::Vector3d::Zero(), 0.35), 64);
    const std::vector<float> sphere_before = sphere_grid.values;
    const pcp::ThroughCarveStats sphere_st = pcp::carve_through_lines(sphere_grid, sphere_tree);
    CHECK(sphere_st.candidates > 0);
    CHECK(sphere_st.carved == 0);
    CHECK((sphere_grid.values == sphere_before));  // not decomposed: a failure would print both lattices
}

TEST_CASE("through carve: no piece whose bared walls stand away from the data", "[through_carve]") {
    // The points on a sphere of radius 0.2, the field a sphere of radius 0.3 whose centre is 0.1
    // off along x: at x = -0.2 it sits on the points, elsewhere it bulges up to 0.2 beyond them,
    // farther than max_distance. The samples of the bulge near the points see past them (tangent
    // lines); where the whole layer between the field's surface and the points is carvable, it is
    // carved, but a piece that would leave the rest of the bulge with walls that no point supports
    // stays.
    const pcp::KdTree tree(pcp::sample_sphere(8000, 0.2, Eigen::Vector3d::Zero(), 11).points.cast<float>());
    const pcp::SdfGrid fat = dense_grid(sphere_sdf(Eigen::Vector3d(0.1, 0, 0), 0.3), 64);
    pcp::SdfGrid grid = fat;
    const pcp::ThroughCarveStats st = pcp::carve_through_lines(grid, tree);
    INFO("pieces " << st.pieces << ", opened " << st.opened << ", carved " << st.carved);
    CHECK(st.opened >= 1);
    CHECK(st.opened < st.pieces);
    // 64 cells over 1.2: sample (52, 32, 32) is (0.375, 0, 0), 0.175 beyond the points in the bulge.
    CHECK(grid.value(52, 32, 32) < 0);
    pcp::ThroughCarveOptions any;
    any.min_wall_support = 0;
    pcp::SdfGrid all = fat;
    const pcp::ThroughCarveStats st_any = pcp::carve_through_lines(all, tree, any);
    CHECK(st_any.opened == st_any.pieces);
    CHECK(st_any.carved > st.carved);
}

TEST_CASE("through carve: off, or a sparse grid, changes nothing, bad options throw", "[through_carve][heavy]") {
    const pcp::KdTree tree(sample_boxes(kSlats, 4000, 3));
    pcp::SdfGrid grid = plate_grid();
    const std::vector<float> before = grid.values;
    pcp::ThroughCarveOptions off;
    off.enabled = false;
    CHECK(pcp::carve_through_lines(grid, tree, off).carved == 0);
    CHECK((grid.values == before));  // not decomposed: a failure would print both lattices
    pcp::SdfGridOptions coarse;
    coarse.band = pcp::NarrowBand::Coarse;
    pcp::SdfGrid sparse = pcp::evaluate_sdf_grid(batch([](const Eigen::Vector3d& p) { return aligned_box_sdf(kPlate, p); }),
                                                 cube_grid(64), coarse);
    const std::vector<float> sparse_before = sparse.values;
    CHECK(pcp::carve_through_lines(sparse, tree).skipped);
    CHECK((sparse.values == sparse_before));  // not decomposed: a failure would print both lattices

    const auto carve_with = [&](void (*change)(pcp::ThroughCarveOptions&)) {
        pcp::ThroughCarveOptions o;
        change(o);
        pcp::SdfGrid g = plate_grid();
        pcp::carve_through_lines(g, tree, o);
    };
    CHECK_THROWS_AS(carve_with([](pcp::ThroughCarveOptions& o) { o.voxels_per_cell = 0; }), pcp::Error);
    CHECK_THROWS_AS(carve_with([](pcp::ThroughCarveOptions& o) { o.rays = 4; }), pcp::Error);
    CHECK_THROWS_AS(carve_with([](pcp::ThroughCarveOptions& o) { o.min_through_lines = 0; }), pcp::Error);
    CHECK_THROWS_AS(carve_with([](pcp::ThroughCarveOptions& o) { o.min_through_lines = 65; }), pcp::Error);
    CHECK_THROWS_AS(carve_with([](pcp::ThroughCarveOptions& o) { o.dilation = 0; }), pcp::Error);
    CHECK_THROWS_AS(carve_with([](pcp::ThroughCarveOptions& o) { o.max_distance = std::nan(""); }), pcp::Error);
    CHECK_THROWS_AS(carve_with([](pcp::ThroughCarveOptions& o) { o.min_wall_support = 1.5; }), pcp::Error);
}
