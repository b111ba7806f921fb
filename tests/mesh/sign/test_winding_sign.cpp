// Tests for pcp/mesh/sign/winding_sign.hpp: the Barnes-Hut winding number against brute force; normals
// oriented outward by a field that is right only near the data; an inner sheet under a sphere and a
// plug across a torus's hole removed by apply() while values near the data keep their sign; a field
// of the opposite convention still gives outward normals; disabled and bad options; points oriented
// by visibility labels (a sphere outward, a thin plate skipped) and the labels' outside where the
// winding number is unclear (a bore whose wall the scan missed).
#include "mc_test_util.hpp"
#include "pcp/cloud/kdtree.hpp"
#include "pcp/cloud/shapes.hpp"
#include "pcp/cloud/visibility.hpp"
#include "pcp/core/error.hpp"
#include "pcp/core/rng.hpp"
#include "pcp/mesh/grid/marching_cubes.hpp"
#include "pcp/mesh/grid/mesh_check.hpp"
#include "pcp/mesh/sign/winding_sign.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

using namespace pcp_test;

namespace {

pcp::PointsF unit_points(const pcp::PointCloud& c) { return c.points.cast<float>(); }

/// The default options, switched on (WindingSignOptions{} is off; the default and fast presets turn it on).
pcp::WindingSignOptions on() {
    pcp::WindingSignOptions o;
    o.enabled = true;
    return o;
}

/// Sphere of radius R at the origin whose field has an inner sheet at depth `depth`: right in a
/// layer under the surface, then positive again (a hollow sphere: the wrong sign in its core).
ScalarSdf sphere_with_inner_sheet(double R, double depth) {
    return [=](const Eigen::Vector3d& p) { return std::max(p.norm() - R, (R - depth) - p.norm()); };
}

/// Torus around the z axis, not rotated (sample_torus's frame), with its hole at z = 0.
ScalarSdf flat_torus(double R, double r) {
    return [=](const Eigen::Vector3d& p) { return std::hypot(std::hypot(p.x(), p.y()) - R, p.z()) - r; };
}

}  // namespace

TEST_CASE("winding sign: the tree's winding number matches brute force", "[winding_sign]") {
    const pcp::PointCloud c = pcp::sample_sphere(4000, 0.35, Eigen::Vector3d::Zero(), 3);
    const pcp::PointsF pts = unit_points(c);
    const pcp::KdTree tree(pts);
    const pcp::WindingSign ws(batch(sphere_sdf(Eigen::Vector3d::Zero(), 0.35)), tree, on());
    pcp::PointsF q(6, 3);
    q << 0, 0, 0, 0.1, -0.05, 0.2, 0.3, 0, 0, 0.45, 0, 0, 0, 0.6, 0.1, -0.8, 0.3, 0.2;
    const Eigen::VectorXf fast = ws.winding(q);
    const Eigen::VectorXf brute = pcp::winding_number_brute_force(tree.points(), ws.normals(), ws.areas(), q);
    for (Eigen::Index i = 0; i < q.rows(); ++i) {
        INFO("query " << i << ": tree " << fast(i) << ", brute force " << brute(i));
        CHECK(std::abs(fast(i) - brute(i)) < 0.03);
    }
    // Inside about 1, outside about 0 (the areas make the sum a surface integral).
    CHECK(brute(0) == Approx(1.0).margin(0.08));
    CHECK(brute(1) == Approx(1.0).margin(0.08));
    CHECK(std::abs(brute(3)) < 0.08);
    CHECK(std::abs(brute(5)) < 0.05);
}

TEST_CASE("winding sign: normals are oriented outward by a field that is wrong under the surface", "[winding_sign]") {
    const double R = 0.4, depth = 0.05;
    const pcp::PointCloud c = pcp::sample_sphere(8000, R, Eigen::Vector3d::Zero(), 5);
    const pcp::KdTree tree(unit_points(c));
    const pcp::WindingSign ws(batch(sphere_with_inner_sheet(R, depth)), tree, on());
    const pcp::PointsF& n = ws.normals();
    Eigen::Index outward = 0;
    for (Eigen::Index i = 0; i < n.rows(); ++i)
        if (n.row(i).dot(tree.points().row(i)) > 0) ++outward;
    CHECK(outward == n.rows());
    CHECK(ws.stats().points == n.rows());
    CHECK(ws.stats().tau > 0);
}

