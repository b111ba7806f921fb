// Optimisation of a flat parameter vector: Adam with bias correction (vectorised, in chunks split over the threads),
// learning-rate schedules (constant, cosine; both with optional linear warm-up) and gradient-norm clipping over several gradient vectors at once.
#pragma once

#include "pcp/nn/common.hpp"

#include <cstdint>
#include <initializer_list>

namespace pcp::nn {

struct AdamOptions {
    double beta1 = 0.9;
    double beta2 = 0.999;
    double eps = 1e-8;
};

/// Adam's moments for one flat parameter vector, and the number of steps taken.
template <class S>
struct AdamState {
    Vec<S> m;  ///< first moment, same layout as the parameters
    Vec<S> v;  ///< second moment
    std::int64_t t = 0;

    AdamState() = default;
    explicit AdamState(Eigen::Index n) : m(Vec<S>::Zero(n)), v(Vec<S>::Zero(n)) {}
};

/// One Adam step with bias correction:
///   m = b1 m + (1-b1) g;  v = b2 v + (1-b2) g^2;  t += 1;
///   p -= lr * (m / (1 - b1^t)) / (sqrt(v / (1 - b2^t)) + eps).
template <class S>
void adam_step(VecRef<S> params, const CVecRef<S>& grads, AdamState<S>& state, double lr,
               const AdamOptions& opts = {});

/// Learning rate as a function of the step (0-based).
struct LrSchedule {
    enum class Kind { Constant, Cosine };
    Kind kind = Kind::Constant;
    double lr = 1e-4;                ///< base (peak) rate
    std::int64_t warmup_steps = 0;   ///< linear warm-up from lr/warmup_steps to lr
    std::int64_t total_steps = 0;    ///< Cosine: decays from lr to final_lr over these steps
    double final_lr = 0.0;           ///< Cosine: rate at total_steps and after

    double at(std::int64_t step) const;
};

/// Scales all gradient vectors by min(1, max_norm / ||(g_1, g_2, ...)||) and returns the norm
/// before clipping. max_norm <= 0 only measures.
template <class S>
double clip_grad_norm(std::initializer_list<Vec<S>*> grads, double max_norm);

}  // namespace pcp::nn
