// The passes of the mesh stage and their order (see mesh_stage.hpp): each runs one function of
// pcp/mesh with the options as overlaid for this cloud, keeps its stats in the report, and says in a
// few words what it changed.
#include "mesh_stage.hpp"

#include "pcp/core/error.hpp"
#include "pcp/mesh/surface/mesh_ops.hpp"
#include "pcp/mesh/repair/cavity_fill.hpp"
#include "pcp/mesh/repair/fine_repair.hpp"
#include "pcp/mesh/surface/sheet_gap.hpp"
#include "pcp/mesh/surface/shell_centre.hpp"
#include "pcp/mesh/surface/smooth.hpp"
#include "pcp/mesh/surface/fairing.hpp"
#include "pcp/mesh/surface/recentre.hpp"
#include "pcp/mesh/surface/surface_fit.hpp"
#include "pcp/mesh/repair/through_carve.hpp"
#include "pcp/mesh/repair/tunnel_fill.hpp"
#include "mesh/grid/grid_samples.hpp"

#include <chrono>
#include <limits>
#include <sstream>

namespace pcp::detail {

namespace {

template <class... T>
std::string words(const T&... parts) {
    std::ostringstream s;
    (s << ... << parts);
    return s.str();
}

// ---- grid passes: the fine grid's samples --------------------------------------------------------

/// Enclosed pockets of "outside": the hollow shells of noisy scans (pcp/mesh/repair/cavity_fill.hpp). A
/// noisy cloud's grid is kept as it was first, for the shell centring.
std::string cavity_fill(MeshContext& c) {
    const ReconstructOptions& o = c.options;
    if (!o.cavity_fill.enabled) return "";
    if (o.shell_centre.enabled && c.dense) c.before_fill = c.grid;
    CavityFillStats& st = c.report.cavity_fill;
    st = fill_cavities(c.grid, o.cavity_fill, &c.labels, &c.cloud.tree());
    if (st.skipped) return "skipped (grid too large)";
    return words("filled ", st.cavities, " pockets (", st.labelled_cavities, " open but labelled inside, ", st.supported_cavities,
                 " open only on the data)");
}

/// Membranes and bubbles too thin for the sign repair's coarse grid (pcp/mesh/repair/fine_repair.hpp).
std::string fine_repair(MeshContext& c) {
    if (!c.options.fine_repair.enabled) return "";
    const FineRepairStats& st = c.report.fine_repair = repair_fine_grid(c.grid, c.cloud.tree(), c.options.fine_repair);
    if (st.skipped) return "skipped (grid too large)";
    return words("flipped ", st.flipped_components, " of ", st.components, " thin regions");
}

/// Passages through the solid too narrow for the data to support: the small handles of a bumpy
/// field (pcp/mesh/repair/tunnel_fill.hpp); a pocket a plug closed off is then a cavity, filled again.
std::string tunnel_fill(MeshContext& c) {
    const ReconstructOptions& o = c.options;
    if (!o.tunnel_fill.enabled) return "";
    const TunnelFillStats& st = c.report.tunnel_fill = fill_tunnels(c.grid, o.tunnel_fill);
    if (st.skipped) return "skipped (grid too large)";
    if (st.plugged > 0 && o.cavity_fill.enabled) {
        const CavityFillStats again = fill_cavities(c.grid, o.cavity_fill, &c.labels, &c.cloud.tree());
        CavityFillStats& fill = c.report.cavity_fill;
        fill.cavities += again.cavities;
        fill.cavity_samples += again.cavity_samples;
        fill.labelled_cavities += again.labelled_cavities;
        fill.supported_cavities += again.supported_cavities;
    }
    return words("plugged ", st.plugged, " of ", st.candidates, " narrow passages");
}

/// Openings the field spans though lines pass through them that cross no wall of the data
/// (pcp/mesh/repair/through_carve.hpp).
std::string through_carve(MeshContext& c) {
    if (!c.options.through_carve.enabled) return "";
    const ThroughCarveStats& st = c.report.through_carve = carve_through_lines(c.grid, c.cloud.tree(), c.options.through_carve);
    if (st.skipped) return "skipped (grid too large)";
    return words("opened ", st.opened, " of ", st.pieces, " pieces (", st.carved, " of ", st.candidates, " samples tried)");
}

/// Sheets the grid's samples miss at the thin offset: their level raised (ReconstructOptions::thin_probe),
/// and the shell centring's copy from before the fill alike (or a raised sheet looks to it like a
/// hollow the fill closed).
std::string thin_probe(MeshContext& c) {
    const ReconstructOptions& o = c.options;
    if (!(o.thin_offset > 0 && o.thin_probe > 0)) return "";
    const auto reach = static_cast<float>(o.thin_probe * c.grid.spec.spacing().minCoeff());
    c.report.thin_raised = c.thin_level.raise_where_thin(c.grid, reach, o.thin_company, o.thin_min_share);
    if (c.before_fill) c.thin_level.shift_like_raise(*c.before_fill);
    return words("raised the level at ", c.report.thin_raised, " points with no inside under them");
}

// ---- surface passes: the mesh --------------------------------------------------------------------

/// A noisy cloud's surface in the middle of its noise band's shell, whose inner wall the cavity
/// fill removed (pcp/mesh/surface/shell_centre.hpp).
std::string shell_centre(MeshContext& c) {
    if (!c.before_fill || c.report.cavity_fill.cavity_samples == 0) return "";
    ShellCentreStats& st = c.report.shell_centre;
    c.mesh = centre_in_shells(c.mesh, *c.before_fill, c.grid, c.cloud.tree(),
                              c.options.shell_centre.max_thickness_k * sampling_scale(c.cloud.tree()), &st);
    return words("moved ", st.moved, " vertices inward by ", st.mean_move, " on average");
}

/// Onto the middle of the points' noise, averaged over a few sampling scales (RecentreOptions);
/// the surface fit then leaves out the far side of thin parts by the spread measured here.
std::string recentre(MeshContext& c) {
    if (!c.options.recentre.enabled) return "";
    RecentreStats& st = c.report.recentre;
    c.mesh = recentre_on_points(c.mesh, c.fit_points, c.options.recentre, &st);
    st.applied = true;
    if (c.noise_spread == 0) c.noise_spread = st.spread;
    return words("noise spread ", st.spread, ", mean move ", st.mean_move);
}

/// Components away from the data removed, vertices moved onto the data (pcp/mesh/surface/surface_fit.hpp).
std::string surface_fit(MeshContext& c) {
    SurfaceFitOptions fit = c.options.surface_fit;
    fit.noise_spread = c.noise_spread;
    const SurfaceFitStats& st = c.report.surface_fit;
    c.mesh = fit_surface_to_points(c.mesh, c.fit_points, fit, &c.report.surface_fit);
    PCP_CHECK(c.mesh.faces.rows() > 0, "reconstruction produced no surface near the input points (every piece of "
                                       "the fitted SDF's zero set lies away from the data)");
    if (!fit.enabled) return "";
    return words("removed ", st.removed_components, " of ", st.components, " components (", st.removed_small, " small, ",
                 st.removed_blisters, " on the largest), moved ", st.supported_vertices, " vertices");
}

/// The noise's bumps that the fit onto noisy data keeps (pcp/mesh/surface/smooth.hpp).
std::string smoothing(MeshContext& c) {
    c.report.smoothed = c.options.smoothing.enabled;
    if (!c.report.smoothed) return "";
    c.mesh = bilateral_smooth(c.mesh, c.options.smoothing.bilateral);
    return "bilateral normal filter";
}

/// Where no data lies under it, the smoothest surface that joins the data (FairOptions).
std::string fairing(MeshContext& c) {
    if (!c.options.fairing.enabled) return "";
    const FairStats& st = c.report.fairing;
    c.mesh = fair_unsupported(c.mesh, c.fit_points, c.options.fairing, &c.report.fairing);
    if (st.failed) return "skipped (its sparse solve failed)";
    return words("placed ", st.free_vertices, " vertices in ", st.patches, " patches (", st.reverted, " patches left)");
}

/// The two sides of a thin part, which the move back and the fit bring onto the same data, apart
/// again where the solid that marching cubes extracted lies between them (pcp/mesh/surface/sheet_gap.hpp).
std::string sheet_gap(MeshContext& c) {
    const SheetGapOptions& o = c.options.sheet_gap;
    if (!o.enabled || (o.where_raised_only && c.report.thin_raised == 0)) return "";
    const SdfGrid& grid = c.grid;
    const ThinLevel& thin = c.thin_level;
    c.mesh = keep_sheets_apart(
        c.mesh,
        [&](const Eigen::Vector3d& p) {
            if (o.where_raised_only && !thin.raised_at(p.cast<float>())) return std::numeric_limits<float>::quiet_NaN();
            return stored_at(grid, p);
        },
        o, &c.report.sheet_gap);
    return words("moved apart at ", c.report.sheet_gap.moved, " vertices (", c.report.sheet_gap.crossed, " had crossed)");
}

/// The support filter's size rule again on the final geometry: the fit and the smoothing shrink a
/// lone sample's octahedron beside the data to a point (remove_small_components).
std::string small_components(MeshContext& c) {
    if (!c.options.surface_fit.enabled) return "";
    c.mesh = remove_small_components(c.mesh, c.options.surface_fit.min_extent_k * c.report.surface_fit.scale,
                                     &c.report.collapsed_removed);
    return words("removed ", c.report.collapsed_removed);
}

/// Scenes: open where the data ends (ReconstructOptions::scene).
std::string scene_trim(MeshContext& c) {
    const SceneOptions& o = c.options.scene;
    if (!o.enabled) return "";
    c.mesh = trim_unsupported_faces(c.mesh, c.cloud.tree(), o.support_k * sampling_scale(c.cloud.tree()), &c.report.scene_trimmed);
    PCP_CHECK(c.mesh.faces.rows() > 0, "scene mode: no face of the mesh lies near the input points");
    return words("removed ", c.report.scene_trimmed, " faces with no data near them");
}

}  // namespace

const std::vector<MeshPass>& grid_passes() {
    static const std::vector<MeshPass> passes = {
        {"cavity fill", cavity_fill},     {"fine repair", fine_repair}, {"tunnel fill", tunnel_fill},
        {"through-line carve", through_carve}, {"thin probe", thin_probe},
    };
    return passes;
}

const std::vector<MeshPass>& surface_passes() {
    static const std::vector<MeshPass> passes = {
        {"shell centring", shell_centre}, {"recentring", recentre}, {"surface fit", surface_fit},
        {"smoothing", smoothing},         {"fairing", fairing},     {"sheet gap", sheet_gap},
        {"small components", small_components}, {"scene trim", scene_trim},
    };
    return passes;
}

void run_passes(const std::vector<MeshPass>& passes, MeshContext& context) {
    for (const MeshPass& pass : passes) {
        const auto t0 = std::chrono::steady_clock::now();
        PassReport done;
        done.name = pass.name;
        done.summary = pass.run(context);
        done.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        context.report.passes.push_back(std::move(done));
    }
}

ReconstructOptions overlay_options(const ReconstructOptions& options, bool noisy) {
    ReconstructOptions o = options;
    if (noisy) {
        const NoisyCloudOptions& n = options.noisy;
        o.cavity_fill.max_open = n.cavity_max_open;
        o.surface_fit.neighbors = n.fit_neighbors;
        o.smoothing.enabled = n.smooth;
        o.recentre.enabled = n.recentre;
        o.thin_company = n.thin_company;
        o.sheet_gap.where_raised_only = n.sheet_gap_where_raised;
    } else {
        o.shell_centre.enabled = false;  // a clean cloud's outer wall lies on the data; the inner one is the field's error
    }
    if (o.scene.enabled) {
        o.winding_sign.enabled = false;    // an open room has no inside
        o.through_carve.enabled = false;   // lines over a room open at its top pass no wall, as over a missed cap
        o.fairing.enabled = false;         // the scene trim removes those faces instead
        o.grid.band = NarrowBand::NearPoints;  // only the blocks near the data: the closed hull costs nothing
        o.grid.grow = false;
    }
    return o;
}

}  // namespace pcp::detail
