// Real data (label realdata): reconstruct an ABC scan with the reduced preset, check L2-CD x 100
// (Points2Surf protocol, against its gt.ply) and the sign of the result against the ground-truth
// signed-distance samples.
#include "pcp/eval.hpp"
#include "pcp/io.hpp"
#include "pcp/reconstruct.hpp"
#include "reduced_preset.hpp"

#include <catch2/catch.hpp>

TEST_CASE("realdata: abc_00010039 reconstructs close to its ground truth with the right sign", "[realdata][reconstruct]") {
    const std::string dir = std::string(PCP_DATA_DIR) + "/abc/abc_00010039/";
    const pcp::PointCloud cloud = pcp::read_point_cloud(dir + "input.ply");
    REQUIRE(cloud.points.rows() == 6936);
    pcp::ReconstructReport report;
    const pcp::Mesh mesh = pcp::reconstruct(cloud.points, nullptr, pcp::test::reduced_preset(), &report);
    CHECK(report.closed);
    const pcp::EvalResult r = pcp::evaluate(mesh, pcp::read_mesh(dir + "gt.ply"));
    const pcp::PointCloud sdf = pcp::read_point_cloud(dir + "sdf_samples.ply");
    const Eigen::VectorXd& truth = sdf.properties.at("sdf");
    // The data's README says "negative inside", but gt.ply's own winding numbers say the opposite
    // for every sample of this scan: in these files the sdf is positive inside. Check that
    // convention against the ground-truth mesh first, then use it.
    const Eigen::VectorXd gt_w = pcp::winding_numbers(pcp::read_mesh(dir + "gt.ply"), sdf.points);
    Eigen::Index convention = 0;
    for (Eigen::Index i = 0; i < gt_w.size(); ++i) convention += (gt_w(i) > 0.5) == (truth(i) > 0);
    REQUIRE(convention >= gt_w.size() * 99 / 100);
    const Eigen::VectorXd w = pcp::winding_numbers(mesh, sdf.points);
    Eigen::Index agree = 0;
    for (Eigen::Index i = 0; i < w.size(); ++i) agree += (w(i) > 0.5) == (truth(i) > 0);
    const double agreement = static_cast<double>(agree) / static_cast<double>(w.size());
    WARN("abc_00010039, reduced preset: L2-CD x 100 = " << 100 * r.metrics.chamfer_l2 << ", NC = "
         << r.metrics.normal_consistency << ", sign agreement " << agreement << " of " << w.size()
         << " samples, " << mesh.faces.rows() << " faces");
    // Measured with the reduced preset (seed 1, 2 threads, 10 % uniform queries, sign repair on,
    // automatic denoising: 3 passes here): L2-CD x 100 = 0.042, NC 0.620, sign agreement 0.801.
    // Before: 0.072 / 0.564 / 0.763 without denoising, 0.199 / 0.563 / 0.747 also without the sign
    // repair, 0.348 also without uniform queries; Poisson baseline on this scan: 1.21 / 0.611 /
    // 0.73. Issue 5 asks for 0.95: not reached; about a quarter of the samples lie within the
    // scan's noise of the surface (docs/BENCHMARKS.md). These bounds guard against regressions.
    CHECK(agreement >= 0.76);
    CHECK(100 * r.metrics.chamfer_l2 < 0.07);
}
