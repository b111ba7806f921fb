// Area-uniform sampling of procedural shapes. The default shape is a CSG solid
// S = (Block \ Cylinder) U Fin; its surface is sampled by drawing candidates on every primitive's
// boundary in proportion to area and keeping those that lie on the boundary of S.
#include "pcp/cloud/shapes.hpp"

#include "pcp/core/error.hpp"
#include "pcp/core/rng.hpp"

#include <array>
#include <cmath>
#include <vector>

namespace pcp {

namespace {

constexpr double kPi = 3.14159265358979323846;

struct Box {
    Eigen::Vector3d lo, hi;
    bool inside(const Eigen::Vector3d& p, double eps) const {
        return (p.array() > lo.array() + eps).all() && (p.array() < hi.array() - eps).all();
    }
    double sdf(const Eigen::Vector3d& p) const {
        const Eigen::Vector3d c = 0.5 * (lo + hi), h = 0.5 * (hi - lo);
        const Eigen::Vector3d q = (p - c).cwiseAbs() - h;
        return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
    }
    double area() const {
        const Eigen::Vector3d e = hi - lo;
        return 2.0 * (e.x() * e.y() + e.y() * e.z() + e.z() * e.x());
    }
    /// A uniform point on the box surface and its outward normal.
    void sample(Rng& rng, Eigen::Vector3d& p, Eigen::Vector3d& n) const {
        const Eigen::Vector3d e = hi - lo;
        const std::array<double, 3> face_area = {e.y() * e.z(), e.z() * e.x(), e.x() * e.y()};
        double u = rng.uniform() * (face_area[0] + face_area[1] + face_area[2]);
        int axis = 0;
        while (axis < 2 && u >= face_area[static_cast<std::size_t>(axis)]) u -= face_area[static_cast<std::size_t>(axis++)];
        const bool high = rng.uniform() < 0.5;
        for (int c = 0; c < 3; ++c) p(c) = lo(c) + rng.uniform() * e(c);
        p(axis) = high ? hi(axis) : lo(axis);
        n.setZero();
        n(axis) = high ? 1.0 : -1.0;
    }
};

/// Infinite cylinder along z through (cx, cy).
struct Cylinder {
    double cx, cy, radius;
    double sdf(const Eigen::Vector3d& p) const { return std::hypot(p.x() - cx, p.y() - cy) - radius; }
};

// The default shape's primitives (units: about 1 across).
const Box kBlock{{-0.5, -0.3, -0.2}, {0.5, 0.3, 0.2}};
const Cylinder kHole{-0.2, 0.0, 0.15};
const Box kFin{{0.05, -0.015, 0.1}, {0.40, 0.015, 0.55}};

void add_noise(PointCloud& cloud, double noise, Rng& rng) {
    if (noise <= 0.0) return;
    for (Eigen::Index i = 0; i < cloud.points.rows(); ++i)
        for (int c = 0; c < 3; ++c) cloud.points(i, c) += noise * rng.normal();
}

PointCloud make_cloud(Eigen::Index n) {
    PointCloud cloud;
    cloud.points.resize(n, 3);
    for (const char* name : {"nx", "ny", "nz"}) cloud.properties[name].resize(n);
    return cloud;
}

void store(PointCloud& cloud, Eigen::Index i, const Eigen::Vector3d& p, const Eigen::Vector3d& n) {
    cloud.points.row(i) = p.transpose();
    cloud.properties["nx"](i) = n.x();
    cloud.properties["ny"](i) = n.y();
    cloud.properties["nz"](i) = n.z();
}

}  // namespace

double default_shape_sdf(const Eigen::Vector3d& p) {
    const double block_minus_hole = std::max(kBlock.sdf(p), -kHole.sdf(p));
    return std::min(block_minus_hole, kFin.sdf(p));
}

PointCloud sample_default_shape(Eigen::Index n, double noise, std::uint64_t seed) {
    PCP_CHECK(n >= 1, "default shape: n must be >= 1");
    PCP_CHECK(noise >= 0.0, "default shape: noise must be >= 0");
    Rng rng(seed, 0);
    const double hole_height = kBlock.hi.z() - kBlock.lo.z();
    const double hole_area = 2.0 * kPi * kHole.radius * hole_height;
    const double areas[3] = {kBlock.area(), hole_area, kFin.area()};
    const double total = areas[0] + areas[1] + areas[2];
    const double eps = 1e-12;
    PointCloud cloud = make_cloud(n);
    Eigen::Index count = 0;
    while (count < n) {
        Eigen::Vector3d p, normal;
        const double u = rng.uniform() * total;
        bool keep = false;
        if (u < areas[0]) {  // block surface: outside the hole and not covered by the fin
            kBlock.sample(rng, p, normal);
            keep = kHole.sdf(p) > eps && !kFin.inside(p, -eps);
        } else if (u < areas[0] + areas[1]) {  // hole wall: normal points into the hole
            const double t = rng.uniform() * 2.0 * kPi;
            p = Eigen::Vector3d(kHole.cx + kHole.radius * std::cos(t), kHole.cy + kHole.radius * std::sin(t),
                                kBlock.lo.z() + rng.uniform() * hole_height);
            normal = Eigen::Vector3d(-std::cos(t), -std::sin(t), 0.0);
            keep = true;
        } else {  // fin surface outside the block
            kFin.sample(rng, p, normal);
            keep = kBlock.sdf(p) > eps;
        }
        if (keep) store(cloud, count++, p, normal);
    }
    add_noise(cloud, noise, rng);
    return cloud;
}

PointCloud sample_sphere(Eigen::Index n, double radius, const Eigen::Vector3d& center, std::uint64_t seed) {
    PCP_CHECK(n >= 1 && radius > 0.0, "sphere: need n >= 1 and radius > 0");
    Rng rng(seed, 1);
    PointCloud cloud = make_cloud(n);
    for (Eigen::Index i = 0; i < n; ++i) {
        Eigen::Vector3d d(rng.normal(), rng.normal(), rng.normal());
        while (d.norm() < 1e-12) d = Eigen::Vector3d(rng.normal(), rng.normal(), rng.normal());
        d.normalize();
        store(cloud, i, center + radius * d, d);
    }
    return cloud;
}

PointCloud sample_torus(Eigen::Index n, double major_radius, double minor_radius, std::uint64_t seed) {
    PCP_CHECK(n >= 1 && minor_radius > 0.0 && major_radius > minor_radius,
              "torus: need n >= 1 and major radius > minor radius > 0");
    Rng rng(seed, 2);
    PointCloud cloud = make_cloud(n);
    Eigen::Index i = 0;
    while (i < n) {
        const double theta = rng.uniform() * 2.0 * kPi, phi = rng.uniform() * 2.0 * kPi;
        // The area element is proportional to (R + r cos phi): accept with that probability.
        if (rng.uniform() * (major_radius + minor_radius) > major_radius + minor_radius * std::cos(phi)) continue;
        const Eigen::Vector3d normal(std::cos(phi) * std::cos(theta), std::cos(phi) * std::sin(theta), std::sin(phi));
        const Eigen::Vector3d ring(major_radius * std::cos(theta), major_radius * std::sin(theta), 0.0);
        store(cloud, i++, ring + minor_radius * normal, normal);
    }
    return cloud;
}

}  // namespace pcp