TEST_CASE("winding sign: a field negative outside still gives outward normals and w = 1 inside", "[winding_sign]") {
    const pcp::PointCloud c = pcp::sample_sphere(3000, 0.3, Eigen::Vector3d::Zero(), 2);
    const pcp::KdTree tree(unit_points(c));
    const ScalarSdf inverted = [](const Eigen::Vector3d& p) { return 0.3 - p.norm(); };
    const pcp::WindingSign ws(batch(inverted), tree, on());
    CHECK(ws.stats().inward);
    Eigen::Index outward = 0;
    for (Eigen::Index i = 0; i < tree.size(); ++i) outward += ws.normals().row(i).dot(tree.points().row(i)) > 0;
    CHECK(outward == tree.size());
    pcp::PointsF q(1, 3);
    q << 0.05, 0.0, 0.0;
    CHECK(ws.winding(q)(0) == Approx(1.0).margin(0.05));
    const pcp::WindingSign right(batch(sphere_sdf(Eigen::Vector3d::Zero(), 0.3)), tree, on());
    CHECK_FALSE(right.stats().inward);
}

TEST_CASE("winding sign: an inner sheet under a sphere is removed, the surface through the data is kept", "[winding_sign]") {
    const double R = 0.4, depth = 0.05;
    const pcp::PointCloud c = pcp::sample_sphere(8000, R, Eigen::Vector3d::Zero(), 5);
    const pcp::KdTree tree(unit_points(c));
    const ScalarSdf f = sphere_with_inner_sheet(R, depth);
    const pcp::WindingSign ws(batch(f), tree, on());
    // Points in the wrong-signed core (depth 0.08), just outside, and at the data.
    pcp::PointsF q(300, 3);
    const pcp::PointsF& pts = tree.points();
    for (Eigen::Index i = 0; i < 100; ++i) {
        const Eigen::RowVector3f dir = pts.row(i * 37).normalized();
        q.row(i) = dir * static_cast<float>(R - 0.08);
        q.row(100 + i) = dir * static_cast<float>(R + 0.03);
        q.row(200 + i) = dir * static_cast<float>(R - 0.002);
    }
    REQUIRE(0.03 > ws.stats().tau);  // every query but the last hundred is away from the data
    Eigen::VectorXf v(q.rows());
    batch(f)(q, v);
    const Eigen::VectorXf before = v;
    ws.apply(q, v);
    for (Eigen::Index i = 0; i < 100; ++i) {
        CHECK(before(i) > 0);  // the wrong sign ...
        CHECK(v(i) < 0);       // ... corrected
        CHECK(std::abs(v(i)) == std::abs(before(i)));
        CHECK(v(100 + i) == before(100 + i));  // outside: right already
        CHECK(v(200 + i) == before(200 + i));  // at the data: the field's own sign
    }
    CHECK(ws.corrected() == 100);

    // The mesh of the corrected field is one sphere (the inner sheet is gone).
    const pcp::SdfBatchFn corrected = [&](const Eigen::Ref<const pcp::PointsF>& p, Eigen::Ref<Eigen::VectorXf> out) {
        batch(f)(p, out);
        ws.apply(p, out);
    };
    const pcp::Mesh before_mesh = pcp::marching_cubes(pcp::evaluate_sdf_grid(batch(f), cube_grid(64)));
    const pcp::Mesh after_mesh = pcp::marching_cubes(pcp::evaluate_sdf_grid(corrected, cube_grid(64)));
    CHECK(topology(before_mesh).euler() == 4);  // two spheres
    CHECK(topology(after_mesh).euler() == 2);   // one
    CHECK(topology(after_mesh).closed_manifold_oriented());
}

