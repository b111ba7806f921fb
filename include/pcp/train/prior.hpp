// Stage 1 of PCP (METHOD.md sections 1-5, paper section 3 "Local Context Prior"): learning the local
// context prior -- the PointNet encoder (theta_1) and the local SDF decoder F (theta_2) -- from the
// local regions of one or more point clouds with the Neural-Pull loss. Each step takes one region,
// draws queries_per_step of its queries, encodes their nearest points into the condition f, and
// takes one Adam step through the double backprop of the pulling loss.
//
// The trainer is deterministic given (clouds, options): the region order of each epoch and the
// queries of each step come from RNG streams derived from (seed, epoch) and (seed, step), so a run
// resumed from a checkpoint ends with exactly the weights of an uninterrupted run (one thread).
#pragma once

#include "pcp/cloud/prepared_cloud.hpp"
#include "pcp/cloud/regions.hpp"
#include "pcp/cloud/sampling.hpp"
#include "pcp/core/types.hpp"
#include "pcp/train/schedule.hpp"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace pcp {

namespace nn {
template <class S>
struct PointNet;
template <class S>
struct BranchMlp;
}  // namespace nn

/// Sizes of the prior's networks (METHOD.md section 2).
struct PriorNetworkOptions {
    int width = 512;           ///< H: width of F's branches and hidden layers (paper: 512)
    int depth = 8;             ///< L: F's hidden layers (paper: 8)
    int condition = 256;       ///< C: condition size (paper: 512, release: 256)
    int pointnet_width = 1024; ///< PointNet's per-point layer width (release: one 3 -> 1024 layer)
    int pointnet_hidden = 512; ///< PointNet head's hidden width (1024 -> 512 -> C)
};

class LocalPrior;

struct PriorTrainOptions {
    RegionOptions regions;           ///< grid 6, normalisation both (paper)
    SamplingOptions sampling;        ///< 40 queries per point at 0.5 sigma_p (paper / release)
    PriorNetworkOptions network;
    int queries_per_step = 2000;     ///< queries of one region per step (paper: 2000)
    int epochs = 500;                ///< passes over all regions, one step per region (release: 500)
    std::int64_t max_steps = 0;      ///< if > 0, stop after this many steps instead
    /// Adam (release: lr 1e-4, constant), seed, progress (stage "prior"), checkpoints, resume.
    TrainingSchedule schedule = TrainingSchedule::every(50, 1000);
    /// If set, training starts from this prior's weights (fine-tuning, e.g. the built-in prior on
    /// the input: ReconstructOptions::prior_tune_steps); its network sizes and region settings
    /// replace `network` and `regions`.
    std::shared_ptr<const LocalPrior> start;

    /// Named presets: "paper" (the paper's sizes and schedule), "default", "fast" (the self-prior
    /// preset used by pcp_reconstruct when no prior is given). Throws pcp::Error for other names.
    static PriorTrainOptions preset(const std::string& name);
};

/// Where a prior came from.
struct PriorProvenance {
    std::vector<std::string> inputs;
    std::string settings;          ///< a one-line summary of the options
    std::int64_t steps = 0;
    double final_loss = 0.0;       ///< mean loss over the last epoch (or the last steps)
    std::string library_version;
};

/// A trained local context prior: the encoder, the decoder F, and the settings needed to use it.
class LocalPrior {
public:
    LocalPrior();
    LocalPrior(const PriorNetworkOptions& network, std::uint64_t seed);  ///< freshly initialised
    LocalPrior(const LocalPrior&);
    LocalPrior(LocalPrior&&) noexcept;
    LocalPrior& operator=(const LocalPrior&);
    LocalPrior& operator=(LocalPrior&&) noexcept;
    ~LocalPrior();

    const nn::PointNet<float>& encoder() const;
    const nn::BranchMlp<float>& decoder() const;
    nn::PointNet<float>& encoder();
    nn::BranchMlp<float>& decoder();

    PriorNetworkOptions network;
    RegionOptions regions;
    SamplingOptions sampling;
    PriorProvenance provenance;

    /// SDF values of F at `points` (N x 3, region coordinates) for the condition of `context`
    /// (M x 3, region coordinates, e.g. the region's points): s = F(q, PointNet(context)).
    Eigen::VectorXf sdf(const Eigen::Ref<const PointsF>& points, const Eigen::Ref<const PointsF>& context) const;

    /// The queries pulled onto F's zero set, p = q - s g/|g| (METHOD.md section 3), for the
    /// condition of `context`; all N x 3 / M x 3 in region coordinates.
    PointsF pull(const Eigen::Ref<const PointsF>& queries, const Eigen::Ref<const PointsF>& context) const;

private:
    struct Nets;
    std::unique_ptr<Nets> nets_;
};

/// Writes `prior` atomically to `path` (format: see src/train/prior_io.cpp).
void save_prior(const std::string& path, const LocalPrior& prior);
/// Reads a prior; a file of another format version, a truncated or corrupt file is refused with a
/// pcp::Error naming the file and the problem.
LocalPrior load_prior(const std::string& path);

/// A cloud to learn from: points in any frame plus a name for messages and provenance.
struct TrainingCloud {
    std::string name;
    Points points;
};

/// The resumable stage-1 trainer.
class PriorTrainer {
public:
    /// Prepares the regions and query pools of every cloud (throws pcp::Error, naming the cloud,
    /// for degenerate clouds; and if no region has options.regions.min_points points).
    PriorTrainer(const std::vector<TrainingCloud>& clouds, const PriorTrainOptions& options);
    /// One cloud already prepared (pcp::reconstruct's self-prior): not checked or normalised again.
    PriorTrainer(const PreparedCloud& cloud, const PriorTrainOptions& options);
    ~PriorTrainer();

    /// Restores weights, Adam state and the step counter from a checkpoint written by this trainer
    /// for the same clouds and options (refused otherwise).
    void resume(const std::string& checkpoint_path);
    /// Writes the training state atomically.
    void checkpoint(const std::string& path) const;

    /// Runs steps until the planned total or until the progress callback returns false; first
    /// continues from the checkpoint when options.schedule.resume is set and the file exists.
    /// @return true when all steps are done, false when stopped early.
    bool run();
    /// One step; returns its loss.
    double step();

    std::int64_t steps_done() const;
    std::int64_t total_steps() const;
    std::size_t num_regions() const;
    /// Queries in all region pools: each holds at most the queries its steps draw (SamplingOptions::max_queries).
    std::int64_t pool_size() const;
    double recent_loss() const;   ///< mean loss of the last min(regions, 100) steps
    LocalPrior prior() const;     ///< the current networks with provenance filled in

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

/// One-shot: trains a prior on `clouds` with `options`.
LocalPrior train_prior(const std::vector<TrainingCloud>& clouds, const PriorTrainOptions& options);

}  // namespace pcp
