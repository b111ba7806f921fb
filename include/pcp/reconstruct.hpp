// The reconstruction pipeline, file-free: point cloud (input frame) -> optional denoising ->
// PreparedCloud (checked, unit box, KD-tree) -> local context prior (given, or a self-prior,
// stage 1: pcp/train/prior.hpp) -> query-network fit (stage 2: pcp/train/query_fit.hpp) -> sign
// from the grid box's boundary -> sign repair and narrow-band SDF grid (pcp/mesh/) -> marching
// cubes at iso -> mesh in the input frame, faces outward (METHOD.md sections 1-5).
#pragma once

#include "pcp/cloud/denoise.hpp"
#include "pcp/core/progress.hpp"
#include "pcp/core/types.hpp"
#include "pcp/mesh/repair/cavity_fill.hpp"
#include "pcp/mesh/sign/field_normals.hpp"
#include "pcp/mesh/repair/fine_repair.hpp"
#include "pcp/mesh/grid/marching_cubes.hpp"
#include "pcp/mesh/surface/sheet_gap.hpp"
#include "pcp/mesh/surface/shell_centre.hpp"
#include "pcp/mesh/repair/through_carve.hpp"
#include "pcp/mesh/repair/tunnel_fill.hpp"
#include "pcp/mesh/grid/sdf_grid.hpp"
#include "pcp/mesh/sign/sign_repair.hpp"
#include "pcp/mesh/surface/smooth.hpp"
#include "pcp/mesh/surface/fairing.hpp"
#include "pcp/mesh/surface/recentre.hpp"
#include "pcp/mesh/surface/surface_fit.hpp"
#include "pcp/mesh/sign/winding_sign.hpp"
#include "pcp/train/prior.hpp"
#include "pcp/train/query_fit.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace pcp {

/// The scene mode (paper, "Surface Reconstruction for Scenes"; not its method, which meshes the
/// closed zero set): rooms are open -- walls seen from one side, floors without an underside, data
/// ending at doors and wall tops -- and a signed field closes every surface. In scene mode the
/// mesh keeps only the faces the data supports (pcp::trim_unsupported_faces): the closing hull and
/// the sheets where there is no data go, the open boundaries stay open. The preset "scene" turns it
/// on with the settings measured for rooms (docs/NOTEBOOK.md, "Scenes").
struct SceneOptions {
    bool enabled = false;
    double support_k = 1.0;  ///< a face stays when an input point lies within support_k x the sampling scale of its centroid
};

/// The prior fitted against when none is given to reconstruct().
enum class PriorSource {
    Builtin,    ///< the generic prior compiled into the library (pcp/train/builtin_prior.hpp)
    SelfPrior,  ///< a prior trained on the input cloud first (ReconstructOptions::self_prior)
    Auto,       ///< Builtin for clean clouds, SelfPrior for the clouds the denoiser found noisy
                ///< (DenoiseOptions::automatic; with several clouds, if any of them is)
};

/// What changes for a cloud the pipeline denoised (noisy): applied over the options of the passes
/// once, before the mesh stage runs (not in the paper; each value measured on the noisy shared
/// cases, docs/NOTEBOOK.md).
struct NoisyCloudOptions {
    /// Cavity fill: a pocket at most this open is filled (CavityFillOptions::max_open): pockets
    /// among the sheets of a noise band are 0.5 open too.
    double cavity_max_open = 0.15;
    /// Surface fit: input points per vertex (SurfaceFitOptions::neighbors): the averaging does
    /// the denoising.
    int fit_neighbors = 32;
    /// Surface passes fit to the input points as given, not the denoised ones (the denoiser's plane
    /// projection pulls points inward on curved parts).
    bool fit_raw_points = true;
    bool smooth = true;              ///< SmoothOptions::enabled
    bool recentre = true;            ///< RecentreOptions::enabled
    bool sheet_gap_where_raised = true;  ///< SheetGapOptions::where_raised_only
    /// ReconstructOptions::thin_company: a noisy field has valleys in the noise band and over
    /// thin noisy plates that a company of 3 raises.
    int thin_company = 6;
};

