// The settings both trainers share (stage 1, PriorTrainer; stage 2, QueryNetFitter): the Adam
// learning rate and its schedule, clipping, the seed of every random draw, progress reports and
// checkpoints. Each trainer's options embed one `TrainingSchedule`; the loop that uses it lives in
// src/train/scaffold.hpp.
#pragma once

#include "pcp/core/progress.hpp"

#include <cstdint>
#include <string>

namespace pcp {

enum class LrScheduleKind { Constant, Cosine };

/// "constant" | "cosine"; throws pcp::Error on anything else.
LrScheduleKind parse_lr_schedule(const std::string& name);
std::string to_string(LrScheduleKind kind);

struct TrainingSchedule {
    double learning_rate = 1e-4;     ///< Adam's peak rate (paper / release: 1e-4)
    LrScheduleKind lr_schedule = LrScheduleKind::Constant;  ///< cosine decays to 0.02 x the rate
    std::int64_t warmup_steps = 0;   ///< linear warm-up from learning_rate / warmup_steps
    double clip_norm = 0.0;          ///< global gradient-norm clipping; 0 = off
    std::uint64_t seed = 1;          ///< every draw of the trainer derives from it
    std::int64_t progress_every = 100;     ///< steps between progress callbacks
    std::string checkpoint_path;           ///< "" = no checkpoints
    std::int64_t checkpoint_every = 2000;  ///< steps between checkpoints (0 = only when stopped)
    /// run(): continue from checkpoint_path when that file exists (refused if it was written for
    /// other inputs or settings); start from step 0 when it does not.
    bool resume = false;
    ProgressCallback progress;       ///< false = stop (a checkpoint is written when a path is set)

    /// The defaults above with other report and checkpoint intervals.
    static TrainingSchedule every(std::int64_t progress_steps, std::int64_t checkpoint_steps) {
        TrainingSchedule s;
        s.progress_every = progress_steps;
        s.checkpoint_every = checkpoint_steps;
        return s;
    }
};

}  // namespace pcp
