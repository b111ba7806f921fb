// The training scaffold both trainers are built on (stage 1, src/train/prior.cpp; stage 2,
// src/train/query_fit.cpp): the optimiser assembled from a TrainingSchedule, the seeded batch
// draw from a query pool, the window of recent losses, the checkpoint header (format tag and
// fingerprint, checked on resume) and the step loop with progress, checkpoints and resume.
#pragma once

#include "pcp/core/error.hpp"
#include "pcp/core/progress.hpp"
#include "pcp/core/rng.hpp"
#include "pcp/nn/checkpoint.hpp"
#include "pcp/nn/metadata.hpp"
#include "pcp/nn/steps.hpp"
#include "pcp/train/schedule.hpp"

#include <chrono>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <functional>
#include <string>

namespace pcp::detail {

using MatF = nn::Mat<float>;

/// Adam with the schedule's rate: constant, or cosine from the rate to 0.02 x the rate over
/// total_steps, after a linear warm-up; clipping as set.
nn::OptimOptions make_optim(const TrainingSchedule& schedule, std::int64_t total_steps);

/// Fills the columns of q and t (3 x n) with pool columns drawn with replacement by `rng`.
void draw_batch(const MatF& pool_queries, const MatF& pool_targets, Rng rng, Eigen::Ref<MatF> q, Eigen::Ref<MatF> t);

/// Throws "<stage>: the loss became <loss> at step <step>; ..." for a non-finite loss.
void check_loss(double loss, const char* stage, std::int64_t step);

/// The mean of the last `capacity` losses.
class LossWindow {
public:
    explicit LossWindow(std::size_t capacity = 100) : capacity_(capacity) {}
    void push(double loss);
    double mean() const;  ///< 0 when empty
    void clear() { losses_.clear(); }
    /// The window as a metadata value (exact: hexadecimal doubles), and back; a checkpoint keeps
    /// it so that a resumed run reports the same recent loss as an uninterrupted one.
    std::string text() const;
    /// Restores text() of a checkpoint; throws pcp::Error naming `source` for a malformed value.
    void restore(const std::string& text, const std::string& source);

private:
    std::size_t capacity_;
    std::deque<double> losses_;
};

/// What a trainer's checkpoint identifies itself by: a format tag and a fingerprint of its
/// inputs and settings.
struct CheckpointId {
    const char* format;        ///< e.g. "pcp-prior-checkpoint 1"
    std::string fingerprint;   ///< inputs + settings
    const char* what;          ///< "prior-training", "query-network"
};

/// A checkpoint's metadata, starting with the format tag and the fingerprint.
nn::Metadata checkpoint_metadata(const CheckpointId& id);
/// Loads `path` and checks its format tag and fingerprint against `id` (refused with one line
/// naming the file otherwise); the file's step must not exceed `total_steps`.
nn::NetFile<float> load_checkpoint(const std::string& path, const CheckpointId& id, std::int64_t total_steps,
                                   nn::Metadata* metadata = nullptr);

/// The step loop of both trainers. `trainer` provides step(), steps_done(), recent_loss(),
/// checkpoint(path) and resume(path). With schedule.resume it first continues from
/// schedule.checkpoint_path when that file exists. Then it steps until `total`, reports progress
/// every progress_every steps, writes a checkpoint every checkpoint_every steps, and when the
/// progress callback asks to stop, writes a checkpoint and returns false.
template <class Trainer>
bool run_step_loop(Trainer& trainer, const char* stage, std::int64_t total, const TrainingSchedule& s) {
    if (s.resume && !s.checkpoint_path.empty() && std::filesystem::exists(s.checkpoint_path) && trainer.steps_done() == 0)
        trainer.resume(s.checkpoint_path);
    const auto start = std::chrono::steady_clock::now();
    const std::int64_t first = trainer.steps_done();
    auto report = [&]() {
        if (!s.progress) return true;
        Progress p;
        p.stage = stage;
        p.step = trainer.steps_done();
        p.total = total;
        p.loss = trainer.recent_loss();
        p.has_loss = true;
        p.elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        p.step_offset = first;
        return s.progress(p);
    };
    if (!report()) return false;
    while (trainer.steps_done() < total) {
        trainer.step();
        const std::int64_t done = trainer.steps_done();
        if (!s.checkpoint_path.empty() && s.checkpoint_every > 0 && done % s.checkpoint_every == 0)
            trainer.checkpoint(s.checkpoint_path);
        if (done % std::max<std::int64_t>(1, s.progress_every) == 0 || done == total) {
            if (!report()) {
                if (!s.checkpoint_path.empty()) trainer.checkpoint(s.checkpoint_path);
                return false;
            }
        }
    }
    return true;
}

}  // namespace pcp::detail
