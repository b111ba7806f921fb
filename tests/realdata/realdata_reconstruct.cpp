// Real data (label realdata): reconstruct an ABC scan with the reduced preset, check L2-CD x 100
// (Points2Surf protocol, against its gt.ply) and the sign of the result against the ground-truth
// signed-distance samples.
#include "pcp/cloud/kdtree.hpp"
#include "pcp/cloud/normalize.hpp"
#include "pcp/eval/eval.hpp"
#include "pcp/io/io.hpp"
#include "pcp/reconstruct.hpp"
#include "gemm_backends.hpp"
#include "pcp/nn/gemm.hpp"
#include "reduced_preset.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <numeric>
#include <vector>

namespace {

/// The fraction of supported vertices of the least supported connected component of `mesh`: a
/// vertex is supported when a point of `cloud` lies within 3 median nearest-neighbour spacings of
/// the cloud (pcp_eval --diagnose's support radius), measured independently of the pipeline's own
/// filter (which uses the denoised cloud and another scale).
double least_supported_component(const pcp::Mesh& mesh, const pcp::Points& cloud, Eigen::Index* components) {
    const pcp::Normalization norm = pcp::fit_unit_box(cloud);
    const pcp::KdTree tree(norm.to_unit(cloud));
    Eigen::VectorXf nn = tree.kth_distance(tree.points(), 2);
    std::nth_element(nn.data(), nn.data() + nn.size() / 2, nn.data() + nn.size());
    const float radius = 3.0f * nn(nn.size() / 2);
    Eigen::VectorXf d;
    tree.nearest(norm.to_unit(mesh.vertices), &d);
    std::vector<int> parent(static_cast<std::size_t>(mesh.vertices.rows()));
    std::iota(parent.begin(), parent.end(), 0);
    auto find = [&](int a) {
        while (parent[static_cast<std::size_t>(a)] != a) a = parent[static_cast<std::size_t>(a)] = parent[static_cast<std::size_t>(parent[static_cast<std::size_t>(a)])];
        return a;
    };
    for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f)
        for (int k = 1; k < 3; ++k) parent[static_cast<std::size_t>(find(mesh.faces(f, 0)))] = find(mesh.faces(f, k));
    std::vector<double> total(parent.size(), 0), near(parent.size(), 0);
    for (Eigen::Index v = 0; v < mesh.vertices.rows(); ++v) {
        const int r = find(static_cast<int>(v));
        total[static_cast<std::size_t>(r)] += 1;
        if (d(v) <= radius) near[static_cast<std::size_t>(r)] += 1;
    }
    double least = 1;
    *components = 0;
    for (std::size_t r = 0; r < parent.size(); ++r)
        if (total[r] > 0) {
            ++*components;
            least = std::min(least, near[r] / total[r]);
        }
    return least;
}

// Reconstructs abc_00010039 with the reduced preset in the current gemm precision and checks it.
void check_abc_00010039() {
    const std::string dir = std::string(PCP_DATA_DIR) + "/abc/abc_00010039/";
    const pcp::PointCloud cloud = pcp::read_point_cloud(dir + "input.ply");
    REQUIRE(cloud.points.rows() == 6936);
    pcp::ReconstructReport report;
    const pcp::Mesh mesh = pcp::reconstruct(cloud.points, nullptr, pcp::test::reduced_preset(), &report);
    CHECK(report.closed);
    // No component of the output without input points near it (issue 15): every component has
    // most of its vertices near the input.
    Eigen::Index components = 0;
    const double least = least_supported_component(mesh, cloud.points, &components);
    WARN("abc_00010039: " << components << " components, the least supported has " << least
                          << " of its vertices near the input; the surface fit removed " << report.surface_fit.removed_components
                          << " of " << report.surface_fit.components);
    CHECK(least >= 0.5);
    const pcp::PointCloud sdf = pcp::read_point_cloud(dir + "sdf_samples.ply");
    const Eigen::VectorXd& truth = sdf.properties.at("sdf");
    // The data's README says "negative inside", but gt.ply's own winding numbers say the opposite
    // for every sample of this scan: in these files the sdf is positive inside. Take the
    // convention from the ground-truth mesh, and require it to be unambiguous.
    const pcp::Mesh gt = pcp::read_mesh(dir + "gt.ply");
    double gt_agreement = 0;
    const pcp::SdfConvention convention = pcp::detect_sdf_convention(gt, sdf.points, truth, &gt_agreement);
    REQUIRE(gt_agreement >= 0.99);
    const pcp::EvalResult r = pcp::evaluate(mesh, gt);
    // Half of the samples lie closer to the surface than 0.0216, while the scan's points lie a
    // median 0.011 (RMS 0.021) from gt.ply: there the sign is decided by the scanner's noise. The
    // samples farther than that RMS distance (measured here) are counted separately.
    const Eigen::VectorXd noise = pcp::point_to_mesh_distance(gt, cloud.points);
    const double noise_rms = std::sqrt(noise.squaredNorm() / static_cast<double>(noise.size()));
    CHECK(noise_rms > 0.015);  // the scan is as noisy as measured (0.0208)
    const pcp::SignAgreement signs = pcp::sign_agreement(mesh, sdf.points, truth, convention, {noise_rms});
    REQUIRE(signs.bins.size() == 2);
    const double agreement = signs.fraction();
    const double far_agreement = signs.bins[1].fraction();
    WARN("abc_00010039, reduced preset, " << pcp::nn::precision_name(pcp::nn::gemm_precision()) << ": L2-CD x 100 = " << 100 * r.metrics.chamfer_l2 << ", NC = "
         << r.metrics.normal_consistency << ", sign agreement " << agreement << " of " << signs.samples
         << " samples, " << far_agreement << " of the " << signs.bins[1].samples << " farther than " << noise_rms
         << " from the surface, " << mesh.faces.rows() << " faces");
    // Measured with the reduced preset (seed 1, 2 threads, 10 % uniform queries, sign repair on,
    // automatic denoising: 3 passes here): L2-CD x 100 = 0.045, NC 0.616, sign agreement 0.800,
    // 0.977 on the 1032 samples farther than the noise. Before: 0.072 / 0.564 / 0.763 without
    // denoising, 0.199 / 0.563 / 0.747 also without the sign repair, 0.348 also without uniform
    // queries; Poisson baseline on this scan: 1.21 / 0.611 / 0.73. Issue 5 asks for 0.95 on all
    // samples: not reached, and not reached either from noise-free points sampled on gt.ply (0.866,
    // fast preset): the near samples need the surface placed to within a few thousandths
    // (docs/NOTEBOOK.md, "Sign agreement"). These bounds guard against regressions.
    CHECK(agreement >= 0.76);
    CHECK(far_agreement >= 0.95);
    CHECK(100 * r.metrics.chamfer_l2 < 0.07);
}

}  // namespace

