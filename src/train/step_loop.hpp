// The step loop shared by the resumable trainers (PriorTrainer, QueryNetFitter): steps until the
// planned total, reports progress every progress_every steps, checkpoints every checkpoint_every
// steps, and when the progress callback asks to stop, writes a checkpoint and returns false.
#pragma once

#include "pcp/core/progress.hpp"

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <string>

namespace pcp::detail {

struct StepLoopOptions {
    const char* stage = "";
    std::int64_t total = 0;
    std::int64_t progress_every = 1;
    std::int64_t checkpoint_every = 0;  ///< 0 = only when stopped
    std::string checkpoint_path;        ///< "" = no checkpoints
    ProgressCallback progress;
};

/// `trainer` provides step(), steps_done(), recent_loss() and checkpoint(path).
/// @return true when all steps are done, false when the callback stopped the run.
template <class Trainer>
bool run_step_loop(Trainer& trainer, const StepLoopOptions& o) {
    const auto start = std::chrono::steady_clock::now();
    const std::int64_t first = trainer.steps_done();
    auto report = [&]() {
        if (!o.progress) return true;
        Progress p;
        p.stage = o.stage;
        p.step = trainer.steps_done();
        p.total = o.total;
        p.loss = trainer.recent_loss();
        p.elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        p.step_offset = first;
        return o.progress(p);
    };
    if (!report()) return false;
    while (trainer.steps_done() < o.total) {
        trainer.step();
        const std::int64_t done = trainer.steps_done();
        if (!o.checkpoint_path.empty() && o.checkpoint_every > 0 && done % o.checkpoint_every == 0)
            trainer.checkpoint(o.checkpoint_path);
        if (done % std::max<std::int64_t>(1, o.progress_every) == 0 || done == o.total) {
            if (!report()) {
                if (!o.checkpoint_path.empty()) trainer.checkpoint(o.checkpoint_path);
                return false;
            }
        }
    }
    return true;
}

}  // namespace pcp::detail