/// The default of every setting is the "default" preset's: ReconstructOptions{} is that preset
/// (presets.cpp derives the others from it; pcp/settings.hpp names and checks the settings). Each
/// value was chosen by a measurement on the shared cases (docs/NOTEBOOK.md).
struct ReconstructOptions {
    /// Denoising of the input (not in the paper): automatic (2 passes when pcp::noise_ratio says the
    /// cloud is noisy), each point moved to its own side's mode (mode_width 2), so that the two
    /// sides of a thin part stay apart.
    DenoiseOptions denoise = [] {
        DenoiseOptions d;
        d.automatic = true;
        d.auto_passes = 2;
        d.mode_width = 2.0;
        return d;
    }();
    /// When no prior is given: the built-in generic prior (pcp/train/builtin_prior.hpp), fine-tuned
    /// on the input (the paper's method with a self-prior: PriorSource::SelfPrior, preset "paper").
    PriorSource prior_source = PriorSource::Builtin;
    /// When the built-in prior is used: fine-tune the built-in prior on the input's regions for this many
    /// steps first (self_prior's regions, sampling and schedule; 0 = use it frozen).
    std::int64_t prior_tune_steps = 300;
    PriorTrainOptions self_prior = PriorTrainOptions::preset("fast");  ///< with PriorSource::SelfPrior
    /// The query network (stage 2): width 128, 6 hidden layers (the paper: 512 x 8), 2400 steps of
    /// 500 queries (the paper: about 100,000 of 400), a cosine schedule from 2e-3 after 100 warm-up
    /// steps, and 10 % of the queries drawn uniformly in the box (not in the paper).
    QueryFitOptions fit = [] {
        QueryFitOptions q;
        q.width = 128;
        q.depth = 6;
        q.queries_per_step = 500;
        q.steps = 2400;
        q.schedule.learning_rate = 2e-3;
        q.schedule.lr_schedule = LrScheduleKind::Cosine;
        q.schedule.warmup_steps = 100;
        q.sampling.uniform_fraction = 0.1f;
        return q;
    }();
    int resolution = 128;            ///< marching-cubes cells along the longest axis (paper: 128 / 512)
    double margin = 0.05;            ///< added around the cloud's unit box on every side (paper: 0.05)
    double iso = 0.0;                ///< the level set extracted: F_g = iso (every mesh stage sees F_g - iso)
    /// Thin parts kept whole (not in the paper): near the data, every mesh stage sees
    /// F_g - iso - thin_offset, and each extracted vertex is moved back along its normal by the
    /// level it was raised by, before the surface fit. Where a part is thinner than the field's
    /// error, F_g between its two sides stays just above zero and its zero level set is torn into
    /// holes and specks; the raised level encloses it, and moving back puts its sides where the
    /// zero level runs elsewhere. The level is raised by thin_offset within the surface fit's
    /// support radius (surface_fit.support_k x the sampling scale) of an input point and fades to
    /// nothing at twice that radius, so a field hovering just above zero away from the data grows
    /// no sheet there. Unit-box units (the cloud's longest edge is 1); 0: off. Measured on every
    /// shared case (docs/NOTEBOOK.md, "Thin parts kept whole").
    double thin_offset = 0.002;
    /// Where the field has no inside under a point of the data (a sheet sampled as one layer of
    /// points, a board thinner than the field resolves), the level near that point is raised
    /// further: to the field's value at thin_probe grid cells along the point's PCA normal, the larger
    /// of the two sides (at most thin_probe cells), so that the extracted slab is two of those deep
    /// and the grid's samples cannot miss it (a thinner slab falls between them: holes in stripes).
    /// Averaged over the 8 nearest points; never below thin_offset. 0: off (thin_offset everywhere).
    double thin_probe = 1.0;
    /// thin_probe's candidates are raised only with at least this many of their 8 nearest points
    /// (themselves included) candidates too (ThinLevel::raise_where_thin): 3 on clean clouds, whose
    /// one-layer sheets need it; more on denoised ones (NoisyCloudOptions::thin_company).
    int thin_company = 3;
    /// ... and only when at least this share of all points is raised (ThinLevel::raise_where_thin):
    /// the built-in shape's 16 of 20,000 points added 5 handles; on a thin noisy plate 1.9-2.7 %
    /// qualify, and the fixed offset already encloses that plate; the shells measured 30-45 %.
    double thin_min_share = 0.03;
    /// Narrow-band settings. The blocks whose corners certify that they are far from the zero set
    /// are interpolated, not evaluated (far_factor 2, the octree band's factor; docs/NOTEBOOK.md,
    /// "The dense grid from the blocks near the surface"), and the others are split down to 2-cell
    /// cells the same way (far_levels 3): in the dense grid the fills need, and in the sparse band
    /// of larger grids.
    SdfGridOptions grid = [] {
        SdfGridOptions g;
        g.far_factor = 2.0;
        g.far_levels = 3;
        return g;
    }();
    /// The sign away from the data by the winding number of the oriented points (not in the paper;
    /// never in the scene mode).
    WindingSignOptions winding_sign = [] {
        WindingSignOptions w;
        w.enabled = true;
        return w;
    }();
    SignRepairOptions sign_repair;   ///< flip regions whose sign the data does not support (not in the paper)
    /// Inside / outside by visibility through the cloud (pcp/cloud/visibility.hpp; its seed is
    /// fit.schedule.seed), computed once for every pass that reads them: the sign repair's label
    /// vote and the cavity fill (their min_label_votes > 0) and the winding sign's orientation
    /// (orient_by_labels); see needs_visibility_labels().
    VisibilityOptions visibility;
    CavityFillOptions cavity_fill;   ///< fill enclosed positive pockets (hollow shells of noisy scans) on a dense grid (not in the paper)
    FineRepairOptions fine_repair;   ///< the sign repair's rule on the fine grid, for thin membranes (not in the paper)
    TunnelFillOptions tunnel_fill;   ///< plug passages through the solid two cells across or less, on a dense grid (not in the paper)
    ThroughCarveOptions through_carve;  ///< make outside the inside samples on lines that cross no wall of the data (not in the paper)
    /// How marching cubes cuts an ambiguous face: the inside joined, so that the mesh bounds the
    /// solid of closed cubes whose handles and pockets the fills above count and remove (not in
    /// the paper). The asymptotic decider separates some diagonal pairs that solid joins: on the
    /// built-in shape it put back two handles the tunnel fill had no reason to see (genus 3 for 1),
    /// and tore a noisy scan's thin wall into 435 pieces (docs/NOTEBOOK.md, "Marching cubes on
    /// the repairs' solid").
    MarchingCubesOptions marching_cubes{McAmbiguity::JoinInside};
    ShellCentreOptions shell_centre; ///< noisy clouds: the surface in the middle of the noise band's shell, not on its outer wall (not in the paper)
    RecentreOptions recentre;        ///< the mesh onto the middle of the raw points' noise before the fit, of noisy clouds by default (not in the paper)
    SurfaceFitOptions surface_fit;   ///< support filter and fit of the mesh onto the data (not in the paper)
    SmoothOptions smoothing;         ///< bilateral smoothing of the final mesh, of noisy clouds by default (not in the paper)
    FairOptions fairing;             ///< the surface where no data lies under it faired onto the supported rest, last (not in the paper; off in the scene mode)
    SheetGapOptions sheet_gap;       ///< the two sides of a thin part at least min_gap apart, after the fairing (not in the paper)
    SceneOptions scene;              ///< open surfaces where the data ends (rooms); off except in the "scene" preset
    NoisyCloudOptions noisy;         ///< what changes for a cloud the pipeline denoised
    /// The oriented normals of the input points, when asked for (not in the paper): read off the
    /// final mesh at the nearest point (Mesh), the PCA normals oriented by it (PcaByMesh), or the
    /// PCA normals oriented by the fitted field's own votes (Field, pcp/mesh/sign/field_normals.hpp).
    NormalSource normal_source = NormalSource::Mesh;
    FieldNormalsOptions normals;     ///< PCA neighbours, and the votes of NormalSource::Field
    /// With fit.schedule.checkpoint_path set: write the finished query network there and keep the
    /// self-prior beside it (PATH.prior), so that a second call with fit.schedule.resume re-meshes
    /// (other resolution, sign repair or surface fit) without training again.
    bool keep_checkpoints = false;
    /// Evaluate the fitted SDF for meshing and for the sign repair with fp32 products even when
    /// the process runs bf16 (nn::set_gemm_precision; the training stays bf16). The grid is a small
    /// part of the time; bf16 rounding in the evaluation roughens the extracted surface. While it
    /// runs, reconstruct() sets the process-wide precision to fp32 and restores it afterwards.
    bool fp32_grid = true;
    /// Inputs of more points than this are fitted on a uniform random subsample of this many
    /// (seeded by fit.schedule.seed, input order kept; 0 = never): the memory and time of the fit
    /// then stop growing with the input. The mesh is in the
    /// input's frame as always, and the oriented normals are given for every input point. 200,000:
    /// the README's shape from 1M points, L2-CD x 100 against those points 0.0236 fitted on all of
    /// them (the queries' spread shrinks with the density), 0.0101 / 0.0106 / 0.0130 on 100k / 200k
    /// / 300k of them, in 18-27 s instead of 48 s (docs/NOTEBOOK.md, "Time and memory against the
    /// number of points with today's default"); no shared case has more than 200,000 points.
    Eigen::Index max_fit_points = 200000;
    ProgressCallback progress;       ///< forwarded to every stage ("prior", "query-net", "sdf-grid")

