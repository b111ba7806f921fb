// Tests for pcp/eval/diagnose.hpp on procedural meshes with known answers: a GT sphere / torus
// against itself, plus a floating sphere, a slightly larger sphere and a sphere with a cap cut off.
// The p2s frame scales the GT's bbox longest edge to 1, so a unit sphere has radius 0.5 there.
#include "pcp/cloud/shapes.hpp"
#include "pcp/core/error.hpp"
#include "pcp/eval/diagnose.hpp"
#include "pcp/eval/eval.hpp"
#include "test_meshes.hpp"

#include <Eigen/Geometry>
#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

namespace {

constexpr double kPi = 3.14159265358979323846;

/// A closed torus around the z axis (major radius R, minor r), nu x nv quads split in two, outward.
pcp::Mesh torus_mesh(double R, double r, int nu, int nv) {
    pcp::Mesh m;
    m.vertices.resize(nu * nv, 3);
    for (int i = 0; i < nu; ++i)
        for (int j = 0; j < nv; ++j) {
            const double u = 2 * kPi * i / nu, v = 2 * kPi * j / nv;
            m.vertices.row(i * nv + j) << (R + r * std::cos(v)) * std::cos(u), (R + r * std::cos(v)) * std::sin(u), r * std::sin(v);
        }
    m.faces.resize(2 * nu * nv, 3);
    auto id = [&](int i, int j) { return (i % nu) * nv + (j % nv); };
    for (int i = 0; i < nu; ++i)
        for (int j = 0; j < nv; ++j) {
            const int f = 2 * (i * nv + j);
            m.faces.row(f) << id(i, j), id(i + 1, j), id(i + 1, j + 1);
            m.faces.row(f + 1) << id(i, j), id(i + 1, j + 1), id(i, j + 1);
        }
    return m;
}

/// Every face with its own three vertices (duplicated positions, as some writers produce).
pcp::Mesh triangle_soup(const pcp::Mesh& mesh) {
    pcp::Mesh soup;
    soup.vertices.resize(3 * mesh.faces.rows(), 3);
    soup.faces.resize(mesh.faces.rows(), 3);
    for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f)
        for (int k = 0; k < 3; ++k) {
            soup.vertices.row(3 * f + k) = mesh.vertices.row(mesh.faces(f, k));
            soup.faces(f, k) = static_cast<std::int32_t>(3 * f + k);
        }
    return soup;
}

pcp::Mesh translated(pcp::Mesh m, const Eigen::RowVector3d& t) {
    m.vertices.rowwise() += t;
    return m;
}

double area(const pcp::Mesh& m) {
    double total = 0;
    for (Eigen::Index f = 0; f < m.faces.rows(); ++f) {
        const Eigen::Vector3d a = m.vertices.row(m.faces(f, 0)), b = m.vertices.row(m.faces(f, 1)), c = m.vertices.row(m.faces(f, 2));
        total += 0.5 * (b - a).cross(c - a).norm();
    }
    return total;
}

}  // namespace

TEST_CASE("diagnose: a sphere and a torus against themselves: one component, its genus, no offset, nothing missing", "[diagnose]") {
    const pcp::Mesh sphere = pcp::test::uv_sphere(1.0, 48, 96);
    const pcp::Mesh torus = torus_mesh(1.0, 0.35, 96, 48);
    for (const auto& [mesh, genus] : {std::pair<const pcp::Mesh*, int>{&sphere, 0}, {&torus, 1}}) {
        INFO("genus " << genus);
        const pcp::Points input = genus == 0 ? pcp::sample_sphere(20000, 1.0, Eigen::Vector3d::Zero(), 3).points
                                             : pcp::sample_torus(20000, 1.0, 0.35, 3).points;
        const Eigen::Ref<const pcp::Points> input_ref(input);
        const pcp::Diagnosis d = pcp::diagnose(*mesh, *mesh, &input_ref);
        REQUIRE(d.pred_components.size() == 1);
        REQUIRE(d.gt_components.size() == 1);
        CHECK(d.pred_components[0].closed);
        CHECK(d.pred_components[0].boundary_edges == 0);
        CHECK(d.pred_components[0].genus == genus);
        CHECK(d.gt_components[0].genus == genus);
        CHECK(d.pred_components[0].faces == mesh->faces.rows());
        CHECK(d.pred_area == Approx(area(*mesh) * d.frame_scale * d.frame_scale).epsilon(1e-9));
        CHECK_FALSE(d.pred_components[0].floating);
        CHECK(d.unsupported_area_fraction < 0.01);
        CHECK(d.floating_components == 0);
        CHECK(d.missing_area_fraction == 0.0);
        CHECK(d.offset_signed_by_closed_gt);
        CHECK(std::abs(d.offset) < 2e-4);
        CHECK(d.mean_abs_distance < 1e-6);  // the samples lie on the GT itself
        // The pieces add up to evaluate()'s L2-CD (same frame, samples and seeds).
        pcp::EvalOptions eo;
        eo.with_floor = false;
        const pcp::EvalResult r = pcp::evaluate(*mesh, *mesh, eo);
        CHECK(d.chamfer_l2 == Approx(r.metrics.chamfer_l2).epsilon(1e-6));
        CHECK(d.accuracy_away_l2 + d.accuracy_main_l2 + d.completeness_missing_l2 + d.completeness_rest_l2 ==
              Approx(r.metrics.chamfer_l2).epsilon(1e-6));
    }
    // Duplicated positions are welded: a triangle soup of the torus is still one genus-1 component.
    const std::vector<pcp::ComponentInfo> soup = pcp::mesh_components(triangle_soup(torus));
    REQUIRE(soup.size() == 1);
    CHECK(soup[0].genus == 1);
    CHECK(soup[0].vertices == torus.vertices.rows());
}

