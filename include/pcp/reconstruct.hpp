// Stage 2 of PCP and meshing (METHOD.md sections 2-5, paper section 3 "Predictive Context Prior"):
// with the prior's decoder F frozen, fit the query network Q(q_g) -> (dq, f') so that the global
// SDF F_g(q_g) = F(q_g + dq, f') pulls the queries onto the cloud (Neural-Pull loss); then evaluate
// F_g on a narrow-band grid, extract the zero level set with marching cubes, orient it outward and
// map it back to the input's frame.
#pragma once

#include "pcp/cloud/denoise.hpp"
#include "pcp/cloud/normalize.hpp"
#include "pcp/train/prior.hpp"
#include "pcp/core/progress.hpp"
#include "pcp/cloud/sampling.hpp"
#include "pcp/mesh/sdf_grid.hpp"
#include "pcp/mesh/sign_repair.hpp"
#include "pcp/core/types.hpp"

#include <cstdint>
#include <memory>
#include <string>

namespace pcp {

/// The paper's ablations of stage 2 (section 4.4, "Ablation Studies", table 9, and "Specializing
/// Context Prior", table 10), as switches of the query-network fitting. Names (CLI --ablation):
///
/// | name            | paper row (table)          | q_l'                 | f'                       | F        |
/// |-----------------|----------------------------|----------------------|--------------------------|----------|
/// | `none`          | "Ours" / "Our specializing" | q_g + dq (Q)         | predicted by Q           | frozen   |
/// | `no-shift`      | "No dq" (9)                | q_g                  | predicted by Q           | frozen   |
/// | `direct`        | "Direct q_l'" (9)          | predicted by Q       | predicted by Q           | frozen   |
/// | `free-code`     | "No f_l'" (9)              | q_g + dq (Q)         | one auto-decoded code    | frozen   |
/// | `pointnet-code` | "No f_l' + f_l" (9)        | q_g + dq (Q)         | frozen encoder, region   | frozen   |
/// | `no-prior`      | "No Prior" (10)            | q_g + dq (Q)         | predicted by Q           | fresh, trained |
/// | `tune-prior`    | "Tune theta_2 + theta_3" (10) | q_g + dq (Q)      | predicted by Q           | prior, trained |
///
///  * direct: Q's point rows get the ordinary He initialisation of the head (not zero), so q_l'
///    starts as a random function of q_g of about unit size, not near q_g: without the residual
///    connection of eq. 3 nothing makes Q start at the identity, which is what the paper ablates.
///  * free-code: one C-vector per shape, shared by every query, initialised N(0, 1/C) (DeepSDF's
///    code initialisation) and optimised by Adam together with Q, same learning rate.
///  * pointnet-code: the cloud (unit box) is split with the prior's own region grid and
///    normalisation (prior.regions); each region's condition is the frozen encoder applied to all
///    of its points in region coordinates (computed once). A query takes the condition of the
///    grid cell that contains it (clamped to the grid); a cell without a region (too few points)
///    takes the region whose cell is nearest (cell-index distance, then lowest index).
///  * no-prior: F has the prior's shape but is freshly initialised (geometric, seeded); without a
///    prior file no self-prior is trained. Both no-prior and tune-prior train F with Q by Adam,
///    same learning rate, through the per-query double backprop (nn::decoder_double_backward).
enum class QueryAblation { None, NoShift, Direct, FreeCode, PointNetCode, NoPrior, TunePrior };

/// "none" | "no-shift" | "direct" | "free-code" | "pointnet-code" | "no-prior" | "tune-prior";
/// throws pcp::Error (listing the names) on anything else.
QueryAblation parse_query_ablation(const std::string& name);
std::string to_string(QueryAblation ablation);

struct QueryFitOptions {
    SamplingOptions sampling;        ///< global queries around the cloud (paper: 40 per point)
    int width = 512;                 ///< Q's width (paper: 512)
    int depth = 8;                   ///< Q's hidden layers (paper: 8)
    int queries_per_step = 400;      ///< batch (release: 400)
    std::int64_t steps = 100000;     ///< (release: about 100,000)
    double learning_rate = 1e-4;     ///< Adam (release: 1e-4)
    LrScheduleKind schedule = LrScheduleKind::Constant;
    std::int64_t warmup_steps = 0;
    double clip_norm = 0.0;
    bool zero_shift_init = true;     ///< start with dq = 0 (q_l' = q_g); modes with a shift only
    QueryAblation ablation = QueryAblation::None;  ///< the paper's ablations (see above)
    std::uint64_t seed = 1;
    std::int64_t progress_every = 100;
    std::string checkpoint_path;     ///< "" = no checkpoints
    std::int64_t checkpoint_every = 2000;
    bool resume = false;             ///< reconstruct(): continue from checkpoint_path if it exists
    ProgressCallback progress;       ///< stage "query-net"; false = stop (a checkpoint is written)
};

/// The resumable stage-2 fitter (F frozen, or trained with Q in the no-prior / tune-prior
/// ablations). Works in the unit box of the given cloud. Checkpoints hold Q, its Adam state, and
/// the mode's extra state (F and its Adam state when trained; the free code and its Adam state).
class QueryNetFitter {
public:
    /// @param[in] points  N x 3 input cloud (input frame); checked and normalised here.
    QueryNetFitter(const Eigen::Ref<const Points>& points, const LocalPrior& prior, const QueryFitOptions& options);
    ~QueryNetFitter();