TEST_CASE("winding sign: a plug across a torus's hole is opened (genus 1)", "[winding_sign]") {
    const double R = 0.3, r = 0.1;
    const pcp::PointCloud c = pcp::sample_torus(12000, R, r, 7);
    const pcp::KdTree tree(unit_points(c));
    const ScalarSdf torus = flat_torus(R, r);
    // The field says "inside" in a slab across the hole: there it is minus the distance to the torus
    // (the pulling loss only fits |F|), so it touches zero at the hole's wall without crossing it.
    const ScalarSdf plugged = [=](const Eigen::Vector3d& p) {
        const double t = torus(p);
        if (std::hypot(p.x(), p.y()) < R && std::abs(p.z()) < 0.8 * r) return -std::abs(t);
        return t;
    };
    const pcp::Mesh before = pcp::marching_cubes(pcp::evaluate_sdf_grid(batch(plugged), cube_grid(64)));
    REQUIRE(topology(before).euler() == 2);  // genus 0: the hole is closed
    const pcp::WindingSign ws(batch(plugged), tree, on());
    const pcp::SdfBatchFn corrected = [&](const Eigen::Ref<const pcp::PointsF>& p, Eigen::Ref<Eigen::VectorXf> out) {
        batch(plugged)(p, out);
        ws.apply(p, out);
    };
    const pcp::Mesh after = pcp::marching_cubes(pcp::evaluate_sdf_grid(corrected, cube_grid(64)));
    const auto topo = topology(after);
    CHECK(topo.closed_manifold_oriented());
    CHECK(topo.euler() == 0);  // one torus: genus 1
    // Nothing left in the middle of the hole.
    Eigen::Index in_hole = 0;
    for (Eigen::Index v = 0; v < after.vertices.rows(); ++v) in_hole += std::hypot(after.vertices(v, 0), after.vertices(v, 1)) < 0.15;
    CHECK(in_hole == 0);

    // The hole's wall has no vote of its own (the field is negative on both sides of it): without
    // the spread of orientation from the confident points, half its normals point into the tube and
    // the winding number in the hole is unclear, so the plug stays.
    pcp::WindingSignOptions own_votes_only = on();
    own_votes_only.normals.confident_vote = 0;
    const pcp::WindingSign unspread(batch(plugged), tree, own_votes_only);
    const pcp::SdfBatchFn partly = [&](const Eigen::Ref<const pcp::PointsF>& p, Eigen::Ref<Eigen::VectorXf> out) {
        batch(plugged)(p, out);
        unspread.apply(p, out);
    };
    CHECK(topology(pcp::marching_cubes(pcp::evaluate_sdf_grid(partly, cube_grid(64)))).euler() != 0);
    CHECK(unspread.stats().weak_orientation == 0);
    CHECK(ws.stats().weak_orientation > 0);
}

TEST_CASE("winding sign: disabled is the identity, bad options throw", "[winding_sign]") {
    const pcp::PointCloud c = pcp::sample_sphere(500, 0.3, Eigen::Vector3d::Zero(), 1);
    const pcp::KdTree tree(unit_points(c));
    const pcp::SdfBatchFn f = batch(sphere_sdf(Eigen::Vector3d::Zero(), 0.3));
    pcp::WindingSignOptions off;
    off.enabled = false;
    const pcp::WindingSign ws(f, tree, off);
    pcp::PointsF q(2, 3);
    q << 0, 0, 0, 0.5, 0, 0;
    Eigen::VectorXf v(2);
    v << 1.0f, -1.0f;  // both wrong
    ws.apply(q, v);
    CHECK(v(0) == 1.0f);
    CHECK(v(1) == -1.0f);
    const pcp::WindingSign identity;
    identity.apply(q, v);
    CHECK(v(0) == 1.0f);

    pcp::WindingSignOptions bad = on();
    bad.normals.normal_k = 2;
    CHECK_THROWS_AS(pcp::WindingSign(f, tree, bad), pcp::Error);
    bad = on();
    bad.margin = 0.5;
    CHECK_THROWS_AS(pcp::WindingSign(f, tree, bad), pcp::Error);
    bad = on();
    bad.opening = 0.5;
    CHECK_THROWS_AS(pcp::WindingSign(f, tree, bad), pcp::Error);
    bad = on();
    bad.near_k = -1;
    CHECK_THROWS_AS(pcp::WindingSign(f, tree, bad), pcp::Error);
    bad = on();
    bad.labels_near_k = -1;
    CHECK_THROWS_AS(pcp::WindingSign(f, tree, bad), pcp::Error);
    CHECK_THROWS_AS(pcp::WindingSign(pcp::label_by_visibility(tree), tree, bad), pcp::Error);
    const pcp::PointCloud few = pcp::sample_sphere(10, 0.3, Eigen::Vector3d::Zero(), 1);
    const pcp::KdTree small(unit_points(few));
    CHECK_THROWS_AS(pcp::WindingSign(f, small, on()), pcp::Error);
    const pcp::SdfBatchFn nan_field = [](const Eigen::Ref<const pcp::PointsF>&, Eigen::Ref<Eigen::VectorXf> out) {
        out.setConstant(std::nanf(""));
    };
    CHECK_THROWS_AS(pcp::WindingSign(nan_field, tree, on()), pcp::Error);
}

