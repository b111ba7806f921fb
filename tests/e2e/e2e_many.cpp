// Several clouds in one fit (issue 17, paper "Optimization": one-hot codes): reconstruct_many fits
// one query network for a sphere and the default shape (block, hole, fin) in different frames and
// sizes, and each mesh comes out close to its own shape, in its own input frame, with the
// single-cloud e2e test's bound for the default shape.
#include "pcp/cloud/shapes.hpp"
#include "pcp/core/error.hpp"
#include "pcp/eval/eval.hpp"
#include "pcp/reconstruct.hpp"
#include "default_shape_truth.hpp"
#include "reduced_preset.hpp"

#include <catch2/catch.hpp>

#include <cmath>

TEST_CASE("reconstruct_many: one query network for two clouds, each mesh on its own shape in its own frame", "[e2e][many]") {
    const Eigen::Vector3d centre(5.0, -2.0, 1.0);
    const double radius = 2.0;
    const std::vector<pcp::Points> clouds = {pcp::sample_sphere(4000, radius, centre, 21).points,
                                             pcp::sample_default_shape(10000, 0.002, 1).points};
    pcp::ReconstructOptions o = pcp::test::reduced_preset();
    o.fit.steps = 1600;  // shared by the two clouds: the single-cloud test's 800 each
    std::vector<pcp::ReconstructReport> reports;
    const std::vector<pcp::Mesh> meshes = pcp::reconstruct_many(clouds, nullptr, o, &reports);
    REQUIRE(meshes.size() == 2);
    REQUIRE(reports.size() == 2);
    CHECK(reports[0].fit_steps == 1600);
    CHECK(reports[1].fit_steps == 1600);
    CHECK(reports[0].input_points == 4000);

    REQUIRE(meshes[0].vertices.rows() > 0);
    double sphere_err = 0;
    for (Eigen::Index i = 0; i < meshes[0].vertices.rows(); ++i)
        sphere_err += std::abs((meshes[0].vertices.row(i).transpose() - centre).norm() - radius);
    sphere_err /= static_cast<double>(meshes[0].vertices.rows());
    INFO("sphere: mean vertex distance " << sphere_err << " (radius " << radius << ")");
    CHECK(sphere_err < 0.01 * 2 * radius);  // within 1 % of the sphere's size, in its frame
    CHECK(reports[0].closed);
    // The default shape: Chamfer-L1 against its noise-free surface, the single-cloud e2e test's bound.
    REQUIRE(meshes[1].faces.rows() > 0);
    const pcp::SurfaceSamples gt = pcp::test::default_shape_truth();
    pcp::EvalOptions eo;
    eo.protocol = pcp::EvalProtocol::Scene;  // no rescaling
    eo.samples = 20000;
    const pcp::EvalResult r = pcp::evaluate(meshes[1], gt, eo);
    WARN("several clouds: sphere mean vertex distance " << sphere_err << "; default shape Chamfer-L1 " << r.metrics.chamfer_l1
                                                        << ", NC " << r.metrics.normal_consistency);
    CHECK(r.metrics.chamfer_l1 < 0.02);

    // Bad input names its cloud; the method only.
    std::vector<pcp::Points> bad = clouds;
    bad[1] = bad[1].topRows(5);
    CHECK_THROWS_WITH(pcp::reconstruct_many(bad, nullptr, o), Catch::Contains("cloud 2"));
    pcp::ReconstructOptions ablated = o;
    ablated.fit.ablation = pcp::QueryAblation::NoShift;
    CHECK_THROWS_AS(pcp::reconstruct_many(clouds, nullptr, ablated), pcp::Error);
    CHECK_THROWS_AS(pcp::reconstruct_many({}, nullptr, o), pcp::Error);
}
