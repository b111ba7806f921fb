// Tests for pcp/mesh/surface/fairing.hpp: a crumpled cap with no points under it comes out smooth and
// nearer the sphere; supported vertices and a patch touching no data stay; bad input throws.
#include "surface_test_util.hpp"
#include "pcp/core/error.hpp"
#include "pcp/core/rng.hpp"
#include "pcp/mesh/grid/mesh_check.hpp"
#include "pcp/mesh/surface/fairing.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <random>

using namespace pcp_test;

namespace {

/// The vertices of a sphere mesh with x > x_cut crumpled radially (a deterministic pattern of
/// amplitude `amplitude`), and points on the sphere with x < x_data only.
struct CrumpledCap {
    pcp::Mesh mesh;
    pcp::PointsF points;
    std::vector<Eigen::Index> cap;  ///< the crumpled vertices
};

CrumpledCap crumpled_cap(double R, double x_cut, double x_data, double amplitude) {
    CrumpledCap c;
    c.mesh = mesh_of(sphere_sdf(Eigen::Vector3d::Zero(), R), 60);
    for (Eigen::Index v = 0; v < c.mesh.vertices.rows(); ++v) {
        const Eigen::RowVector3d p = c.mesh.vertices.row(v);
        if (p.x() <= x_cut) continue;
        const double bump = amplitude * std::sin(97 * p.y() + 3) * std::cos(89 * p.z() + 1);
        c.mesh.vertices.row(v) = p * (1 + bump / p.norm());
        c.cap.push_back(v);
    }
    const pcp::PointsF all = sphere_points(20000, R, 7);
    std::vector<Eigen::Index> keep;
    for (Eigen::Index i = 0; i < all.rows(); ++i)
        if (all(i, 0) < x_data) keep.push_back(i);
    c.points.resize(static_cast<Eigen::Index>(keep.size()), 3);
    for (std::size_t k = 0; k < keep.size(); ++k) c.points.row(static_cast<Eigen::Index>(k)) = all.row(keep[k]);
    return c;
}

double mean_radial_error(const pcp::Mesh& mesh, const std::vector<Eigen::Index>& vertices, double radius) {
    double s = 0;
    for (Eigen::Index v : vertices) s += std::abs(mesh.vertices.row(v).norm() - radius);
    return s / static_cast<double>(vertices.size());
}

/// The mean over `vertices` of |r_v - the mean r of v's edge neighbours| (r: distance to the
/// origin): the crumples, not the cap's overall shape.
double radial_roughness(const pcp::Mesh& mesh, const std::vector<Eigen::Index>& vertices) {
    std::vector<double> sum(static_cast<std::size_t>(mesh.vertices.rows()), 0.0), count(sum.size(), 0.0);
    for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f)
        for (int k = 0; k < 3; ++k) {
            const int a = mesh.faces(f, k), b = mesh.faces(f, (k + 1) % 3);
            sum[static_cast<std::size_t>(a)] += mesh.vertices.row(b).norm();
            count[static_cast<std::size_t>(a)] += 1;
        }
    double s = 0;
    for (Eigen::Index v : vertices)
        s += std::abs(mesh.vertices.row(v).norm() - sum[static_cast<std::size_t>(v)] / count[static_cast<std::size_t>(v)]);
    return s / static_cast<double>(vertices.size());
}

}  // namespace

