// Oriented normals of points: from a field's votes, from a mesh, and their score against a GT mesh.
#include "mc_test_util.hpp"
#include "test_meshes.hpp"
#include "pcp/cloud/kdtree.hpp"
#include "pcp/cloud/shapes.hpp"
#include "pcp/core/error.hpp"
#include "pcp/eval/eval.hpp"
#include "pcp/mesh/sign/field_normals.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace pcp_test;

namespace {
constexpr double kRadius = 0.4;

/// Fraction of points whose normal points away from the origin (outward on a centred sphere).
double outward_fraction(const pcp::Points& points, const pcp::Points& normals) {
    Eigen::Index out = 0;
    for (Eigen::Index i = 0; i < points.rows(); ++i) out += points.row(i).dot(normals.row(i)) > 0;
    return static_cast<double>(out) / static_cast<double>(points.rows());
}

/// Mean angle (degrees) between the normals and the sphere's radial direction, orientation ignored.
double mean_direction_error_deg(const pcp::Points& points, const pcp::Points& normals) {
    double sum = 0;
    for (Eigen::Index i = 0; i < points.rows(); ++i)
        sum += std::acos(std::min(1.0, std::abs(points.row(i).normalized().dot(normals.row(i).normalized())))) * 180.0 / M_PI;
    return sum / static_cast<double>(points.rows());
}
}  // namespace

TEST_CASE("field normals: a sphere's field orients its PCA normals outward, its negative inward", "[mesh][normals]") {
    const pcp::PointCloud cloud = pcp::sample_sphere(3000, kRadius, Eigen::Vector3d::Zero(), 7);
    const pcp::KdTree tree(cloud.points.cast<float>());
    const ScalarSdf sphere = sphere_sdf(Eigen::Vector3d::Zero(), kRadius);
    const pcp::FieldNormals oriented = pcp::orient_normals_by_field(batch(sphere), tree);
    REQUIRE(oriented.normals.rows() == 3000);
    CHECK(oriented.stats.points == 3000);
    CHECK(oriented.stats.confident == 3000);  // an exact SDF votes 1 everywhere
    CHECK(oriented.stats.weak_orientation == 0);
    const pcp::Points normals = oriented.normals.cast<double>();
    CHECK(outward_fraction(cloud.points, normals) == 1.0);
    CHECK(mean_direction_error_deg(cloud.points, normals) < 3.0);

    const ScalarSdf negated = [&](const Eigen::Vector3d& p) { return -sphere(p); };
    const pcp::FieldNormals inward = pcp::orient_normals_by_field(batch(negated), tree);
    CHECK(outward_fraction(cloud.points, inward.normals.cast<double>()) == 0.0);

    // Points off the field's zero set have no vote; with no confident point at all each keeps the
    // sign of its own (zero) vote, and nothing is spread.
    const ScalarSdf shifted = [&](const Eigen::Vector3d& p) { return sphere(p) + 0.2; };
    const pcp::FieldNormals off = pcp::orient_normals_by_field(batch(shifted), tree);
    CHECK(off.stats.confident == 0);
    CHECK(off.votes.cwiseAbs().maxCoeff() == 0.0);
}

TEST_CASE("field normals: bad options and too few points are refused", "[mesh][normals]") {
    const pcp::PointCloud cloud = pcp::sample_sphere(10, kRadius, Eigen::Vector3d::Zero(), 7);
    const pcp::KdTree tree(cloud.points.cast<float>());
    const pcp::SdfBatchFn f = batch(sphere_sdf(Eigen::Vector3d::Zero(), kRadius));
    CHECK_THROWS_AS(pcp::orient_normals_by_field(f, tree), pcp::Error);  // 10 points, normal_k 16
    pcp::FieldNormalsOptions bad;
    bad.normal_k = 3;
    CHECK_NOTHROW(pcp::orient_normals_by_field(f, tree, bad));
    bad.probe = 0;
    CHECK_THROWS_WITH(pcp::orient_normals_by_field(f, tree, bad), Catch::Contains("probe"));
    bad = {};
    bad.normal_k = 65;
    CHECK_THROWS_WITH(pcp::orient_normals_by_field(f, tree, bad), Catch::Contains("normal_k"));
    const pcp::SdfBatchFn nan = [](const Eigen::Ref<const pcp::PointsF>&, Eigen::Ref<Eigen::VectorXf> v) {
        v.setConstant(std::nanf(""));
    };
    bad = {};
    bad.normal_k = 3;
    CHECK_THROWS_WITH(pcp::orient_normals_by_field(nan, tree, bad), Catch::Contains("not finite"));
    CHECK_THROWS_AS(pcp::parse_normal_source("gradient"), pcp::Error);
    for (const pcp::NormalSource s : {pcp::NormalSource::Mesh, pcp::NormalSource::PcaByMesh, pcp::NormalSource::Field})
        CHECK(pcp::parse_normal_source(pcp::to_string(s)) == s);
}

