// Tests for pcp/mesh/surface/recentre.hpp: the recentring brings a surface lying inside noisy points
// (a sphere, both sides of a thin slab) onto their middle, leaves a sheet far from the points and a
// clean surface where they are; bad options throw.
#include "surface_test_util.hpp"
#include "pcp/core/error.hpp"
#include "pcp/core/rng.hpp"
#include "pcp/mesh/grid/mesh_check.hpp"
#include "pcp/mesh/surface/recentre.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <random>

using namespace pcp_test;

namespace {

/// `n` points on the sphere of radius `radius` about the origin, moved along the radius by Gaussian
/// noise of deviation `sigma`.
pcp::PointsF noisy_sphere_points(Eigen::Index n, double radius, double sigma, std::uint64_t seed) {
    pcp::Points p = pcp::sample_sphere(n, radius, Eigen::Vector3d::Zero(), seed).points;
    pcp::Rng rng(seed + 1);
    for (Eigen::Index i = 0; i < n; ++i) p.row(i) *= (radius + rng.normal(0.0, sigma)) / radius;
    return p.cast<float>();
}

double mean_radius(const pcp::Mesh& mesh) { return mesh.vertices.rowwise().norm().mean(); }

}  // namespace

TEST_CASE("recentre: a surface inside a noisy sphere's points comes onto their middle, topology unchanged", "[surface_fit]") {
    const double R = 0.3, sigma = 0.01;  // the noise about 1.5 point spacings
    const pcp::Mesh mesh = mesh_of(sphere_sdf({0, 0, 0}, R - 0.006), 64);
    const pcp::KdTree tree(noisy_sphere_points(16000, R, sigma, 7));
    pcp::RecentreStats st;
    const pcp::Mesh out = pcp::recentre_on_points(mesh, tree, {}, &st);
    INFO("mean radius before " << mean_radius(mesh) << ", after " << mean_radius(out) << "; spread " << st.spread
                               << ", rounds " << st.rounds);
    CHECK(std::abs(mean_radius(mesh) - R) > 0.0055);
    CHECK(std::abs(mean_radius(out) - R) < 0.0015);
    CHECK(st.mean_move > 0.004);                              // outward
    CHECK(st.spread == Approx(sigma).epsilon(0.25));          // the noise's deviation, measured
    CHECK(st.rounds > 1);
    const pcp::MeshTopology t0 = pcp::mesh_topology(mesh), t1 = pcp::mesh_topology(out);
    CHECK(t1.F == t0.F);
    CHECK(t1.euler() == t0.euler());
    CHECK(pcp::is_closed_and_oriented(out));
}

TEST_CASE("recentre: both sides of a thin slab under noise as wide as a quarter of it move out to their own sides",
          "[surface_fit][heavy]") {
    // A plate of half-thickness 0.03 with noise of deviation 0.015 along z (the two sides' points
    // overlap, as on the scanned plate abc_00010074), its mesh 0.008 too thin on each side.
    const double h = 0.03, sigma = 0.015, thin = 0.008;
    const pcp::Mesh mesh = mesh_of(plate_sdf(h - thin), 120);
    const pcp::Mesh out = pcp::recentre_on_points(mesh, pcp::KdTree(noisy_plate_points(h, sigma, 11)));
    // The broad faces, away from the rim: the mean |z| of their vertices.
    const auto mean_side = mean_broad_face_z;
    INFO("mean |z| of the broad faces before " << mean_side(mesh) << ", after " << mean_side(out) << " (the sides at " << h << ")");
    CHECK(std::abs(mean_side(mesh) - h) > 0.0075);
    CHECK(std::abs(mean_side(out) - h) < 0.002);
}

TEST_CASE("recentre: a sheet farther from the points than their noise is not moved", "[surface_fit]") {
    // 2.5 deviations inside the points: not a bias of the surface but a sheet away from the data
    // (an inner sheet, a membrane), which the recentring leaves to the repairs.
    const double R = 0.3, sigma = 0.01;
    const pcp::Mesh mesh = mesh_of(sphere_sdf({0, 0, 0}, R - 0.025), 64);
    pcp::RecentreStats st;
    const pcp::Mesh out = pcp::recentre_on_points(mesh, pcp::KdTree(noisy_sphere_points(16000, R, sigma, 9)), {}, &st);
    INFO("mean radius before " << mean_radius(mesh) << ", after " << mean_radius(out) << "; spread " << st.spread);
    CHECK(st.spread == Approx(sigma).epsilon(0.25));  // the noise, not the sheet's distance
    CHECK(std::abs(mean_radius(out) - mean_radius(mesh)) < 1e-4);
    // At under one deviation it is a bias and moves.
    const pcp::Mesh near = mesh_of(sphere_sdf({0, 0, 0}, R - 0.0075), 64);
    const pcp::Mesh moved = pcp::recentre_on_points(near, pcp::KdTree(noisy_sphere_points(16000, R, sigma, 9)));
    CHECK(mean_radius(moved) > mean_radius(near) + 0.003);
}

TEST_CASE("recentre: a surface on clean points stays where it is, and bad options throw", "[surface_fit]") {
    const double R = 0.3;
    const pcp::Mesh mesh = mesh_of(sphere_sdf({0, 0, 0}, R), 48);
    const pcp::KdTree tree(sphere_points(8000, R, 3));
    pcp::RecentreStats st;
    const pcp::Mesh out = pcp::recentre_on_points(mesh, tree, {}, &st);
    INFO("mean |r - R| before " << mean_radial_error(mesh, R) << ", after " << mean_radial_error(out, R));
    CHECK(mean_radial_error(out, R) < mean_radial_error(mesh, R) + 2e-4);
    CHECK(std::abs(st.mean_move) < 1e-3);
    CHECK(out.faces == mesh.faces);
    // Nothing to do on an empty mesh.
    CHECK(pcp::recentre_on_points(pcp::Mesh{}, tree).vertices.rows() == 0);
    // Each bad option alone throws.
    const auto throws_with = [&](void (*spoil)(pcp::RecentreOptions&)) {
        pcp::RecentreOptions bad;
        spoil(bad);
        CHECK_THROWS_AS(pcp::recentre_on_points(mesh, tree, bad), pcp::Error);
    };
    throws_with([](pcp::RecentreOptions& o) { o.window_k = 0; });
    throws_with([](pcp::RecentreOptions& o) { o.passes = 0; });
    throws_with([](pcp::RecentreOptions& o) { o.passes = 21; });
    throws_with([](pcp::RecentreOptions& o) { o.clip_k = std::numeric_limits<double>::quiet_NaN(); });
    throws_with([](pcp::RecentreOptions& o) { o.max_move_k = -1; });
    pcp::Mesh broken = mesh;
    broken.faces(0, 0) = static_cast<std::int32_t>(mesh.vertices.rows());
    CHECK_THROWS_AS(pcp::recentre_on_points(broken, tree), pcp::Error);
}
