// Helpers shared by tests/mesh/ (marching cubes, SDF grid, sign repair): analytic signed
// distance functions (sphere, torus, a rotated box with sharp edges) wrapped as SdfBatchFn, and
// mesh checks (edge manifoldness, orientation consistency, Euler characteristic, signed volume).
#pragma once

#include "pcp/mesh/grid/mesh_check.hpp"

#include "pcp/mesh/grid/sdf_grid.hpp"
#include "pcp/core/types.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
#include <utility>
#include <vector>

namespace pcp_test {

using ScalarSdf = std::function<double(const Eigen::Vector3d&)>;

inline ScalarSdf sphere_sdf(Eigen::Vector3d centre, double radius) {
    return [=](const Eigen::Vector3d& p) { return (p - centre).norm() - radius; };
}

/// Torus around the z axis (after a small rotation so that it is not grid-aligned).
inline ScalarSdf torus_sdf(Eigen::Vector3d centre, double R, double r) {
    const Eigen::Matrix3d rot = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 0.5).normalized()).toRotationMatrix();
    return [=](const Eigen::Vector3d& p) {
        const Eigen::Vector3d q = rot.transpose() * (p - centre);
        const double ring = std::hypot(q.x(), q.y()) - R;
        return std::hypot(ring, q.z()) - r;
    };
}

/// A box with half sizes h, rotated: sharp edges and corners that cut the grid obliquely.
inline ScalarSdf box_sdf(Eigen::Vector3d centre, Eigen::Vector3d h) {
    const Eigen::Matrix3d rot = Eigen::AngleAxisd(0.4, Eigen::Vector3d(0.3, 1, 0.7).normalized()).toRotationMatrix();
    return [=](const Eigen::Vector3d& p) {
        const Eigen::Vector3d q = (rot.transpose() * (p - centre)).cwiseAbs() - h;
        return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
    };
}

inline pcp::SdfBatchFn batch(ScalarSdf f) {
    return [f](const Eigen::Ref<const pcp::PointsF>& points, Eigen::Ref<Eigen::VectorXf> values) {
        for (Eigen::Index i = 0; i < points.rows(); ++i)
            values[i] = float(f(points.row(i).transpose().cast<double>()));
    };
}

inline pcp::GridSpec cube_grid(int resolution, double half = 0.6) {
    pcp::GridSpec spec;
    spec.resolution = resolution;
    spec.box.min = Eigen::Vector3d::Constant(-half);
    spec.box.max = Eigen::Vector3d::Constant(half);
    return spec;
}

/// `f` on every sample of cube_grid(resolution) (the dense grid of the cavity and tunnel fills).
inline pcp::SdfGrid dense_grid(const ScalarSdf& f, int resolution) {
    pcp::SdfGridOptions o;
    o.band = pcp::NarrowBand::Dense;
    return pcp::evaluate_sdf_grid(batch(f), cube_grid(resolution), o);
}

// The topology counts are the library's own (pcp/mesh/grid/mesh_check.hpp).
using pcp::MeshTopology;
inline MeshTopology topology(const pcp::Mesh& mesh) { return pcp::mesh_topology(mesh); }

/// Volume enclosed by a closed mesh, positive when its faces are counter-clockwise seen from outside.
inline double signed_volume(const pcp::Mesh& mesh) {
    double v = 0.0;
    for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
        const Eigen::Vector3d a = mesh.vertices.row(mesh.faces(f, 0)).transpose();
        const Eigen::Vector3d b = mesh.vertices.row(mesh.faces(f, 1)).transpose();
        const Eigen::Vector3d c = mesh.vertices.row(mesh.faces(f, 2)).transpose();
        v += a.dot(b.cross(c)) / 6.0;
    }
    return v;
}

/// Faces as sorted rows, each rotated so that its smallest index comes first (orientation kept).
inline std::vector<std::array<int, 3>> canonical_faces(const pcp::Faces& faces) {
    std::vector<std::array<int, 3>> out;
    for (Eigen::Index f = 0; f < faces.rows(); ++f) {
        std::array<int, 3> t{faces(f, 0), faces(f, 1), faces(f, 2)};
        while (t[0] != std::min({t[0], t[1], t[2]})) std::rotate(t.begin(), t.begin() + 1, t.end());
        out.push_back(t);
    }
    std::sort(out.begin(), out.end());
    return out;
}

}  // namespace pcp_test