    /// Whether any pass that reads the visibility labels runs with these options.
    bool needs_visibility_labels() const;

    /// Named presets: "paper", "default", "fast", "scene". Throws pcp::Error for other names.
    static ReconstructOptions preset(const std::string& name);
};

/// One pass of the mesh stage as it ran (src/pipeline/mesh_stage.hpp): its name, what it changed
/// in a few words (empty: it did not run), and its time.
struct PassReport {
    std::string name;
    std::string summary;
    double seconds = 0;
};

struct ReconstructReport {
    std::vector<PassReport> passes;  ///< the grid and surface passes in their order
    double seconds_denoise = 0, seconds_prior = 0, seconds_fit = 0, seconds_grid = 0, seconds_mesh = 0;
    RecentreStats recentre;          ///< whether the recentring ran, the noise's spread and the mean move
    SurfaceFitStats surface_fit;     ///< what the surface fit removed and moved
    bool smoothed = false;           ///< the final mesh was smoothed (SmoothOptions, NoisyCloudOptions::smooth)
    FairStats fairing;               ///< the vertices the fairing placed (all 0: none, or the scene mode)
    std::int64_t collapsed_removed = 0;  ///< components the mesh stages shrank below the support filter's size, removed last (remove_small_components)
    SheetGapStats sheet_gap;         ///< the thin parts' sides moved apart
    std::int64_t thin_raised = 0;    ///< input points whose thin level thin_probe raised (before averaging)
    FineRepairStats fine_repair;     ///< what the fine sign repair flipped
    CavityFillStats cavity_fill;     ///< what the cavity fill negated
    TunnelFillStats tunnel_fill;     ///< what the tunnel fill plugged
    ThroughCarveStats through_carve; ///< what the through-line carve opened
    ShellCentreStats shell_centre;   ///< the vertices moved to the middle of their shell
    WindingSignStats winding_sign;   ///< the oriented normals and the winding-number tree
    FieldNormalsStats normals;       ///< the oriented normals of the input points (all 0: not asked for)
    std::int64_t winding_corrected = 0;  ///< field values whose sign the winding number changed
    VisibilityStats visibility;      ///< the visibility labels (all 0: not computed)
    bool builtin_prior = false;      ///< the fit used the built-in prior (frozen or fine-tuned)
    double prior_loss = 0, fit_loss = 0;
    std::int64_t fit_steps = 0;
    int denoise_passes = 0;          ///< passes applied to the input (DenoiseOptions; resolved when automatic)
    std::int64_t sdf_evaluations = 0;  ///< points the networks evaluated for the fine grid and the sign repair's coarse grid (the fine samples at the coarse ones reuse their values)
    std::int64_t sdf_reused = 0;       ///< fine-grid samples that took the sign repair's coarse value at the same point instead
    SignRepairStats sign_repair;
    bool sign_flipped = false;       ///< the fitted SDF was negated so that the outside is positive
    bool closed = false;             ///< every edge of the mesh is shared by exactly two faces
    std::int64_t scene_trimmed = 0;  ///< faces the scene mode removed (no data near them)
    bool cancelled = false;
    std::int64_t input_points = 0;   ///< points given
    std::int64_t fit_points = 0;     ///< points the fit used (fewer than input_points above ReconstructOptions::max_fit_points)
};