TEST_CASE("realdata: abc_00010039 reconstructs close to its ground truth with the right sign", "[realdata][reconstruct]") {
    pcp::test::RestoreGemmSettings restore;
    pcp::nn::set_gemm_precision(pcp::nn::Precision::Fp32);
    check_abc_00010039();
}

// The apps' default (--precision auto) is bf16 where the CPU has it: the same bounds hold there.
// Tagged [bf16]: reported Skipped where bf16 is unavailable (tests/support/main.cpp).
TEST_CASE("realdata: abc_00010039 in bf16 meets the same bounds", "[realdata][reconstruct][bf16]") {
    pcp::test::RestoreGemmSettings restore;
    pcp::nn::set_gemm_precision(pcp::nn::Precision::Bf16);
    check_abc_00010039();
}

// No component of the output without input points near it, on a clean object (issue 15): the
// bunny, reduced preset. Measured (seed 1, 2 threads, fp32): the surface fit removes 5 of 10
// components, and the least supported one left has 0.84 of its vertices near the input; without
// the fit (PCP_TEST_SURFACE_FIT_OFF=1 in the environment) 10 components are left, the least
// supported with none of its vertices near the input, and the check fails.
TEST_CASE("realdata: every component of the bunny's mesh has input points near it", "[realdata][reconstruct]") {
    pcp::test::RestoreGemmSettings restore;
    pcp::nn::set_gemm_precision(pcp::nn::Precision::Fp32);
    const pcp::PointCloud cloud = pcp::read_point_cloud(std::string(PCP_DATA_DIR) + "/objects/bunny/input.ply");
    pcp::ReconstructOptions options = pcp::test::reduced_preset();
    if (std::getenv("PCP_TEST_SURFACE_FIT_OFF")) options.surface_fit.enabled = false;
    pcp::ReconstructReport report;
    const pcp::Mesh mesh = pcp::reconstruct(cloud.points, nullptr, options, &report);
    Eigen::Index components = 0;
    const double least = least_supported_component(mesh, cloud.points, &components);
    WARN("bunny: " << components << " components, the least supported has " << least
                   << " of its vertices near the input; the surface fit removed " << report.surface_fit.removed_components
                   << " of " << report.surface_fit.components);
    CHECK(least >= 0.5);
}


// abc_00016513 with the default preset at 256 cells: the fairing's thin plate, with its cotangent
// weights clipped to [0.01, 1000] x their mean and no guard, shot vertices of the barely scanned
// bore up to 0.75 of the shape's extent away (needles; docs/NOTEBOOK.md, "Needles in the fairing
// at 256 cells"). Every vertex now lies within 0.064 of the extent of an input point (measured on
// a 2-core Xeon; 0.067 with the fairing off, 0.084 at 128 cells); the bound leaves room for other
// machines' rounding. Whether the needles appear depends on the fitted field: with 2400 steps on a
// 2-core Emerald Rapids this test measured 0.095, and 0.094 with the old clip and no guard put back,
// so there it guards the 256-cell pipeline as a whole; the guard's own deterministic check is the
// unit test `fairing: a patch whose solution leaves its box is left as it was`.
TEST_CASE("realdata: abc_00016513 at 256 cells has no vertex far from its input", "[realdata][reconstruct]") {
    pcp::test::RestoreGemmSettings restore;
    pcp::nn::set_gemm_precision(pcp::nn::Precision::Fp32);
    const pcp::PointCloud cloud = pcp::read_point_cloud(std::string(PCP_DATA_DIR) + "/abc/abc_00016513/input.ply");
    pcp::ReconstructOptions options = pcp::ReconstructOptions::preset("default");
    options.resolution = 256;
    pcp::ReconstructReport report;
    const pcp::Mesh mesh = pcp::reconstruct(cloud.points, nullptr, options, &report);
    const pcp::KdTree tree(cloud.points.cast<float>());
    Eigen::VectorXf d;
    tree.nearest(mesh.vertices.cast<float>(), &d);
    const double extent = (cloud.points.colwise().maxCoeff() - cloud.points.colwise().minCoeff()).maxCoeff();
    const double farthest = static_cast<double>(d.maxCoeff()) / extent;
    WARN("abc_00016513 at 256 cells: the farthest vertex lies " << farthest << " of the extent from the input; faired "
                                                                 << report.fairing.free_vertices << " vertices in " << report.fairing.patches
                                                                 << " patches, " << report.fairing.reverted << " left by the guard");
    CHECK(farthest < 0.15);
}
