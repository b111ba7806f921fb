// Tests for pcp/mesh/repair/through_carve.hpp: a plate that the field spans across the gaps between four
// slats is carved back into the slats (the points lie on the slats only); a narrow bore that the
// field fills is carved open (and 64 directions miss it); a solid box keeps every inside sample,
// a sphere scanned with a hole in its top its inside below the hole's rim; off, and a sparse grid,
// change nothing; bad options throw.
#include "mc_test_util.hpp"
#include "pcp/cloud/kdtree.hpp"
#include "pcp/cloud/shapes.hpp"
#include "pcp/core/error.hpp"
#include "pcp/core/rng.hpp"
#include "pcp/mesh/grid/marching_cubes.hpp"
#include "pcp/mesh/repair/through_carve.hpp"

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

TEST_CASE("through carve: a narrow bore that the field fills is carved open, which 64 directions miss", "[through_carve]") {
    // A block 0.4 x 0.4 x 0.4 with a bore of radius 0.06 along x through it: points on the block's
    // faces but the bore's mouths, and on the bore's wall; the field is the block's, bore filled.
    // From the bore's middle the lines that leave at both ends lie in a cone of about 16 degrees
    // (4 % of the directions), from beside a mouth in one of about 10.
    const Box block{Eigen::Vector3d::Zero(), Eigen::Vector3d(0.2, 0.2, 0.2)};
    const double radius = 0.06;
    const pcp::PointsF faces = sample_boxes({block}, 16000, 13);
    std::vector<Eigen::RowVector3f> kept;
    for (Eigen::Index i = 0; i < faces.rows(); ++i) {
        const Eigen::RowVector3f q = faces.row(i);
        if (std::abs(std::abs(q.x()) - 0.2f) < 1e-6f && std::hypot(q.y(), q.z()) < radius) continue;  // a mouth
        kept.push_back(q);
    }
    pcp::Rng rng(17);
    for (int i = 0; i < 3000; ++i) {
        const double x = -0.2 + 0.4 * rng.uniform(), a = 2 * 3.14159265358979 * rng.uniform();
        kept.emplace_back(float(x), float(radius * std::cos(a)), float(radius * std::sin(a)));
    }
    pcp::PointsF points(static_cast<Eigen::Index>(kept.size()), 3);
    for (std::size_t i = 0; i < kept.size(); ++i) points.row(static_cast<Eigen::Index>(i)) = kept[i];
    const pcp::KdTree tree(points);
    const pcp::SdfGrid filled = dense_grid([&](const Eigen::Vector3d& p) { return aligned_box_sdf(block, p); }, 64);
    // 64 cells over 1.2: sample 32 is the centre, on the bore's axis; (32, 32 + 4, 32) is 0.075
    // from the axis, in the block's body.
    REQUIRE(filled.value(32, 32, 32) < 0);
    REQUIRE(filled.value(32, 36, 32) < 0);

    pcp::SdfGrid grid = filled;
    const pcp::ThroughCarveStats st = pcp::carve_through_lines(grid, tree);
    INFO("pieces " << st.pieces << ", opened " << st.opened << ", carved " << st.carved);
    CHECK(grid.value(32, 32, 32) > 0);
    CHECK(grid.value(24, 32, 32) > 0);  // x = -0.15, in the bore near its mouth
    CHECK(grid.value(32, 36, 32) < 0);
    const pcp::Mesh mesh = pcp::marching_cubes(grid);
    CHECK(topology(mesh).closed_manifold_oriented());
    CHECK(topology(mesh).euler() == 0);  // the block with its bore: genus 1

    // 64 directions over the half-sphere: two or three of them point down the bore, fewer than the
    // 6 lines asked for.
    pcp::ThroughCarveOptions few;
    few.directions = 64;
    pcp::SdfGrid coarse = filled;
    pcp::carve_through_lines(coarse, tree, few);
    CHECK(coarse.value(32, 32, 32) < 0);
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
    // out through the hole, but every line through its deep inside meets the sphere's other side,
    // and the cap's middle is farther from the data than any candidate. Within a few sampling
    // scales of the points a line over the hole may pass the wall through a gap between the balls
    // at its other end: near the rim a groove goes, elsewhere a few samples next to the wall (the
    // field of a real fit spans such a hole flat, in the rim's plane, and loses a few samples).
    pcp::PointsF all = pcp::sample_sphere(12000, 0.35, Eigen::Vector3d::Zero(), 9).points.cast<float>();
    std::vector<Eigen::Index> kept;
    for (Eigen::Index i = 0; i < all.rows(); ++i)
        if (all(i, 2) < 0.25f) kept.push_back(i);
    pcp::PointsF open(static_cast<Eigen::Index>(kept.size()), 3);
    for (std::size_t i = 0; i < kept.size(); ++i) open.row(static_cast<Eigen::Index>(i)) = all.row(kept[i]);
    const pcp::KdTree sphere_tree(open);
    const pcp::SdfGrid sphere_before = dense_grid(sphere_sdf(Eigen::Vector3d::Zero(), 0.35), 64);
    pcp::SdfGrid sphere_grid = sphere_before;
    const pcp::ThroughCarveStats sphere_st = pcp::carve_through_lines(sphere_grid, sphere_tree);
    CHECK(sphere_st.candidates > 0);
    std::int64_t inside = 0, deep_carved = 0, rim_carved = 0;
    for (int k = 0; k <= 64; ++k)
        for (int j = 0; j <= 64; ++j)
            for (int i = 0; i <= 64; ++i) {
                if (!(sphere_before.value(i, j, k) < 0)) continue;
                ++inside;
                if (sphere_grid.value(i, j, k) < 0) continue;
                const Eigen::Vector3d p = sphere_before.spec.sample_position(i, j, k);
                // the rim: the circle z = 0.25, radius sqrt(0.35^2 - 0.25^2)
                const double to_rim = std::hypot(std::hypot(p.x(), p.y()) - std::sqrt(0.35 * 0.35 - 0.25 * 0.25), p.z() - 0.25);
                if (to_rim < 0.1) ++rim_carved;
                if (p.norm() < 0.28) ++deep_carved;  // 0.07 or more inside the wall
            }
    INFO("inside " << inside << ", carved " << sphere_st.carved << ": " << rim_carved << " within 0.1 of the rim, " << deep_carved
                   << " deep");
    CHECK(deep_carved == 0);
    CHECK(rim_carved * 2 > sphere_st.carved);
    CHECK(sphere_st.carved * 20 < inside);
    // 64 cells over 1.2: sample (32, 32, 49) is (0, 0, 0.319), the cap's middle.
    CHECK(sphere_grid.value(32, 32, 49) < 0);
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
    CHECK_THROWS_AS(carve_with([](pcp::ThroughCarveOptions& o) { o.directions = 4; }), pcp::Error);
    CHECK_THROWS_AS(carve_with([](pcp::ThroughCarveOptions& o) { o.min_through_lines = 0; }), pcp::Error);
    CHECK_THROWS_AS(carve_with([](pcp::ThroughCarveOptions& o) { o.min_through_lines = 1025; }), pcp::Error);
    CHECK_THROWS_AS(carve_with([](pcp::ThroughCarveOptions& o) { o.dilation = 0; }), pcp::Error);
    CHECK_THROWS_AS(carve_with([](pcp::ThroughCarveOptions& o) { o.max_distance = std::nan(""); }), pcp::Error);
}
