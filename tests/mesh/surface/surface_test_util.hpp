// Helpers of the surface passes' tests: meshes of analytic fields, points on a sphere.
#pragma once

#include "mc_test_util.hpp"
#include "pcp/cloud/shapes.hpp"
#include "pcp/core/rng.hpp"
#include "pcp/mesh/grid/marching_cubes.hpp"

#include <algorithm>
#include <cmath>

namespace pcp_test {

/// The mesh of `sdf` on a dense grid over [-0.6, 0.6]^3.
inline pcp::Mesh mesh_of(const ScalarSdf& sdf, int resolution) {
    pcp::SdfGridOptions opts;
    opts.band = pcp::NarrowBand::Dense;
    return pcp::marching_cubes(pcp::evaluate_sdf_grid(batch(sdf), cube_grid(resolution), opts));
}

inline pcp::PointsF sphere_points(Eigen::Index n, double radius, std::uint64_t seed) {
    return pcp::sample_sphere(n, radius, Eigen::Vector3d::Zero(), seed).points.cast<float>();
}

inline double mean_radial_error(const pcp::Mesh& mesh, double radius) {
    return (mesh.vertices.rowwise().norm().array() - radius).abs().mean();
}

/// Both broad faces of a plate of half-thickness h (half sizes 0.35, 0.35), points on a 0.01 grid
/// with normal noise of deviation sigma along z, and the mean |z| of a mesh's broad-face vertices.
inline pcp::PointsF noisy_plate_points(double h, double sigma, std::uint64_t seed) {
    pcp::Rng rng(seed);
    Eigen::Index n = 0;
    pcp::PointsF pts(2 * 71 * 71, 3);
    for (int side = 0; side < 2; ++side)
        for (int i = 0; i < 71; ++i)
            for (int j = 0; j < 71; ++j)
                pts.row(n++) << static_cast<float>(-0.35 + 0.01 * i), static_cast<float>(-0.35 + 0.01 * j),
                    static_cast<float>((side ? h : -h) + rng.normal(0.0, sigma));
    return pts;
}

inline double mean_broad_face_z(const pcp::Mesh& m) {
    double s = 0;
    int c = 0;
    for (Eigen::Index v = 0; v < m.vertices.rows(); ++v) {
        const Eigen::RowVector3d p = m.vertices.row(v);
        if (std::abs(p.x()) < 0.25 && std::abs(p.y()) < 0.25) {
            s += std::abs(p.z());
            ++c;
        }
    }
    return s / std::max(c, 1);
}

inline ScalarSdf plate_sdf(double h) {
    return [h](const Eigen::Vector3d& p) {
        const Eigen::Vector3d q = p.cwiseAbs() - Eigen::Vector3d(0.35, 0.35, h);
        return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
    };
}

}  // namespace pcp_test
