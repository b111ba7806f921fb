// Stage 2 of PCP (METHOD.md sections 2-4, paper section 3 "Predictive Context Prior"): with the
// prior's decoder F frozen, fit the query network Q(q_g) -> (dq, f') so that the global SDF
// F_g(q_g) = F(q_g + dq, f') pulls the queries onto the cloud (Neural-Pull loss); and the paper's
// ablations of this stage (tables 9-10).
#pragma once

#include "pcp/cloud/prepared_cloud.hpp"
#include "pcp/cloud/sampling.hpp"
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
};

/// The resumable stage-2 fitter (F frozen, or trained with Q in the no-prior / tune-prior
/// ablations). Works in the unit box of the given cloud. Checkpoints hold Q, its Adam state, and
/// the mode's extra state (F and its Adam state when trained; the free code and its Adam state).
class QueryNetFitter {
public:
    /// @param[in] cloud  the input, prepared (checked, in the unit box, indexed); must outlive the fitter.
    QueryNetFitter(const PreparedCloud& cloud, const LocalPrior& prior, const QueryFitOptions& options);
    /// Several clouds, one query network (paper, "Optimization": multiple point clouds with one-hot
    /// vectors as the condition of each q_g): Q(q_g, e_k) for the queries of cloud k, each cloud in
    /// its own unit box. Each step draws its queries from the clouds in equal shares (a cloud per
    /// query, uniformly; then one of its pool's queries); each cloud's pool holds at most its share
    /// of the draws. One cloud is exactly the single-cloud fitter (no code branch). With several,
    /// only the method (ablation none): refused otherwise.
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
    /// Queries in the pool the steps draw from: at most steps x queries_per_step (SamplingOptions::max_queries).
    std::int64_t pool_size() const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace pcp