TEST_CASE("winding sign: a field that cannot orient the cloud is skipped on a sample, a borderline one counted in full", "[winding_sign]") {
    constexpr double R = 0.35;
    const pcp::PointCloud c = pcp::sample_sphere(6000, R, Eigen::Vector3d::Zero(), 5);
    const pcp::KdTree tree(unit_points(c));
    const ScalarSdf sphere = sphere_sdf(Eigen::Vector3d::Zero(), R);
    // Signed above z = z0, unsigned below: the fraction (R - z0) / 2R of the points votes confidently.
    auto signed_above = [&](double z0) -> ScalarSdf {
        return [=](const Eigen::Vector3d& p) { return p.z() >= z0 ? sphere(p) : std::abs(sphere(p)); };
    };
    pcp::WindingSignOptions o = on();
    REQUIRE(o.precheck_points == 2048);
    // 20 %: the sample decides (well below 0.5 - 0.05).
    const pcp::WindingSign low(batch(signed_above(0.6 * R)), tree, o);
    CHECK(low.stats().skipped);
    CHECK(low.stats().sampled == 2048);
    CHECK(static_cast<double>(low.stats().confident) / 6000.0 == Approx(0.2).margin(0.04));
    // 48 %: the sample cannot tell, every point is counted, and the count skips it.
    const pcp::WindingSign border(batch(signed_above(0.04 * R)), tree, o);
    CHECK(border.stats().skipped);
    CHECK(border.stats().sampled == 0);
    CHECK(static_cast<double>(border.stats().confident) / 6000.0 == Approx(0.48).margin(0.03));
    // 60 %: oriented and applied.
    const pcp::WindingSign high(batch(signed_above(-0.2 * R)), tree, o);
    CHECK_FALSE(high.stats().skipped);
    CHECK(high.stats().sampled == 0);
    // Without the sample the low one is counted in full, with the same decision.
    o.precheck_points = 0;
    const pcp::WindingSign full(batch(signed_above(0.6 * R)), tree, o);
    CHECK(full.stats().skipped);
    CHECK(full.stats().sampled == 0);
    CHECK(std::abs(full.stats().confident - low.stats().confident) < 0.04 * 6000);
    o.precheck_points = -1;
    CHECK_THROWS_AS(pcp::WindingSign(batch(sphere), tree, o), pcp::Error);
    o = on();
    o.precheck_slack = 1.5;
    CHECK_THROWS_AS(pcp::WindingSign(batch(sphere), tree, o), pcp::Error);
}

