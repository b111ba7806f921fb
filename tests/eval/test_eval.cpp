// Tests for pcp/eval.hpp with known answers.
#include "pcp/core/error.hpp"
#include "pcp/eval/eval.hpp"
#include "test_meshes.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <vector>

TEST_CASE("eval: a hand-computed three-point case", "[eval]") {
    // pred = {(0,0,0), (1,0,0)} with normals +z; gt = {(0,0,0.5)} with normal +x.
    // pred->gt distances: 0.5 and sqrt(1.25); gt->pred: 0.5.
    // L1 = ((0.5 + 1.118034)/2 + 0.5)/2 = 0.6545085; L2 = ((0.25 + 1.25)/2 + 0.25)/2 = 0.5;
    // NC = 0 (perpendicular normals); Hausdorff = sqrt(1.25);
    // F(0.6): precision 1/2, recall 1 -> 2/3; F(0.4): 0.
    pcp::SurfaceSamples pred, gt;
    pred.points.resize(2, 3);
    pred.points << 0, 0, 0, 1, 0, 0;
    pred.normals.resize(2, 3);
    pred.normals << 0, 0, 1, 0, 0, 1;
    gt.points.resize(1, 3);
    gt.points << 0, 0, 0.5;
    gt.normals.resize(1, 3);
    gt.normals << 1, 0, 0;
    const pcp::Metrics m = pcp::compare_samples(pred, gt, {0.4, 0.6});
    CHECK(m.chamfer_l1 == Approx(0.6545085).epsilon(1e-6));
    CHECK(m.chamfer_l2 == Approx(0.5).epsilon(1e-6));
    CHECK(m.normal_consistency == Approx(0.0).margin(1e-12));
    CHECK(m.hausdorff == Approx(std::sqrt(1.25)).epsilon(1e-6));
    REQUIRE(m.fscores.size() == 2);
    CHECK(m.fscores[0].fscore == 0.0);
    CHECK(m.fscores[1].precision == 0.5);
    CHECK(m.fscores[1].recall == 1.0);
    CHECK(m.fscores[1].fscore == Approx(2.0 / 3.0));
}

TEST_CASE("eval: a mesh against itself gives the floor, normals agree", "[eval]") {
    const pcp::Mesh sphere = pcp::test::uv_sphere(1.0, 40, 80);
    pcp::EvalOptions opts;
    const pcp::EvalResult r = pcp::evaluate(sphere, sphere, opts);
    CHECK(r.frame_scale == Approx(0.5).epsilon(1e-3));
    // Both are the same measurement up to sampling noise.
    CHECK(r.metrics.chamfer_l1 == Approx(r.floor.chamfer_l1).epsilon(0.1));
    CHECK(r.metrics.chamfer_l2 == Approx(r.floor.chamfer_l2).epsilon(0.2));
    CHECK(r.metrics.normal_consistency > 0.99);
    CHECK(r.scene_error < 1e-12);  // its own vertices lie on it
    // 10,000 samples on a sphere of area pi (radius 0.5): mean spacing ~ 0.018, so the floor is small.
    CHECK(r.floor.chamfer_l1 < 0.01);
}

TEST_CASE("eval: concentric spheres give the analytic distances", "[eval]") {
    const pcp::Mesh inner = pcp::test::uv_sphere(0.5, 64, 128), outer = pcp::test::uv_sphere(0.6, 64, 128);
    pcp::EvalOptions opts;
    opts.protocol = pcp::EvalProtocol::Scene;  // no rescaling: distances in the meshes' units
    opts.samples = 20000;
    opts.with_floor = false;
    const pcp::EvalResult r = pcp::evaluate(outer, inner, opts);
    // Every point of one sphere is 0.1 from the other (plus tessellation and sampling error).
    CHECK(r.metrics.chamfer_l1 == Approx(0.1).margin(0.006));
    CHECK(r.metrics.chamfer_l2 == Approx(0.01).margin(0.0012));
    CHECK(r.metrics.hausdorff == Approx(0.1).margin(0.02));
    CHECK(r.scene_error == Approx(0.1).margin(0.001));
    CHECK(r.metrics.normal_consistency > 0.99);
    // Monotone F-score: precision and recall can only grow with the threshold.
    const pcp::Metrics m = pcp::compare_samples(pcp::sample_mesh_surface(outer, 5000, 1),
                                                pcp::sample_mesh_surface(inner, 5000, 2),
                                                {0.05, 0.09, 0.1, 0.11, 0.2});
    for (std::size_t i = 1; i < m.fscores.size(); ++i) CHECK(m.fscores[i].fscore >= m.fscores[i - 1].fscore);
    CHECK(m.fscores.front().fscore == 0.0);
    CHECK(m.fscores.back().fscore == 1.0);
}

TEST_CASE("eval: a translated square is at the translation distance", "[eval]") {
    pcp::Mesh a = pcp::test::unit_square(), b = pcp::test::unit_square();
    b.vertices.col(2).array() += 0.25;
    const Eigen::VectorXd d = pcp::point_to_mesh_distance(a, b.vertices);
    CHECK((d.array() - 0.25).abs().maxCoeff() < 1e-12);
    // A point beside the square: distance to its nearest edge.
    pcp::Points p(1, 3);
    p << 2.0, 0.5, 0.0;
    CHECK(pcp::point_to_mesh_distance(a, p)(0) == Approx(1.0));
}