TEST_CASE("fairing: a crumpled cap with no points under it comes out smooth and near the sphere, the supported rest stays",
          "[surface_fit]") {
    const double R = 0.2937;  // no grid node on the sphere: no degenerate triangle
    const CrumpledCap c = crumpled_cap(R, 0.2, 0.17, 0.02);
    REQUIRE(c.cap.size() > 100);
    const pcp::KdTree tree(c.points);
    pcp::FairStats st;
    const pcp::Mesh out = pcp::fair_unsupported(c.mesh, tree, {}, &st);
    const double before = mean_radial_error(c.mesh, c.cap, R), after = mean_radial_error(out, c.cap, R);
    const double rough_before = radial_roughness(c.mesh, c.cap), rough_after = radial_roughness(out, c.cap);
    INFO("crumpled cap: mean |r - R| before " << before << ", after " << after << ", roughness before " << rough_before
                                              << ", after " << rough_after << "; " << st.free_vertices << " free vertices in "
                                              << st.patches << " patches, mean move " << st.mean_move);
    CHECK(rough_after < rough_before / 10);  // the crumples are gone
    CHECK(after < before / 1.5);             // and the cap is nearer the sphere: a thin plate, not a flat lid
    CHECK(st.patches >= 1);  // the cap, and maybe a vertex or two in the random sampling's widest gaps
    CHECK(st.unanchored == 0);
    CHECK(st.free_vertices >= static_cast<std::int64_t>(c.cap.size()));
    // Supported vertices (support_count input points within the radius) do not move at all.
    const Eigen::VectorXf d = tree.kth_distance(c.mesh.vertices.cast<float>(), pcp::FairOptions{}.support_count);
    const double radius = pcp::FairOptions{}.support_k * pcp::sampling_scale(tree);
    std::int64_t moved_supported = 0;
    for (Eigen::Index v = 0; v < d.size(); ++v)
        if (d(v) <= radius && out.vertices.row(v) != c.mesh.vertices.row(v)) ++moved_supported;
    CHECK(moved_supported == 0);
    CHECK(out.faces == c.mesh.faces);
    CHECK(pcp::is_closed_and_oriented(out));
}

TEST_CASE("fairing: stray points scattered over an unsupported cap do not hold its crumples", "[surface_fit]") {
    // A noisy scan's strays: single points far apart, lying on the crumpled cap itself. One point
    // is not data under the surface (FairOptions::support_count): the whole cap is faired.
    const double R = 0.2937;
    CrumpledCap c = crumpled_cap(R, 0.2, 0.17, 0.02);
    REQUIRE(c.cap.size() > 500);
    std::vector<Eigen::Index> strays;
    for (std::size_t k = 0; k < c.cap.size(); k += 30) strays.push_back(c.cap[k]);
    const Eigen::Index n = c.points.rows();
    c.points.conservativeResize(n + static_cast<Eigen::Index>(strays.size()), 3);
    for (std::size_t k = 0; k < strays.size(); ++k)
        c.points.row(n + static_cast<Eigen::Index>(k)) = c.mesh.vertices.row(strays[k]).cast<float>();
    const pcp::KdTree tree(c.points);
    // No two strays share a vertex's support radius, so every cap vertex has at most one point near it.
    const double radius = pcp::FairOptions{}.support_k * pcp::sampling_scale(tree);
    const Eigen::VectorXf second = tree.kth_distance(c.mesh.vertices.cast<float>(), 2);
    for (Eigen::Index v : c.cap) REQUIRE(second(v) > radius);
    const auto held_in_place = [&](const pcp::Mesh& faired) {  // cap vertices the fairing left where they were
        std::int64_t held = 0;
        for (Eigen::Index v : c.cap) held += faired.vertices.row(v) == c.mesh.vertices.row(v) ? 1 : 0;
        return held;
    };
    pcp::FairStats st;
    const pcp::Mesh out = pcp::fair_unsupported(c.mesh, tree, {}, &st);
    const std::int64_t held = held_in_place(out);
    INFO(strays.size() << " strays; " << held << " of " << c.cap.size() << " cap vertices did not move; roughness "
                       << radial_roughness(c.mesh, c.cap) << " -> " << radial_roughness(out, c.cap));
    CHECK(held == 0);
    CHECK(radial_roughness(out, c.cap) < radial_roughness(c.mesh, c.cap) / 10);
    CHECK(mean_radial_error(out, c.cap, R) < mean_radial_error(c.mesh, c.cap, R) / 1.5);
    // Counting one point as support (the rule before), the strays hold the vertices near them.
    pcp::FairOptions one;
    one.support_count = 1;
    CHECK(held_in_place(pcp::fair_unsupported(c.mesh, tree, one)) >= static_cast<std::int64_t>(strays.size()));
    one.support_count = 0;
    CHECK_THROWS_AS(pcp::fair_unsupported(c.mesh, tree, one), pcp::Error);
}