namespace {

/// A washer (a thick tube) around the z axis: outer radius 0.4, bore radius 0.15, |z| <= 0.25,
/// sampled evenly on its outer wall and end rings, and on its bore's wall only for |z| > gap: the
/// bore's middle band is a hole in the scan. Returns the unit-box points.
pcp::PointsF washer_with_unscanned_bore(double gap, std::uint64_t seed) {
    constexpr double Ro = 0.4, Ri = 0.15, H = 0.25, kPi = 3.14159265358979323846;
    const double density = 60000.0;  // points per unit area
    pcp::Rng rng(seed, 1);
    std::vector<Eigen::RowVector3f> pts;
    auto add = [&](double x, double y, double z) { pts.emplace_back(float(x), float(y), float(z)); };
    for (int i = 0, n = int(density * 2 * kPi * Ro * 2 * H); i < n; ++i) {
        const double t = 2 * kPi * rng.uniform(), z = H * (2 * rng.uniform() - 1);
        add(Ro * std::cos(t), Ro * std::sin(t), z);
    }
    for (int i = 0, n = int(density * 2 * kPi * Ri * 2 * (H - gap)); i < n; ++i) {
        const double t = 2 * kPi * rng.uniform(), u = (H - gap) * (2 * rng.uniform() - 1);
        add(Ri * std::cos(t), Ri * std::sin(t), u < 0 ? u - gap : u + gap);
    }
    for (int i = 0, n = int(density * kPi * (Ro * Ro - Ri * Ri)); i < 2 * n; ++i) {
        const double t = 2 * kPi * rng.uniform(), r = std::sqrt(Ri * Ri + (Ro * Ro - Ri * Ri) * rng.uniform());
        add(r * std::cos(t), r * std::sin(t), i < n ? H : -H);
    }
    pcp::PointsF out(static_cast<Eigen::Index>(pts.size()), 3);
    for (std::size_t i = 0; i < pts.size(); ++i) out.row(static_cast<Eigen::Index>(i)) = pts[i];
    return out;
}

}  // namespace

TEST_CASE("winding sign: points oriented by visibility labels face outward, a sphere's inside is 1", "[winding_sign]") {
    const pcp::PointCloud c = pcp::sample_sphere(8000, 0.35, Eigen::Vector3d::Zero(), 5);
    const pcp::KdTree tree(unit_points(c));
    const pcp::VisibilityLabels labels = pcp::label_by_visibility(tree);
    const pcp::WindingSign ws(labels, tree, on());
    REQUIRE_FALSE(ws.stats().skipped);
    CHECK(ws.stats().by_labels);
    CHECK(ws.stats().confident > 6000);  // the labels see outside on one side of nearly every point
    CHECK_FALSE(ws.stats().inward);
    Eigen::Index outward = 0;
    for (Eigen::Index i = 0; i < tree.size(); ++i) outward += ws.normals().row(i).dot(tree.points().row(i)) > 0;
    CHECK(outward == tree.size());
    pcp::PointsF q(2, 3);
    q << 0.05, -0.1, 0.0, 0.6, 0.0, 0.0;
    const Eigen::VectorXf w = ws.winding(q);
    CHECK(w(0) == Approx(1.0).margin(0.05));
    CHECK(std::abs(w(1)) < 0.05);
}

TEST_CASE("winding sign: a thin plate seen from both sides gives the labels no side, and is skipped", "[winding_sign]") {
    pcp::Rng rng(3, 1);
    pcp::PointsF pts(6000, 3);
    for (Eigen::Index i = 0; i < pts.rows(); ++i)  // both faces of a 0.6 x 0.6 x 0.004 plate
        pts.row(i) << float(0.6 * rng.uniform() - 0.3), float(0.6 * rng.uniform() - 0.3), i % 2 ? 0.002f : -0.002f;
    const pcp::KdTree tree(pts);
    const pcp::WindingSign ws(pcp::label_by_visibility(tree), tree, on());
    CHECK(ws.stats().skipped);
    CHECK(ws.stats().by_labels);
    CHECK(ws.stats().confident < tree.size() / 10);
    pcp::PointsF q(1, 3);
    q << 0.0f, 0.0f, 0.2f;
    Eigen::VectorXf v(1);
    v << -1.0f;
    ws.apply(q, v);
    CHECK(v(0) == -1.0f);  // skipped: the identity
    pcp::VisibilityLabels empty;
    CHECK_THROWS_AS(pcp::WindingSign(empty, tree, on()), pcp::Error);
}