TEST_CASE("mesh normals: a closed sphere mesh gives the radial direction, outward, at points off it", "[mesh][normals]") {
    const pcp::Mesh sphere = pcp::test::uv_sphere(kRadius, 24, 48);
    pcp::PointCloud cloud = pcp::sample_sphere(2000, kRadius, Eigen::Vector3d::Zero(), 3);
    // Points a little inside and outside the surface still read the nearest point's normal.
    for (Eigen::Index i = 0; i < cloud.points.rows(); ++i) cloud.points.row(i) *= (i % 2 ? 1.02 : 0.98);
    const pcp::Points normals = pcp::mesh_normals_at(sphere, cloud.points);
    REQUIRE(normals.rows() == 2000);
    CHECK(outward_fraction(cloud.points, normals) == 1.0);
    CHECK(mean_direction_error_deg(cloud.points, normals) < 1.0);  // interpolated vertex normals, not facets
    for (Eigen::Index i = 0; i < normals.rows(); ++i) CHECK(std::abs(normals.row(i).norm() - 1.0) < 1e-9);
    CHECK_THROWS_AS(pcp::mesh_normals_at(pcp::Mesh{}, cloud.points), pcp::Error);
    // PCA normals: the direction, unoriented.
    const pcp::PointsF pca = pcp::pca_normals(pcp::KdTree(pcp::sample_sphere(2000, kRadius, Eigen::Vector3d::Zero(), 3).points.cast<float>()), 16);
    CHECK(pca.rows() == 2000);
    CHECK_THROWS_AS(pcp::pca_normals(pcp::KdTree(cloud.points.topRows(10).cast<float>()), 16), pcp::Error);
}

TEST_CASE("eval: normal orientation against a GT mesh counts the correct side and the angles", "[eval][normals]") {
    const pcp::Mesh sphere = pcp::test::uv_sphere(kRadius, 24, 48);
    const pcp::PointCloud cloud = pcp::sample_sphere(1000, kRadius, Eigen::Vector3d::Zero(), 5);
    pcp::Points radial = cloud.points.rowwise().normalized();
    pcp::NormalOrientation r = pcp::normal_orientation(cloud.points, radial, sphere);
    CHECK(r.points == 1000);
    CHECK(r.correct_side == 1.0);
    CHECK(r.mean_angle_deg < 5.0);  // facets of a 24 x 48 sphere
    CHECK(r.mean_unoriented_deg == Approx(r.mean_angle_deg));
    // Half of them turned: half on the correct side, the direction as good as before.
    for (Eigen::Index i = 0; i < radial.rows(); i += 2) radial.row(i) = -radial.row(i);
    r = pcp::normal_orientation(cloud.points, 3.0 * radial, sphere);  // lengths do not matter
    CHECK(r.correct_side == Approx(0.5));
    CHECK(r.mean_angle_deg > 85.0);
    CHECK(r.mean_unoriented_deg < 5.0);
    CHECK_THROWS_WITH(pcp::normal_orientation(cloud.points, radial.topRows(10), sphere), Catch::Contains("normals"));
    radial.row(3).setZero();
    CHECK_THROWS_WITH(pcp::normal_orientation(cloud.points, radial, sphere), Catch::Contains("zero"));
    radial.row(3) << std::nan(""), 0, 0;
    CHECK_THROWS_WITH(pcp::normal_orientation(cloud.points, radial, sphere), Catch::Contains("finite"));
}

TEST_CASE("field normals: the confident fraction estimated on a sample matches the whole count", "[mesh][normals]") {
    const pcp::PointCloud cloud = pcp::sample_sphere(6000, kRadius, Eigen::Vector3d::Zero(), 11);
    const pcp::KdTree tree(cloud.points.cast<float>());
    const ScalarSdf sphere = sphere_sdf(Eigen::Vector3d::Zero(), kRadius);
    // Signed above z = 0.2 R, unsigned below (|F|: the probes on either side agree, the vote is 0):
    // 40 % of an even sampling of the sphere votes confidently.
    const ScalarSdf half = [&](const Eigen::Vector3d& p) { return p.z() >= 0.2 * kRadius ? sphere(p) : std::abs(sphere(p)); };
    const pcp::FieldNormals all = pcp::orient_normals_by_field(batch(half), tree);
    const double exact = static_cast<double>(all.stats.confident) / 6000.0;
    CHECK(exact == Approx(0.4).margin(0.03));
    // Every point: the same votes, the same count.
    CHECK(pcp::confident_vote_fraction(batch(half), tree, {}, 6000) == exact);
    CHECK(pcp::confident_vote_fraction(batch(half), tree, {}, 100000) == exact);
    // A uniform sample of 1000: within a few standard errors (0.016) of the count.
    CHECK(pcp::confident_vote_fraction(batch(half), tree, {}, 1000) == Approx(exact).margin(0.05));
    CHECK(pcp::confident_vote_fraction(batch(sphere), tree, {}, 500) == 1.0);
    const ScalarSdf unsigned_field = [&](const Eigen::Vector3d& p) { return std::abs(sphere(p)); };
    CHECK(pcp::confident_vote_fraction(batch(unsigned_field), tree, {}, 500) == 0.0);
    CHECK_THROWS_AS(pcp::confident_vote_fraction(batch(sphere), tree, {}, 0), pcp::Error);
}