/// Thread safety: reconstruct may be called from several threads at once on different clouds (each
/// thread's OpenMP thread count is its own: omp_set_num_threads in that thread); the meshes equal
/// those of sequential calls (tests/e2e/e2e_concurrent.cpp, fp32). One exception: under bf16 with
/// fp32_grid (the default there) the grid stage switches the process-wide GEMM precision, so a
/// concurrent call's training then runs some steps in fp32 and is not reproducible; run such calls
/// one at a time, or set fp32_grid = false.
///
/// Point cloud (input frame) -> mesh (input frame, outward faces). With `prior` null the fit uses
/// the built-in prior or a self-prior trained on the cloud first (options.self_prior), as
/// options.prior_source says; the no-prior ablation only takes the network sizes from
/// options.self_prior. With `normals` non-null it also receives the
/// oriented unit normal of every input point (N x 3, input frame, same order, pointing outward),
/// read off the fitted field (pcp/mesh/sign/field_normals.hpp; of the denoised point when the cloud was
/// denoised); empty when the run was cancelled.
Mesh reconstruct(const Eigen::Ref<const Points>& points, const LocalPrior* prior, const ReconstructOptions& options,
                 ReconstructReport* report = nullptr, Points* normals = nullptr);

/// Several clouds, one fit (paper, "Optimization": multiple point clouds with one-hot vectors as
/// the condition of each q_g): each cloud is prepared on its own (denoised when asked, its own unit
/// box, subsampled above max_fit_points), one prior serves them all (given, or a self-prior trained
/// on all of them), and ONE query network is fitted with each query conditioned on its cloud's
/// one-hot code (QueryNetFitter's several-cloud form: equal shares of options.fit.steps x batch).
/// Then each cloud is meshed from its own F_g(., e_k) exactly as reconstruct() does, in its own
/// input frame. One cloud is reconstruct() itself. Only the method (ablation none) and no sign
/// guide; resume and progress as for one cloud (stages "prior", "query-net", then "sdf-grid" once
/// per cloud). `reports` (if given) gets one report per cloud; the prior's and the fit's figures
/// are the shared run's, in each. Returns one mesh per cloud, in order; empty when cancelled
/// (reports' `cancelled` set). Throws pcp::Error naming the cloud ("cloud k") for bad input.
std::vector<Mesh> reconstruct_many(const std::vector<Points>& clouds, const LocalPrior* prior,
                                   const ReconstructOptions& options, std::vector<ReconstructReport>* reports = nullptr);

}  // namespace pcp
