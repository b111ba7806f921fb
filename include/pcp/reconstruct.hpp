// Stage 2 of PCP and meshing (METHOD.md sections 2-5, paper section 3 "Predictive Context Prior"):
// with the prior's decoder F frozen, fit the query network Q(q_g) -> (dq, f') so that the global
// SDF F_g(q_g) = F(q_g + dq, f') pulls the queries onto the cloud (Neural-Pull loss); then evaluate
// F_g on a narrow-band grid, extract the zero level set with marching cubes, orient it outward and
// map it back to the input's frame.
#pragma once

#include "pcp/normalize.hpp"
#include "pcp/prior.hpp"
#include "pcp/progress.hpp"
#include "pcp/sampling.hpp"
#include "pcp/sdf_grid.hpp"
#include "pcp/types.hpp"

#include <cstdint>
#include <memory>
#include <string>

namespace pcp {

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
    bool zero_shift_init = true;     ///< start with dq = 0 (q_l' = q_g)
    std::uint64_t seed = 1;
    std::int64_t progress_every = 100;
    std::string checkpoint_path;     ///< "" = no checkpoints
    std::int64_t checkpoint_every = 2000;
    bool resume = false;             ///< reconstruct(): continue from checkpoint_path if it exists
    ProgressCallback progress;       ///< stage "query-net"; false = stop (a checkpoint is written)
};

/// The resumable stage-2 fitter (F frozen). Works in the unit box of the given cloud.
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
    PriorTrainOptions self_prior = PriorTrainOptions::preset("fast");  ///< used when no prior is given
    QueryFitOptions fit;
    int resolution = 128;            ///< marching-cubes cells along the longest axis (paper: 128 / 512)
    double margin = 0.05;            ///< added around the cloud's unit box on every side (paper: 0.05)
    double iso = 0.0;
    SdfGridOptions grid;             ///< narrow-band settings
    ProgressCallback progress;       ///< forwarded to every stage ("prior", "query-net", "sdf-grid")

    /// Named presets: "paper", "default", "fast". Throws pcp::Error for other names.
    static ReconstructOptions preset(const std::string& name);
};

struct ReconstructReport {
    double seconds_prior = 0, seconds_fit = 0, seconds_grid = 0, seconds_mesh = 0;
    double prior_loss = 0, fit_loss = 0;
    std::int64_t fit_steps = 0;
    std::int64_t sdf_evaluations = 0;
    bool sign_flipped = false;       ///< the fitted SDF was negated so that the outside is positive
    bool closed = false;             ///< every edge of the mesh is shared by exactly two faces
    bool cancelled = false;
};

/// Point cloud (input frame) -> mesh (input frame, outward faces). With `prior` null a self-prior
/// is trained on the cloud first (options.self_prior).
Mesh reconstruct(const Eigen::Ref<const Points>& points, const LocalPrior* prior, const ReconstructOptions& options,
                 ReconstructReport* report = nullptr);

/// True if every undirected edge of `mesh` belongs to exactly two faces, traversed in opposite
/// directions (closed, manifold along edges, consistently oriented).
bool is_closed_and_oriented(const Mesh& mesh);

}  // namespace pcp
