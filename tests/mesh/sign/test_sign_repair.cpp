// Tests for pcp/sign_repair.hpp: a negative pocket outside the data (bulge) and a positive bubble
// inside it are flipped and vanish from the mesh; a correct field, a hole the field closes by
// itself, and a second true surface are left alone; disabled repair is the identity; bad options.
#include "mc_test_util.hpp"
#include "pcp/core/error.hpp"
#include "pcp/core/rng.hpp"
#include "pcp/mesh/grid/marching_cubes.hpp"
#include "pcp/cloud/shapes.hpp"
#include "pcp/mesh/sign/sign_repair.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

using namespace pcp_test;

namespace {

const pcp::Aabb kBox{Eigen::Vector3d::Constant(-0.6), Eigen::Vector3d::Constant(0.6)};

pcp::PointsF sphere_points(Eigen::Index n, double radius, const Eigen::Vector3d& centre, std::uint64_t seed) {
    return pcp::sample_sphere(n, radius, centre, seed).points.cast<float>();
}

/// The mesh of `field` (optionally repaired) on a dense 48^3 grid over kBox.
pcp::Mesh mesh_of(const pcp::SdfBatchFn& field, const pcp::SignRepair* repair) {
    pcp::SdfBatchFn g = [&](const Eigen::Ref<const pcp::PointsF>& p, Eigen::Ref<Eigen::VectorXf> v) {
        field(p, v);
        if (repair) repair->apply(p, v);
    };
    pcp::GridSpec spec;
    spec.resolution = 48;
    spec.box = kBox;
    pcp::SdfGridOptions opts;
    opts.band = pcp::NarrowBand::Dense;
    return pcp::marching_cubes(pcp::evaluate_sdf_grid(g, spec, opts));
}

float value_at(const pcp::SdfBatchFn& field, const pcp::SignRepair& repair, const Eigen::Vector3f& x) {
    pcp::PointsF p(1, 3);
    p.row(0) = x.transpose();
    Eigen::VectorXf v(1);
    field(p, v);
    repair.apply(p, v);
    return v(0);
}

pcp::SignRepairOptions with_votes(int votes) {
    pcp::SignRepairOptions o;
    o.min_label_votes = votes;
    return o;
}

double max_distance_to_sphere(const pcp::Mesh& mesh, double radius) {
    return (mesh.vertices.rowwise().norm().array() - radius).abs().maxCoeff();
}

}  // namespace

TEST_CASE("sign repair: a negative pocket away from the data is flipped and leaves the mesh", "[sign_repair]") {
    const ScalarSdf sphere = sphere_sdf({0, 0, 0}, 0.3);
    const ScalarSdf pocket = sphere_sdf({0.44, 0, 0}, 0.1);  // 0.04 from the sphere, no data on it
    const pcp::SdfBatchFn field = batch([&](const Eigen::Vector3d& p) { return std::min(sphere(p), pocket(p)); });
    const pcp::PointsF points = sphere_points(4000, 0.3, Eigen::Vector3d::Zero(), 1);
    const pcp::KdTree tree(points);
    const pcp::SignRepair repair(field, kBox, tree);

    // The coarse grid's far cells interpolated (SignRepairOptions::far_factor): the same repair as
    // from every sample evaluated, for a fraction of the evaluations.
    CHECK(repair.stats().evaluations < 65LL * 65 * 65 / 2);
    pcp::SignRepairOptions every;
    every.far_factor = 0;
    const pcp::SignRepair full(field, kBox, tree, every);
    CHECK(full.stats().evaluations == 65LL * 65 * 65);
    CHECK(full.stats().flipped_components == repair.stats().flipped_components);
    CHECK(full.stats().flipped_samples == repair.stats().flipped_samples);
    CHECK(repair.stats().flipped_components == 1);
    CHECK(repair.stats().flipped_samples > 0);
    CHECK(value_at(field, repair, {0.44f, 0, 0}) > 0);   // the pocket's centre is now outside
    CHECK(value_at(field, repair, {0, 0, 0}) < 0);       // the sphere's centre is still inside
    CHECK(value_at(field, repair, {-0.5f, 0, 0}) > 0);

    const MeshTopology before = topology(mesh_of(field, nullptr));
    CHECK(max_distance_to_sphere(mesh_of(field, nullptr), 0.3) > 0.2);  // the pocket's surface
    const pcp::Mesh after = mesh_of(field, &repair);
    const MeshTopology t = topology(after);
    CHECK(t.closed_manifold_oriented());
    CHECK(t.euler() == 2);
    // Only a sliver of the pocket may stay, within tau of the data.
    CHECK(max_distance_to_sphere(after, 0.3) <= repair.stats().tau + 0.03);
    CHECK(before.F > t.F);
}

