// Tests for pcp/mesh/surface/smooth.hpp: a noisy box gets flat faces and keeps its corners, zero iterations
// are the identity, bad options and bad faces throw.
#include "mc_test_util.hpp"
#include "pcp/core/error.hpp"
#include "pcp/core/rng.hpp"
#include "pcp/mesh/grid/marching_cubes.hpp"
#include "pcp/mesh/surface/smooth.hpp"

#include <catch2/catch.hpp>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>

using namespace pcp_test;

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
    // noise is several cells wide: docs/NOTEBOOK.md).
    pcp::BilateralOptions light;
    light.normal_iterations = light.vertex_iterations = 10;
    light.sigma_r = 0.35;
    const pcp::Mesh bilateral = pcp::bilateral_smooth(noisy, light);
    INFO("flatness noisy " << f0 << ", bilateral " << flatness(bilateral) << ", clean " << flatness(clean));
    CHECK(flatness(bilateral) > f0 + 0.5 * (1.0 - f0));  // more than half the way to flat
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
    pcp::Mesh face_out_of_range = noisy;
    face_out_of_range.faces(0, 1) = static_cast<std::int32_t>(noisy.vertices.rows());
    CHECK_THROWS_AS(pcp::bilateral_smooth(face_out_of_range, light), pcp::Error);
}