TEST_CASE("eval: empty and broken inputs are refused", "[eval]") {
    const pcp::Mesh good = pcp::test::unit_square();
    pcp::Mesh empty;
    CHECK_THROWS_WITH(pcp::evaluate(empty, good), Catch::Contains("predicted mesh is empty"));
    CHECK_THROWS_WITH(pcp::evaluate(good, empty), Catch::Contains("ground-truth mesh is empty"));
    pcp::Mesh bad = good;
    bad.faces(0, 1) = 7;
    CHECK_THROWS_WITH(pcp::evaluate(bad, good), Catch::Contains("out of range"));
    pcp::Mesh flat = good;
    flat.vertices.col(1).setZero();  // zero area
    CHECK_THROWS_WITH(pcp::sample_mesh_surface(flat, 10, 1), Catch::Contains("zero area"));
    CHECK_THROWS_WITH(pcp::parse_eval_protocol("famous"), Catch::Contains("famous"));
}

TEST_CASE("eval: winding numbers are 1 inside and 0 outside a closed mesh", "[eval]") {
    const pcp::Mesh sphere = pcp::test::uv_sphere(1.0, 20, 40);
    pcp::Points p(4, 3);
    p << 0, 0, 0, 0.5, 0.3, -0.2, 1.5, 0, 0, 0, 3, 1;
    const Eigen::VectorXd w = pcp::winding_numbers(sphere, p);
    CHECK(w(0) == Approx(1.0).margin(1e-9));
    CHECK(w(1) == Approx(1.0).margin(1e-9));
    CHECK(w(2) == Approx(0.0).margin(1e-9));
    CHECK(w(3) == Approx(0.0).margin(1e-9));
    pcp::Mesh inward = sphere;  // flipped orientation: -1 inside
    inward.faces.col(1).swap(inward.faces.col(2));
    CHECK(pcp::winding_numbers(inward, p)(0) == Approx(-1.0).margin(1e-9));
}

TEST_CASE("eval: sign agreement against signed-distance samples, overall and by |sdf|", "[eval]") {
    const pcp::Mesh sphere = pcp::test::uv_sphere(1.0, 20, 40);
    // Samples on the x axis at radius r, with the sphere's true signed distance r - 1.
    const std::vector<double> radii = {0.2, 0.95, 0.99, 1.02, 1.2, 2.0};
    pcp::Points p(radii.size(), 3);
    Eigen::VectorXd sdf(radii.size());
    for (std::size_t i = 0; i < radii.size(); ++i) {
        p.row(i) << radii[i], 0, 0;
        sdf(i) = radii[i] - 1.0;
    }
    const pcp::SignAgreement all = pcp::sign_agreement(sphere, p, sdf, pcp::SdfConvention::NegativeInside, {0.03, 0.5});
    CHECK(all.samples == 6);
    CHECK(all.agree == 6);
    CHECK(all.fraction() == 1.0);
    REQUIRE(all.bins.size() == 3);  // [0, 0.03), [0.03, 0.5), [0.5, inf)
    CHECK(all.bins[0].samples == 2);  // 0.99 and 1.02
    CHECK(all.bins[1].samples == 2);  // 0.95 and 1.2
    CHECK(all.bins[2].samples == 2);  // 0.2 and 2.0
    CHECK(std::isinf(all.bins[2].upper));

    // The opposite convention disagrees everywhere; detection picks the right one.
    CHECK(pcp::sign_agreement(sphere, p, sdf, pcp::SdfConvention::PositiveInside).agree == 0);
    double best = 0;
    CHECK(pcp::detect_sdf_convention(sphere, p, sdf, &best) == pcp::SdfConvention::NegativeInside);
    CHECK(best == 1.0);
    CHECK(pcp::detect_sdf_convention(sphere, p, -sdf) == pcp::SdfConvention::PositiveInside);

    // A smaller sphere (radius 0.9) puts the samples at 0.95 and 0.99 outside: 4 of 6, and both
    // misses fall in the bins of the near samples.
    const pcp::SignAgreement smaller =
        pcp::sign_agreement(pcp::test::uv_sphere(0.9, 20, 40), p, sdf, pcp::SdfConvention::NegativeInside, {0.03, 0.5});
    CHECK(smaller.agree == 4);
    CHECK(smaller.bins[0].agree == 1);
    CHECK(smaller.bins[1].agree == 1);
    CHECK(smaller.bins[2].agree == 2);

    CHECK_THROWS_WITH(pcp::sign_agreement(sphere, p, sdf.head(3), pcp::SdfConvention::NegativeInside),
                      Catch::Contains("6 points but 3 sdf values"));
    CHECK_THROWS_WITH(pcp::sign_agreement(sphere, p, sdf, pcp::SdfConvention::NegativeInside, {0.5, 0.1}),
                      Catch::Contains("increasing"));
    Eigen::VectorXd bad = sdf;
    bad(2) = std::numeric_limits<double>::quiet_NaN();
    CHECK_THROWS_WITH(pcp::sign_agreement(sphere, p, bad, pcp::SdfConvention::NegativeInside), Catch::Contains("not all finite"));
}