TEST_CASE("diagnose: a detached sphere with no input near it is one floating component, counted as away", "[diagnose]") {
    const pcp::Mesh sphere = pcp::test::uv_sphere(1.0, 48, 96);
    const pcp::Mesh blob = translated(pcp::test::uv_sphere(0.25, 16, 32), Eigen::RowVector3d(1.8, 0, 0));
    const pcp::Mesh pred = pcp::test::concat(sphere, blob);
    const pcp::Points input = pcp::sample_sphere(20000, 1.0, Eigen::Vector3d::Zero(), 3).points;
    const Eigen::Ref<const pcp::Points> input_ref(input);
    const pcp::Diagnosis d = pcp::diagnose(pred, sphere, &input_ref);
    REQUIRE(d.pred_components.size() == 2);
    CHECK(d.pred_components[0].faces == sphere.faces.rows());  // sorted by area
    CHECK_FALSE(d.pred_components[0].floating);
    CHECK(d.pred_components[1].floating);
    CHECK(d.pred_components[1].genus == 0);
    CHECK(d.pred_components[1].unsupported_fraction == 1.0);
    CHECK(d.floating_components == 1);
    const double blob_fraction = area(blob) / area(pred);
    CHECK(d.floating_area_fraction == Approx(blob_fraction).epsilon(1e-9));
    CHECK(d.unsupported_area_fraction == Approx(blob_fraction).margin(0.01));
    CHECK(d.away_sample_fraction == Approx(blob_fraction).margin(0.01));
    CHECK(d.accuracy_away_l2 > 0);
    CHECK(d.accuracy_away_l2 > 10 * d.accuracy_main_l2);  // the main sphere lies on the GT
    CHECK(std::abs(d.offset) < 2e-4);
    CHECK(d.missing_area_fraction == 0.0);
}

TEST_CASE("diagnose: a slightly larger sphere is offset outward by the radius difference, with little roughness", "[diagnose]") {
    const pcp::Mesh gt = pcp::test::uv_sphere(1.0, 48, 96);
    const double delta = 0.02;  // file units; 0.01 in the frame (GT bbox longest edge 2 -> 1)
    const pcp::Mesh pred = pcp::test::uv_sphere(1.0 + delta, 48, 96);
    const pcp::Diagnosis d = pcp::diagnose(pred, gt, nullptr);
    CHECK_FALSE(d.has_input);
    CHECK(d.offset == Approx(delta / 2).margin(5e-4));
    CHECK(d.roughness < 5e-4);
    CHECK(d.mean_abs_distance == Approx(delta / 2).margin(5e-4));
    CHECK(d.accuracy_away_l2 == 0.0);
    // The smaller sphere inside: the same offset, negative.
    const pcp::Diagnosis inner = pcp::diagnose(pcp::test::uv_sphere(1.0 - delta, 48, 96), gt, nullptr);
    CHECK(inner.offset == Approx(-delta / 2).margin(5e-4));
}

TEST_CASE("diagnose: a sphere with its cap cut off misses about the cap's area and has boundary edges", "[diagnose]") {
    const pcp::Mesh gt = pcp::test::uv_sphere(1.0, 48, 96);
    std::vector<Eigen::Index> kept;
    for (Eigen::Index f = 0; f < gt.faces.rows(); ++f) {
        const double z = (gt.vertices(gt.faces(f, 0), 2) + gt.vertices(gt.faces(f, 1), 2) + gt.vertices(gt.faces(f, 2), 2)) / 3;
        if (z < 0.6) kept.push_back(f);
    }
    pcp::Mesh pred{gt.vertices, gt.faces(kept, Eigen::all)};
    const double removed = 1.0 - area(pred) / area(gt);
    REQUIRE(removed > 0.15);
    pcp::DiagnoseOptions options;
    options.near_k = 1;  // a narrow band along the cut counts as near
    const pcp::Diagnosis d = pcp::diagnose(pred, gt, nullptr, options);
    REQUIRE(d.pred_components.size() == 1);
    CHECK(d.pred_components[0].boundary_edges > 0);
    CHECK_FALSE(d.pred_components[0].closed);
    CHECK(d.pred_components[0].genus == -1);
    CHECK(d.missing_area_fraction == Approx(removed).margin(0.02));
    CHECK(d.missing_area_fraction < removed);
    CHECK(d.completeness_missing_l2 > 0.9 * d.completeness_l2);
    CHECK(std::abs(d.offset) < 2e-4);
}

TEST_CASE("diagnose: bad arguments throw", "[diagnose]") {
    const pcp::Mesh sphere = pcp::test::uv_sphere(1.0, 8, 16);
    pcp::DiagnoseOptions options;
    options.support_k = 0;
    CHECK_THROWS_AS(pcp::diagnose(sphere, sphere, nullptr, options), pcp::Error);
    const pcp::Points one = pcp::Points::Zero(1, 3);
    const Eigen::Ref<const pcp::Points> one_ref(one);
    CHECK_THROWS_AS(pcp::diagnose(sphere, sphere, &one_ref), pcp::Error);
    CHECK_THROWS_AS(pcp::diagnose(pcp::Mesh{}, sphere, nullptr), pcp::Error);
}