TEST_CASE("sign repair: a positive bubble inside the shape is flipped", "[sign_repair]") {
    const ScalarSdf sphere = sphere_sdf({0, 0, 0}, 0.4);
    const ScalarSdf bubble = sphere_sdf({0.05, 0, 0}, 0.12);
    const pcp::SdfBatchFn field = batch([&](const Eigen::Vector3d& p) { return std::max(sphere(p), -bubble(p)); });
    const pcp::PointsF points = sphere_points(6000, 0.4, Eigen::Vector3d::Zero(), 2);
    const pcp::SignRepair repair(field, kBox, pcp::KdTree(points));
    CHECK(repair.stats().flipped_components == 1);
    CHECK(value_at(field, repair, {0.05f, 0, 0}) < 0);
    const pcp::Mesh after = mesh_of(field, &repair);
    CHECK(topology(after).euler() == 2);
    CHECK(topology(mesh_of(field, nullptr)).euler() == 4);  // two spheres before
    CHECK(max_distance_to_sphere(after, 0.4) < 0.02);
}

TEST_CASE("sign repair: a correct field, a hole it closes, and a second surface are left alone", "[sign_repair]") {
    SECTION("a correct sphere") {
        const pcp::SdfBatchFn field = batch(sphere_sdf({0, 0, 0}, 0.3));
        const pcp::SignRepair repair(field, kBox, pcp::KdTree(sphere_points(3000, 0.3, Eigen::Vector3d::Zero(), 3)));
        CHECK(repair.stats().flipped_components == 0);
        CHECK(repair.stats().components >= 2);  // outside and inside
    }
    SECTION("no data on a cap: the field closes the hole itself") {
        const pcp::SdfBatchFn field = batch(sphere_sdf({0, 0, 0}, 0.3));
        const pcp::PointsF all = sphere_points(4000, 0.3, Eigen::Vector3d::Zero(), 4);
        std::vector<Eigen::Index> keep;
        for (Eigen::Index i = 0; i < all.rows(); ++i)
            if (all(i, 2) < 0.2f) keep.push_back(i);
        pcp::PointsF points(Eigen::Index(keep.size()), 3);
        for (std::size_t i = 0; i < keep.size(); ++i) points.row(Eigen::Index(i)) = all.row(keep[i]);
        REQUIRE(points.rows() < all.rows() * 0.95);
        const pcp::SignRepair repair(field, kBox, pcp::KdTree(points));
        CHECK(repair.stats().flipped_components == 0);
        CHECK(value_at(field, repair, {0, 0, 0}) < 0);
    }
    SECTION("two spheres, both with data") {
        const ScalarSdf a = sphere_sdf({-0.3, 0, 0}, 0.2), b = sphere_sdf({0.3, 0, 0}, 0.15);
        const pcp::SdfBatchFn field = batch([&](const Eigen::Vector3d& p) { return std::min(a(p), b(p)); });
        pcp::PointsF points(4000, 3);
        points << sphere_points(2500, 0.2, {-0.3, 0, 0}, 5), sphere_points(1500, 0.15, {0.3, 0, 0}, 6);
        const pcp::SignRepair repair(field, kBox, pcp::KdTree(points));
        CHECK(repair.stats().flipped_components == 0);
        CHECK(topology(mesh_of(field, &repair)).euler() == 4);
    }
    SECTION("disabled: the identity, without evaluations") {
        const ScalarSdf sphere = sphere_sdf({0, 0, 0}, 0.3), pocket = sphere_sdf({0.44, 0, 0}, 0.1);
        const pcp::SdfBatchFn field = batch([&](const Eigen::Vector3d& p) { return std::min(sphere(p), pocket(p)); });
        pcp::SignRepairOptions opts;
        opts.enabled = false;
        const pcp::SignRepair repair(field, kBox, pcp::KdTree(sphere_points(3000, 0.3, Eigen::Vector3d::Zero(), 7)), opts);
        CHECK(repair.stats().evaluations == 0);
        CHECK(value_at(field, repair, {0.44f, 0, 0}) < 0);
    }
}

