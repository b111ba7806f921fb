// Stage 2 of PCP (METHOD.md sections 2-4, paper section 3 "Predictive Context Prior"): with the
// prior's decoder F frozen, fit the query network Q(q_g) -> (dq, f') so that the global SDF
// F_g(q_g) = F(q_g + dq, f') pulls the queries onto the cloud (Neural-Pull loss); and the paper's
// ablations of this stage (tables 9-10).
#pragma once

#include "pcp/cloud/prepared_cloud.hpp"
#include "pcp/cloud/sampling.hpp"
#include "pcp/cloud/visibility.hpp"
#include "pcp/core/types.hpp"
#include "pcp/train/prior.hpp"
#include "pcp/train/schedule.hpp"

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

/// The sign guide (not in the paper; pcp/cloud/visibility.hpp): during the first until x steps,
/// each step adds round(fraction x queries_per_step) queries drawn in the cells that visibility
/// labels inside or outside, with the loss weight x mean relu(-label x F_g)
/// (nn::Stage2Workspace::guided). The pulling loss cannot tell a field from its negative; this tells
/// the fit which side is which wherever the cloud alone can tell. Nothing is guided when no cell is
/// labelled. Measured and left off (docs/BENCHMARKS.md, "Visibility labels"): over three seeds it
/// did not make the fit's outcome more stable, and it cost abc_00016513 about 15 % of L2-CD.
struct SignGuideOptions {
    bool enabled = false;        ///< off by default (measured, not adopted)
    double fraction = 0.1;       ///< guided queries per step, x queries_per_step (0, 1]
    double weight = 1.0;         ///< of the hinge against the pulling loss (> 0)
    double until = 0.2;          ///< guide the first until x steps only (0, 1]
    VisibilityOptions visibility;  ///< the labels, when the fitter is not given them
};

/// Stop when converged instead of after a fixed count (not in the paper). Every `window` steps
/// the fit compares the window's mean loss with the previous window's; once the relative decrease
/// is below `tolerance` (and at least min_steps are done), a cooldown of cooldown_fraction x the
/// steps done (at least min_cooldown) follows and the fit stops there. QueryFitOptions::steps
/// stays the cap. With a cosine schedule (the presets') the rates are the schedule's own until the
/// plateau and the rest of its decay runs in the cooldown (nn::LrSchedule::compress_from); without
/// a plateau the fit is exactly the schedule's. With a constant rate, the peak rate until the
/// plateau, then cosine to 0.02 x over the cooldown (placed to end at the cap when no plateau
/// comes). Measured against the peak-rate-until-the-plateau form in docs/BENCHMARKS.md ("The stop
/// rule on the preset's own schedule").
struct StopRule {
    bool enabled = false;
    std::int64_t window = 200;
    double tolerance = 0.01;
    std::int64_t min_steps = 400;
    double cooldown_fraction = 0.25;
    std::int64_t min_cooldown = 200;
};

struct QueryFitOptions {
    SamplingOptions sampling;        ///< global queries around the cloud (paper: 40 per point)
    int width = 512;                 ///< Q's width (paper: 512)
    int depth = 8;                   ///< Q's hidden layers (paper: 8)
    int queries_per_step = 400;      ///< batch (release: 400)
    /// Not in the paper (speed only): the step's batch in this many parts, one thread each
    /// (nn::Stage2Trainer::batch_parts; 0 = one per thread, 1 = the whole batch with its products
    /// split over the threads). The same loss and gradient up to rounding.
    int batch_parts = 0;
    std::int64_t steps = 100000;     ///< (release: about 100,000)
    /// Adam (release: lr 1e-4, constant), seed, progress (stage "query-net"), checkpoints, resume.
    TrainingSchedule schedule = TrainingSchedule::every(100, 2000);
    bool zero_shift_init = true;     ///< start with dq = 0 (q_l' = q_g); modes with a shift only
    QueryAblation ablation = QueryAblation::None;  ///< the paper's ablations (see above)
    SignGuideOptions sign_guide;     ///< not in the paper (see above)
    StopRule stop;                   ///< not in the paper (see above); off: exactly `steps` steps
};

/// The resumable stage-2 fitter (F frozen, or trained with Q in the no-prior / tune-prior
/// ablations). Works in the unit box of the given cloud. Checkpoints hold Q, its Adam state, and
/// the mode's extra state (F and its Adam state when trained; the free code and its Adam state).
class QueryNetFitter {
public:
    /// @param[in] cloud  the input, prepared (checked, in the unit box, indexed); must outlive the fitter.
    /// @param[in] labels  visibility labels of the cloud for the sign guide (copied), or null: then
    ///                    computed here with options.sign_guide.visibility when the guide is on.
    QueryNetFitter(const PreparedCloud& cloud, const LocalPrior& prior, const QueryFitOptions& options,
                   const VisibilityLabels* labels = nullptr);
    /// Several clouds, one query network (paper, "Optimization": multiple point clouds with one-hot
    /// vectors as the condition of each q_g): Q(q_g, e_k) for the queries of cloud k, each cloud in
    /// its own unit box. Each step draws its queries from the clouds in equal shares (a cloud per
    /// query, uniformly; then one of its pool's queries); each cloud's pool holds at most its share
    /// of the draws. One cloud is exactly the single-cloud fitter (no code branch). With several,
    /// only the method (ablation none) and no sign guide: refused otherwise.
    /// @param[in] clouds  prepared clouds (at least one, none null); they must outlive the fitter.
    QueryNetFitter(const std::vector<const PreparedCloud*>& clouds, const LocalPrior& prior,
                   const QueryFitOptions& options);
    ~QueryNetFitter();

    /// Steps until done or cancelled (false); first continues from the checkpoint when
    /// options.schedule.resume is set and the file exists.
    bool run();
    double step();    ///< one step; its loss
    std::int64_t steps_done() const;
    double recent_loss() const;

    void checkpoint(const std::string& path) const;
    void resume(const std::string& path);

    /// The global SDF at `unit_points` (N x 3, unit box). Thread-safe; OpenMP-parallel over batches.
    void sdf(const Eigen::Ref<const PointsF>& unit_points, Eigen::Ref<Eigen::VectorXf> values) const;
    /// The global SDF of cloud `index` (its one-hot code) at points of its unit box.
    void sdf(int index, const Eigen::Ref<const PointsF>& unit_points, Eigen::Ref<Eigen::VectorXf> values) const;

    const PreparedCloud& cloud() const;  ///< the first cloud
    const PreparedCloud& cloud(int index) const;
    int num_clouds() const;
    /// Guided queries per step (0: the guide is off or labelled nothing).
    int guided_per_step() const;
    /// Queries in the pool the steps draw from: at most steps x queries_per_step (SamplingOptions::max_queries).
    std::int64_t pool_size() const;
    /// The steps the fit will end at: options.steps, or with the stop rule the end of its cooldown
    /// once a plateau was found (at most options.steps).
    std::int64_t planned_steps() const;
    /// The step at which the stop rule found the plateau (-1: not found, or the rule is off).
    std::int64_t plateau_step() const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace pcp