    bool run();       ///< steps until done or cancelled (false)
    double step();    ///< one step; its loss
    std::int64_t steps_done() const;
    double recent_loss() const;

    void checkpoint(const std::string& path) const;
    void resume(const std::string& path);

    /// The global SDF at `unit_points` (N x 3, unit box). Thread-safe; OpenMP-parallel over batches.
    void sdf(const Eigen::Ref<const PointsF>& unit_points, Eigen::Ref<Eigen::VectorXf> values) const;

    const Normalization& normalization() const;
    const PointsF& unit_points() const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

struct ReconstructOptions {
    DenoiseOptions denoise;          ///< optional plane-projection denoising of the input (off; not in the paper)
    PriorTrainOptions self_prior = PriorTrainOptions::preset("fast");  ///< used when no prior is given
    QueryFitOptions fit;
    int resolution = 128;            ///< marching-cubes cells along the longest axis (paper: 128 / 512)
    double margin = 0.05;            ///< added around the cloud's unit box on every side (paper: 0.05)
    double iso = 0.0;
    SdfGridOptions grid;             ///< narrow-band settings
    SignRepairOptions sign_repair;   ///< flip regions whose sign the data does not support (not in the paper)
    /// Evaluate the fitted SDF for meshing and for the sign repair with fp32 products even when
    /// the process runs bf16 (nn::set_gemm_precision; the training stays bf16). The grid is a small
    /// part of the time; bf16 rounding in the evaluation roughens the extracted surface. While it
    /// runs, reconstruct() sets the process-wide precision to fp32 and restores it afterwards.
    bool fp32_grid = true;
    ProgressCallback progress;       ///< forwarded to every stage ("prior", "query-net", "sdf-grid")

    /// Named presets: "paper", "default", "fast". Throws pcp::Error for other names.
    static ReconstructOptions preset(const std::string& name);
};

struct ReconstructReport {
    double seconds_denoise = 0, seconds_prior = 0, seconds_fit = 0, seconds_grid = 0, seconds_mesh = 0;
    double prior_loss = 0, fit_loss = 0;
    std::int64_t fit_steps = 0;
    int denoise_passes = 0;          ///< passes applied to the input (DenoiseOptions; resolved when automatic)
    std::int64_t sdf_evaluations = 0;  ///< fine grid, plus the sign repair's coarse grid
    SignRepairStats sign_repair;
    bool sign_flipped = false;       ///< the fitted SDF was negated so that the outside is positive
    bool closed = false;             ///< every edge of the mesh is shared by exactly two faces
    bool cancelled = false;
};

/// Point cloud (input frame) -> mesh (input frame, outward faces). With `prior` null a self-prior
/// is trained on the cloud first (options.self_prior), except in the no-prior ablation, which only
/// takes the network sizes from options.self_prior.
Mesh reconstruct(const Eigen::Ref<const Points>& points, const LocalPrior* prior, const ReconstructOptions& options,
                 ReconstructReport* report = nullptr);

/// True if every undirected edge of `mesh` belongs to exactly two faces, traversed in opposite
/// directions (closed, manifold along edges, consistently oriented).
bool is_closed_and_oriented(const Mesh& mesh);

}  // namespace pcp
