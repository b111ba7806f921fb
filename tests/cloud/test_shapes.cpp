// Tests for pcp/shapes.hpp: the sampled points lie on the analytic surfaces.
#include "pcp/cloud/shapes.hpp"

#include <catch2/catch.hpp>

TEST_CASE("shapes: default shape samples lie on its surface and cover every part", "[shapes]") {
    const pcp::PointCloud cloud = pcp::sample_default_shape(20000, 0.0, 1);
    REQUIRE(cloud.points.rows() == 20000);
    int on_hole = 0, on_fin = 0;
    for (Eigen::Index i = 0; i < cloud.points.rows(); ++i) {
        const Eigen::Vector3d p = cloud.points.row(i).transpose();
        REQUIRE(std::abs(pcp::default_shape_sdf(p)) < 1e-9);
        // A step along the outward normal leaves the solid, a step against it enters it.
        const Eigen::Vector3d n(cloud.properties.at("nx")(i), cloud.properties.at("ny")(i), cloud.properties.at("nz")(i));
        REQUIRE(pcp::default_shape_sdf(p + 1e-3 * n) > 0.0);
        REQUIRE(pcp::default_shape_sdf(p - 1e-3 * n) < 0.0);
        if (std::hypot(p.x() + 0.2, p.y()) < 0.1501) ++on_hole;
        if (p.z() > 0.2 + 1e-9) ++on_fin;
    }
    CHECK(on_hole > 1000);
    CHECK(on_fin > 1000);
}

TEST_CASE("shapes: sphere and torus samples lie on their surfaces, noise has the asked spread", "[shapes]") {
    const pcp::PointCloud s = pcp::sample_sphere(1000, 0.3, Eigen::Vector3d(1, 2, 3), 2);
    for (Eigen::Index i = 0; i < s.points.rows(); ++i)
        REQUIRE((s.points.row(i) - Eigen::RowVector3d(1, 2, 3)).norm() == Approx(0.3).epsilon(1e-12));
    const pcp::PointCloud t = pcp::sample_torus(1000, 0.3, 0.1, 3);
    for (Eigen::Index i = 0; i < t.points.rows(); ++i) {
        const Eigen::RowVector3d p = t.points.row(i);
        REQUIRE(std::hypot(std::hypot(p.x(), p.y()) - 0.3, p.z()) == Approx(0.1).epsilon(1e-9));
    }
    const pcp::PointCloud clean = pcp::sample_default_shape(5000, 0.0, 9);
    const pcp::PointCloud noisy = pcp::sample_default_shape(5000, 0.01, 9);
    const double rms = std::sqrt((noisy.points - clean.points).squaredNorm() / (3.0 * 5000));
    CHECK(rms == Approx(0.01).epsilon(0.05));
}