TEST_CASE("fairing: a patch whose solution leaves its box is left as it was", "[surface_fit]") {
    // A cap pushed deep inside the sphere: the thin plate over it rises back out, above the box of
    // the cap and its border; with no margin (guard 0) the guard keeps the patch as it was.
    const double R = 0.2937;
    CrumpledCap c = crumpled_cap(R, 0.2, 0.17, 0.0);
    for (Eigen::Index v : c.cap) c.mesh.vertices.row(v) *= 0.75;
    const pcp::KdTree tree(c.points);
    pcp::FairOptions strict;
    strict.guard = 0;
    pcp::FairStats st;
    const pcp::Mesh kept = pcp::fair_unsupported(c.mesh, tree, strict, &st);
    CHECK(st.reverted >= 1);
    for (Eigen::Index v : c.cap) CHECK(kept.vertices.row(v) == c.mesh.vertices.row(v));
    // With the default margin the same cap is faired, back toward the sphere.
    const pcp::Mesh faired = pcp::fair_unsupported(c.mesh, tree, {}, &st);
    CHECK(st.reverted == 0);
    CHECK(mean_radial_error(faired, c.cap, R) < mean_radial_error(c.mesh, c.cap, R) / 2);
    strict.guard = -1;
    CHECK_THROWS_AS(pcp::fair_unsupported(c.mesh, tree, strict), pcp::Error);
}

TEST_CASE("fairing: a fully supported mesh and a disabled fairing are the identity, a patch touching no data stays, bad input throws",
          "[surface_fit]") {
    const double R = 0.3;
    const pcp::Mesh sphere = mesh_of(sphere_sdf(Eigen::Vector3d::Zero(), R), 40);
    const pcp::KdTree everywhere(sphere.vertices.cast<float>());  // a point on every vertex
    pcp::FairStats st;
    CHECK(pcp::fair_unsupported(sphere, everywhere, {}, &st).vertices == sphere.vertices);
    CHECK(st.free_vertices == 0);
    // A second sphere far from every point: no supported vertex to join, so it is left as it is.
    pcp::Mesh two = sphere;
    two.vertices.conservativeResize(2 * sphere.vertices.rows(), 3);
    two.vertices.bottomRows(sphere.vertices.rows()) = sphere.vertices.rowwise() + Eigen::RowVector3d(2, 0, 0);
    two.faces.conservativeResize(2 * sphere.faces.rows(), 3);
    two.faces.bottomRows(sphere.faces.rows()) = sphere.faces.array() + static_cast<int>(sphere.vertices.rows());
    CHECK(pcp::fair_unsupported(two, everywhere, {}, &st).vertices == two.vertices);
    CHECK(st.unanchored == sphere.vertices.rows());
    CHECK(st.free_vertices == 0);
    const CrumpledCap c = crumpled_cap(R, 0.21, 0.18, 0.02);
    const pcp::KdTree tree(c.points);
    pcp::FairOptions off;
    off.enabled = false;
    CHECK(pcp::fair_unsupported(c.mesh, tree, off).vertices == c.mesh.vertices);
    pcp::FairOptions bad;
    bad.support_k = 0;
    CHECK_THROWS_AS(pcp::fair_unsupported(c.mesh, tree, bad), pcp::Error);
    bad.support_k = std::numeric_limits<double>::quiet_NaN();
    CHECK_THROWS_AS(pcp::fair_unsupported(c.mesh, tree, bad), pcp::Error);
    pcp::Mesh broken = c.mesh;
    broken.faces(0, 1) = static_cast<int>(broken.vertices.rows());
    CHECK_THROWS_AS(pcp::fair_unsupported(broken, tree), pcp::Error);
    pcp::Mesh nan_vertex = c.mesh;
    nan_vertex.vertices(0, 2) = std::numeric_limits<double>::quiet_NaN();
    CHECK_THROWS_AS(pcp::fair_unsupported(nan_vertex, tree), pcp::Error);
}