TEST_CASE("winding sign: a bore whose wall the scan missed is opened by the labels where the winding number is unclear",
          "[winding_sign]") {
    const pcp::PointsF pts = washer_with_unscanned_bore(0.07, 11);
    const pcp::KdTree tree(pts);
    const pcp::VisibilityLabels labels = pcp::label_by_visibility(tree);
    const pcp::WindingSign ws(labels, tree, on());
    REQUIRE_FALSE(ws.stats().skipped);
    // The bore's middle (on the axis, in the unscanned band) and the solid between the walls.
    pcp::PointsF q(4, 3);
    q << 0.0f, 0.0f, 0.0f, 0.05f, 0.0f, 0.0f, 0.0f, -0.04f, 0.02f, 0.0f, 0.3f, 0.0f;
    const Eigen::VectorXf w = ws.winding(q);
    for (int i = 0; i < 3; ++i) {
        INFO("bore point " << i << ": w = " << w(i) << ", label " << labels.label_at(q.row(i).transpose().cast<double>()));
        CHECK(std::abs(w(i) - 0.5f) <= 0.2f);  // unclear: the missed wall leaves it half enclosed
        CHECK(labels.label_at(q.row(i).transpose().cast<double>()) > 0);  // the lines along the bore are free
    }
    CHECK(w(3) > 0.7f);  // inside the material: clear
    // A field that plugs the bore (negative there) and is hollow in the material (positive there).
    Eigen::VectorXf v(4);
    v << -0.01f, -0.01f, -0.01f, 0.02f;
    ws.apply(q, v);
    CHECK(v(0) > 0);
    CHECK(v(1) > 0);
    CHECK(v(2) > 0);
    CHECK(v(3) < 0);
    CHECK(ws.corrected() == 4);
}

TEST_CASE("winding sign: near points the labels oriented by their neighbours only beyond labels_near_k", "[winding_sign]") {
    // A ball with a thin fin: the fin's two faces see outside on both sides, their votes are weak
    // and they take their orientation from the ball's points by the spread.
    pcp::Rng rng(5, 1);
    const pcp::PointCloud ball = pcp::sample_sphere(6000, 0.25, Eigen::Vector3d::Zero(), 4);
    pcp::PointsF pts(6000 + 4000, 3);
    pts.topRows(6000) = ball.points.cast<float>();
    for (Eigen::Index i = 0; i < 4000; ++i)
        pts.row(6000 + i) << float(0.24 + 0.22 * rng.uniform()), float(0.2 * rng.uniform() - 0.1), i % 2 ? 0.003f : -0.003f;
    const pcp::KdTree tree(pts);
    const pcp::VisibilityLabels labels = pcp::label_by_visibility(tree);
    const pcp::WindingSign ws(labels, tree, on());
    REQUIRE_FALSE(ws.stats().skipped);
    const double scale = pcp::sampling_scale(tree);
    // Over the fin at 0.7 sampling scales (beyond near_k 0.4, within labels_near_k 0.8), at 0.9
    // (just beyond it: a layer the field left there is corrected) and at 1.5.
    pcp::PointsF q(3, 3);
    q << 0.4f, 0.0f, float(0.003 + 0.7 * scale), 0.4f, 0.0f, float(0.003 + 1.5 * scale), 0.4f, 0.0f,
        float(0.003 + 0.9 * scale);
    const Eigen::VectorXf w = ws.winding(q);
    INFO("w near the fin " << w(0) << ", farther " << w(1) << ", at 0.9 scales " << w(2) << ", scale " << scale);
    Eigen::VectorXf v(3);
    v << -0.01f, -0.01f, -0.01f;  // a sheet of the field over the fin
    const auto lo = static_cast<float>(0.5 - on().margin);
    const Eigen::VectorXf before = v;
    ws.apply(q, v);
    CHECK(v(0) == before(0));  // within labels_near_k of a weakly oriented point: the field's sign
    REQUIRE(w(1) < lo);
    CHECK(v(1) > 0);  // farther, the clear winding number decides
    REQUIRE(w(2) < lo);
    CHECK(v(2) > 0);  // and already at 0.9 scales
    // The same sample is decided at near_k when the fin's points are treated as the ball's.
    pcp::WindingSignOptions same = on();
    same.labels_near_k = same.near_k;
    const pcp::WindingSign strict(labels, tree, same);
    Eigen::VectorXf u = before;
    strict.apply(q, u);
    REQUIRE(w(0) < lo);
    CHECK(u(0) > 0);
}
