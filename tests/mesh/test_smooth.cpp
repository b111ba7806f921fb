// Tests for pcp/mesh/smooth.hpp: a bumpy sphere gets rounder without shrinking, zero iterations is
// the identity, topology is kept, bad options and bad faces throw.
#include "mc_test_util.hpp"
#include "pcp/core/error.hpp"
#include "pcp/core/rng.hpp"
#include "pcp/mesh/marching_cubes.hpp"
#include "pcp/mesh/smooth.hpp"

#include <catch2/catch.hpp>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>

using namespace pcp_test;

namespace {

/// Mean and standard deviation of the vertices' distance to the origin.
std::pair<double, double> radius_stats(const pcp::Mesh& m) {
    const Eigen::VectorXd r = m.vertices.rowwise().norm();
    const double mean = r.mean();
    return {mean, std::sqrt((r.array() - mean).square().mean())};
}

}  // namespace

TEST_CASE("smoothing: a bumpy sphere gets rounder and keeps its size", "[smooth]") {
    const pcp::Mesh sphere = pcp::marching_cubes(pcp::evaluate_sdf_grid(batch(sphere_sdf(Eigen::Vector3d::Zero(), 0.4)), cube_grid(64)));
    pcp::Mesh bumpy = sphere;
    pcp::Rng rng(7, 1);
    for (Eigen::Index v = 0; v < bumpy.vertices.rows(); ++v)
        bumpy.vertices.row(v) *= 1.0 + 0.02 * rng.normal();
    const auto [r0, sd0] = radius_stats(bumpy);
    const pcp::Mesh smooth = pcp::taubin_smooth(bumpy, 20);
    const auto [r1, sd1] = radius_stats(smooth);
    CHECK(sd1 < 0.4 * sd0);
    CHECK(std::abs(r1 - 0.4) < 0.004);  // Taubin's pairs do not shrink it (1 %)
    CHECK(smooth.faces == bumpy.faces);
    CHECK(topology(smooth).euler() == topology(bumpy).euler());
    CHECK(pcp::taubin_smooth(bumpy, 0).vertices == bumpy.vertices);
}

TEST_CASE("smoothing: bad options and faces throw", "[smooth]") {
    pcp::Mesh m;
    m.vertices = pcp::Points::Zero(3, 3);
    m.faces.resize(1, 3);
    m.faces << 0, 1, 2;
    CHECK_THROWS_AS(pcp::taubin_smooth(m, -1), pcp::Error);
    CHECK_THROWS_AS(pcp::taubin_smooth(m, 1, 0.0), pcp::Error);
    CHECK_THROWS_AS(pcp::taubin_smooth(m, 1, 0.5, 0.4), pcp::Error);
    CHECK_THROWS_AS(pcp::taubin_smooth(m, 1, 0.5, 1.0), pcp::Error);
    m.faces << 0, 1, 3;
    CHECK_THROWS_AS(pcp::taubin_smooth(m, 1), pcp::Error);
}

TEST_CASE("bilateral smoothing: a noisy box gets flat faces and keeps its edges", "[smooth]") {
    // An axis-aligned box (half size 0.3) meshed by marching cubes, its vertices displaced along
    // random directions: the faces' normals scatter around the six axes.
    const ScalarSdf box = [](const Eigen::Vector3d& p) {
        const Eigen::Vector3d q = p.cwiseAbs() - Eigen::Vector3d::Constant(0.3);
        return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
    };
    const pcp::Mesh clean = pcp::marching_cubes(pcp::evaluate_sdf_grid(batch(box), cube_grid(48)));
    pcp::Mesh noisy = clean;
    pcp::Rng rng(3, 1);
    for (Eigen::Index v = 0; v < noisy.vertices.rows(); ++v)
        for (int c = 0; c < 3; ++c) noisy.vertices(v, c) += 0.004 * rng.normal();
    // Area-weighted mean of |n . axis| over faces: 1 for a box's faces exactly on its planes.
    auto flatness = [](const pcp::Mesh& m) {
        double sum = 0, area = 0;
        for (Eigen::Index f = 0; f < m.faces.rows(); ++f) {
            const Eigen::Vector3d a = m.vertices.row(m.faces(f, 0)), b = m.vertices.row(m.faces(f, 1)), c = m.vertices.row(m.faces(f, 2));
            const Eigen::Vector3d n = (b - a).cross(c - a);
            const double A = 0.5 * n.norm();
            if (A <= 0) continue;
            sum += A * n.normalized().cwiseAbs().maxCoeff();
            area += A;
        }
        return sum / area;
    };
    // Largest |coordinate| over the vertices: the corners' reach (0.3 for the exact box).
    auto reach = [](const pcp::Mesh& m) { return m.vertices.cwiseAbs().rowwise().maxCoeff().maxCoeff(); };
    const double f0 = flatness(noisy);
    // Light settings for this light noise (the defaults are chosen on the noisy ABC scans, whose
    // noise is several cells wide: docs/BENCHMARKS.md).
    pcp::BilateralOptions light;
    light.normal_iterations = light.vertex_iterations = 10;
    light.sigma_r = 0.35;
    const pcp::Mesh bilateral = pcp::bilateral_smooth(noisy, light);
    const pcp::Mesh taubin = pcp::taubin_smooth(noisy, 30);
    INFO("flatness noisy " << f0 << ", bilateral " << flatness(bilateral) << ", taubin " << flatness(taubin) << ", clean " << flatness(clean));
    CHECK(flatness(bilateral) > f0 + 0.5 * (1.0 - f0));  // more than half the way to flat
    CHECK(flatness(bilateral) > flatness(taubin));        // edges kept: Taubin rounds them
    CHECK(std::abs(reach(bilateral) - 0.3) < 0.01);
    CHECK(bilateral.faces == noisy.faces);
    pcp::BilateralOptions none;
    none.normal_iterations = none.vertex_iterations = 0;
    CHECK(pcp::bilateral_smooth(noisy, none).vertices == noisy.vertices);
    pcp::BilateralOptions bad;
    bad.sigma_r = 0;
    CHECK_THROWS_AS(pcp::bilateral_smooth(noisy, bad), pcp::Error);
    bad = {};
    bad.normal_iterations = -1;
    CHECK_THROWS_AS(pcp::bilateral_smooth(noisy, bad), pcp::Error);
}