TEST_CASE("sign repair: bad options and inputs are errors", "[sign_repair]") {
    const pcp::SdfBatchFn field = batch(sphere_sdf({0, 0, 0}, 0.3));
    const pcp::PointsF points = sphere_points(100, 0.3, Eigen::Vector3d::Zero(), 9);
    pcp::SignRepairOptions opts;
    opts.resolution = 1;
    CHECK_THROWS_AS(pcp::SignRepair(field, kBox, pcp::KdTree(points), opts), pcp::Error);
    opts.resolution = 257;
    CHECK_THROWS_AS(pcp::SignRepair(field, kBox, pcp::KdTree(points), opts), pcp::Error);
    opts = {};
    opts.max_unsupported = 1.0;
    CHECK_THROWS_AS(pcp::SignRepair(field, kBox, pcp::KdTree(points), opts), pcp::Error);
    opts = {};
    opts.near_cells = -1;
    CHECK_THROWS_AS(pcp::SignRepair(field, kBox, pcp::KdTree(points), opts), pcp::Error);
    CHECK_THROWS_AS(pcp::SignRepair(field, kBox, pcp::KdTree(points.topRows(1))), pcp::Error);
    const pcp::SdfBatchFn nan = [](const Eigen::Ref<const pcp::PointsF>&, Eigen::Ref<Eigen::VectorXf> v) {
        v.setConstant(std::numeric_limits<float>::quiet_NaN());
    };
    CHECK_THROWS_AS(pcp::SignRepair(nan, kBox, pcp::KdTree(points)), pcp::Error);
    const pcp::SignRepair identity;
    Eigen::VectorXf v(2);
    CHECK_THROWS_AS(identity.apply(points.topRows(3), v), pcp::Error);
}

TEST_CASE("sign repair: visibility labels open a part that the field closed with membranes", "[sign_repair][heavy]") {
    // Data: a U-shaped channel (two walls at x = +-0.15 and a floor at z = -0.3, 0.8 long in y).
    // Field: the solid box the channel spans (negative inside), so membranes close its top and its
    // ends. Two thirds of the inside's boundary lies along the walls, so the component rule keeps it;
    // the labels (the inside sees out through the top and the ends) flip it.
    pcp::Rng rng(9, 0);
    pcp::PointsF points(9000, 3);
    for (Eigen::Index i = 0; i < points.rows(); ++i) {
        const double u = rng.uniform(), y = -0.4 + 0.8 * rng.uniform();
        if (i % 3 == 2) points.row(i) << float(-0.15 + 0.3 * u), float(y), -0.3f;           // floor
        else points.row(i) << (i % 3 == 0 ? -0.15f : 0.15f), float(y), float(-0.3 + 0.6 * u);  // walls
    }
    const pcp::SdfBatchFn field = batch([](const Eigen::Vector3d& p) {
        const Eigen::Vector3d q = p.cwiseAbs() - Eigen::Vector3d(0.15, 0.4, 0.3);
        return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
    });
    const pcp::KdTree tree(points);
    const pcp::SignRepair plain(field, kBox, tree);
    CHECK(value_at(field, plain, {0, 0, 0}) < 0);  // left closed without labels
    pcp::VisibilityOptions vo;
    vo.outside_fraction = 0.2;  // the middle sees out through about a third of the directions
    const pcp::VisibilityLabels labels = pcp::label_by_visibility(tree, kBox, vo);
    REQUIRE(labels.stats.outside > 0);
    const pcp::SignRepair repair(field, kBox, tree, with_votes(4), &labels);
    CHECK(repair.stats().label_flipped == 1);
    CHECK(value_at(field, repair, {0, 0, 0}) > 0);
    CHECK(value_at(field, repair, {0, 0.3f, 0.1f}) > 0);
    // Off (min_label_votes = 0): the labels are ignored.
    const pcp::SignRepair ignored(field, kBox, tree, with_votes(0), &labels);
    CHECK(value_at(field, ignored, {0, 0, 0}) < 0);
}

TEST_CASE("sign repair: the label vote leaves a positive inside to the cavity fill", "[sign_repair][heavy]") {
    // A thin negative shell around the sphere with the inside positive: the labels say inside, but
    // a coarse flip would leave the shell's inner layer as a sheet, so the vote does not act.
    const pcp::SdfBatchFn field = batch([](const Eigen::Vector3d& p) { return std::abs(p.norm() - 0.3) - 0.01; });
    const pcp::PointsF points = sphere_points(6000, 0.3, Eigen::Vector3d::Zero(), 2);
    const pcp::KdTree tree(points);
    const pcp::VisibilityLabels labels = pcp::label_by_visibility(tree, kBox);
    REQUIRE(labels.stats.inside > 0);
    const pcp::SignRepair repair(field, kBox, tree, with_votes(4), &labels);
    CHECK(repair.stats().label_flipped == 0);
    CHECK(value_at(field, repair, {0, 0, 0}) > 0);
}
