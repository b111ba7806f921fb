// The mesh stage of pcp::reconstruct (internal): from a fitted field to the mesh in the input
// frame, as two ordered lists of passes over one shared context. The lists in mesh_passes.cpp are
// the statement of the order; docs/ARCHITECTURE.md draws it.
//
//   field    the sign outside (the grid box's boundary, or a scene's free space), the thin level,
//            the winding sign and the sign repair composed into one field (mesh_stage.cpp)
//   grid     that field on the fine grid (narrow band, or dense for the fills)
//   grid passes     repairs of the grid's samples, in order (grid_passes())
//   extraction      marching cubes, then each vertex moved back by its thin level
//   surface passes  moves and trims of the mesh, in order (surface_passes())
//   output   the input frame, closedness, the oriented normals when asked for
//
// Noisy clouds and scenes differ only by the options: overlay_options() applies their settings
// once, before any pass runs; the passes read the options as they are.
#pragma once

#include "pcp/reconstruct.hpp"
#include "pcp/cloud/prepared_cloud.hpp"
#include "pcp/mesh/repair/thin_level.hpp"

#include <optional>
#include <string>
#include <vector>

namespace pcp::detail {

/// What every pass may read and change.
struct MeshContext {
    MeshContext(const PreparedCloud& cloud_in, const KdTree& fit_points_in, const VisibilityLabels& labels_in,
                const ReconstructOptions& options_in, ReconstructReport& report_in, ThinLevel& thin_level_in)
        : cloud(cloud_in), fit_points(fit_points_in), labels(labels_in), options(options_in), report(report_in),
          thin_level(thin_level_in) {}

    const PreparedCloud& cloud;        ///< the fitted cloud (denoised when the pipeline denoised it), unit box
    const KdTree& fit_points;          ///< the points the surface passes fit to (the raw input of a denoised cloud)
    const VisibilityLabels& labels;    ///< empty when no pass reads them
    const ReconstructOptions& options; ///< with the overlays applied (overlay_options)
    ReconstructReport& report;
    ThinLevel& thin_level;
    SdfGrid grid;                      ///< the fine grid, F_g - iso - the thin level, positive outside
    bool dense = false;                ///< the grid holds every sample of its lattice
    std::optional<SdfGrid> before_fill;  ///< a noisy cloud's grid before the cavity fill (the shell centring's)
    Mesh mesh;                         ///< unit box; set by the extraction
    double noise_spread = 0;           ///< measured by the recentring, used by the surface fit
};

/// One step of the mesh stage: `run` does its work on the context (or nothing, when its options
/// say so) and returns what it changed in a few words ("" when it did not run).
struct MeshPass {
    const char* name;
    std::string (*run)(MeshContext&);
};

/// The grid passes and the surface passes, in their order.
const std::vector<MeshPass>& grid_passes();
const std::vector<MeshPass>& surface_passes();

/// Runs `passes` in order, appending one PassReport per pass to context.report.passes.
void run_passes(const std::vector<MeshPass>& passes, MeshContext& context);

/// The options as the passes of one cloud see them: for a noisy cloud (one the pipeline denoised)
/// the values of ReconstructOptions::noisy written into the settings the passes read, for a
/// clean one no shell centring, and the scene mode's (no winding sign, no through-line carve, no
/// fairing, the grid near the points only) applied once.
ReconstructOptions overlay_options(const ReconstructOptions& options, bool noisy);

/// A progress callback that calls both (either may be empty).
ProgressCallback chain(const ProgressCallback& a, const ProgressCallback& b);

/// Per-point values of the fitted cloud, given to every input point: the same rows, or, when the
/// fit used a subsample, the row of the fitted point nearest to each input point.
PointsF per_input_point(const PointsF& values, const PreparedCloud& cloud, const Eigen::Ref<const Points>& all_points,
                        bool subsampled);

/// From the fitted field of cloud `index` to its mesh in the input frame (the stages above).
Mesh mesh_stage(const QueryNetFitter& fitter, int index, const PreparedCloud& cloud, const Eigen::Ref<const Points>& all_points,
                bool subsampled, const VisibilityLabels& labels, const ReconstructOptions& options, ReconstructReport& r,
                Points* normals);

}  // namespace pcp::detail
