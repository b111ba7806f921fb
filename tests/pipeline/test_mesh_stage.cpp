// Tests for the mesh stage's plan (src/pipeline/mesh_stage.hpp): the two pass lists in their order,
// the overlays of noisy clouds and scenes applied to the options once, and a run's report with one
// entry per pass in that order.
#include "pipeline/mesh_stage.hpp"

#include "pcp/cloud/shapes.hpp"

#include <catch2/catch.hpp>

#include <string>
#include <vector>

namespace {

std::vector<std::string> names(const std::vector<pcp::detail::MeshPass>& passes) {
    std::vector<std::string> out;
    for (const pcp::detail::MeshPass& p : passes) out.push_back(p.name);
    return out;
}

}  // namespace

TEST_CASE("mesh stage: the passes in their order", "[mesh_stage]") {
    CHECK(names(pcp::detail::grid_passes()) ==
          std::vector<std::string>{"cavity fill", "fine repair", "tunnel fill", "through-line carve", "thin probe"});
    CHECK(names(pcp::detail::surface_passes()) ==
          std::vector<std::string>{"shell centring", "recentring", "surface fit", "smoothing", "fairing", "sheet gap",
                                   "small components", "scene trim"});
}

TEST_CASE("mesh stage: a noisy cloud's settings and the scene mode's are overlays of the options", "[mesh_stage]") {
    const pcp::ReconstructOptions d;
    const pcp::ReconstructOptions clean = pcp::detail::overlay_options(d, false);
    CHECK(clean.cavity_fill.max_open == d.cavity_fill.max_open);
    CHECK(clean.surface_fit.neighbors == d.surface_fit.neighbors);
    CHECK_FALSE(clean.smoothing.enabled);
    CHECK_FALSE(clean.recentre.enabled);
    CHECK_FALSE(clean.shell_centre.enabled);  // a clean cloud's outer wall lies on the data
    CHECK_FALSE(clean.sheet_gap.where_raised_only);
    const pcp::ReconstructOptions noisy = pcp::detail::overlay_options(d, true);
    CHECK(noisy.cavity_fill.max_open == d.noisy.cavity_max_open);
    CHECK(noisy.surface_fit.neighbors == d.noisy.fit_neighbors);
    CHECK(noisy.thin_company == d.noisy.thin_company);
    CHECK(noisy.smoothing.enabled);
    CHECK(noisy.recentre.enabled);
    CHECK(noisy.shell_centre.enabled);
    CHECK(noisy.sheet_gap.where_raised_only);
    const pcp::ReconstructOptions scene = pcp::detail::overlay_options(pcp::ReconstructOptions::preset("scene"), true);
    CHECK_FALSE(scene.winding_sign.enabled);
    CHECK_FALSE(scene.through_carve.enabled);
    CHECK_FALSE(scene.fairing.enabled);
    CHECK_FALSE(scene.recentre.enabled);  // the scene preset's noisy clouds are not recentred
    CHECK(scene.grid.band == pcp::NarrowBand::NearPoints);
    pcp::ReconstructOptions room_with_fill = pcp::ReconstructOptions::preset("scene");
    room_with_fill.through_carve.enabled = true;  // asked for, still off in a scene: it would open the floor
    CHECK_FALSE(pcp::detail::overlay_options(room_with_fill, false).through_carve.enabled);
}

TEST_CASE("mesh stage: a run reports every pass in order, the ones that did nothing with no summary", "[mesh_stage][heavy]") {
    pcp::ReconstructOptions o = pcp::ReconstructOptions::preset("fast");
    o.fit.steps = 150;
    o.prior_tune_steps = 0;
    o.resolution = 40;
    o.denoise.automatic = false;
    pcp::ReconstructReport report;
    const pcp::Mesh mesh = pcp::reconstruct(pcp::sample_sphere(3000, 0.4, Eigen::Vector3d::Zero(), 5).points, nullptr, o, &report);
    REQUIRE(mesh.faces.rows() > 0);
    std::vector<std::string> ran;
    for (const pcp::PassReport& p : report.passes) {
        ran.push_back(p.name);
        CHECK(p.seconds >= 0);
    }
    std::vector<std::string> all = names(pcp::detail::grid_passes());
    for (const std::string& n : names(pcp::detail::surface_passes())) all.push_back(n);
    CHECK(ran == all);
    const auto summary = [&](const std::string& name) {
        for (const pcp::PassReport& p : report.passes)
            if (p.name == name) return p.summary;
        return std::string("?");
    };
    CHECK_FALSE(summary("surface fit").empty());
    CHECK(summary("smoothing").empty());   // a clean cloud
    CHECK(summary("scene trim").empty());  // not a scene
    CHECK(summary("shell centring").empty());
}
