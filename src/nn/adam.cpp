// Adam, learning-rate schedules and gradient clipping (see pcp/nn/adam.hpp).
#include "pcp/nn/adam.hpp"

#include "pcp/core/error.hpp"

#include <algorithm>
#include <cmath>

#include <omp.h>

namespace pcp::nn {

namespace {
/// Below this many parameters one thread does the step (a parallel region costs more).
constexpr Eigen::Index kAdamParallelMin = 32768;
}  // namespace

template <class S>
void adam_step(VecRef<S> params, const CVecRef<S>& grads, AdamState<S>& st, double lr,
               const AdamOptions& o) {
    const Eigen::Index n = params.size();
    PCP_CHECK(grads.size() == n && st.m.size() == n && st.v.size() == n,
              "nn::adam_step: sizes differ: params " << n << ", grads " << grads.size()
                                                     << ", moments " << st.m.size());
    st.t += 1;
    const double bc1 = 1.0 - std::pow(o.beta1, double(st.t));
    const double bc2 = 1.0 - std::pow(o.beta2, double(st.t));
    // Folded form: p -= step_size * m / (sqrt(v) * inv_sqrt_bc2 + eps).
    const S b1 = S(o.beta1), b2 = S(o.beta2);
    const S step_size = S(lr / bc1);
    const S inv_sqrt_bc2 = S(1.0 / std::sqrt(bc2));
    const S eps = S(o.eps);
    // In chunks that stay in L1, as Eigen array expressions (packet sqrt and division: the scalar
    // loop's std::sqrt kept GCC from vectorising it), split over the threads for large vectors;
    // each entry's arithmetic is the same whatever the split.
    constexpr Eigen::Index kChunk = 2048;
    const auto chunk = [&](Eigen::Index c) {
        const Eigen::Index lo = c * kChunk, len = std::min(kChunk, n - lo);
        auto m = st.m.segment(lo, len).array();
        auto v = st.v.segment(lo, len).array();
        const auto g = grads.segment(lo, len).array();
        m = b1 * m + (S(1) - b1) * g;
        v = b2 * v + (S(1) - b2) * g.square();
        params.segment(lo, len).array() -= step_size * m / (v.sqrt() * inv_sqrt_bc2 + eps);
    };
    const Eigen::Index chunks = (n + kChunk - 1) / kChunk;
    const int threads = n >= kAdamParallelMin ? std::max(1, Eigen::nbThreads()) : 1;
    if (threads > 1) {
#pragma omp parallel for schedule(static) num_threads(threads)
        for (Eigen::Index c = 0; c < chunks; ++c) chunk(c);
    } else {  // no parallel region at all: even a one-thread region allocates its team
        for (Eigen::Index c = 0; c < chunks; ++c) chunk(c);
    }
}

double LrSchedule::at(std::int64_t step) const {
    PCP_CHECK(step >= 0, "nn::LrSchedule: negative step");
    if (warmup_steps > 0 && step < warmup_steps) return lr * double(step + 1) / double(warmup_steps);
    switch (kind) {
        case Kind::Constant:
            return lr;
        case Kind::Cosine: {
            const std::int64_t start = warmup_steps;
            const double t = double(step);
            if (t < double(start)) return lr;
            const double span = double(std::max<std::int64_t>(total_steps - start, 1));
            const double x = std::min(1.0, (t - double(start)) / span);
            return final_lr + 0.5 * (lr - final_lr) * (1.0 + std::cos(3.14159265358979323846 * x));
        }
    }
    return lr;
}

template <class S>
double clip_grad_norm(std::initializer_list<Vec<S>*> grads, double max_norm) {
    double sq = 0.0;
    for (const Vec<S>* g : grads) sq += double(g->squaredNorm());
    const double norm = std::sqrt(sq);
    if (max_norm > 0.0 && norm > max_norm) {
        const S scale = S(max_norm / norm);
        for (Vec<S>* g : grads) *g *= scale;
    }
    return norm;
}

template void adam_step<float>(VecRef<float>, const CVecRef<float>&, AdamState<float>&, double,
                               const AdamOptions&);
template void adam_step<double>(VecRef<double>, const CVecRef<double>&, AdamState<double>&,
                                double, const AdamOptions&);
template double clip_grad_norm<float>(std::initializer_list<Vec<float>*>, double);
template double clip_grad_norm<double>(std::initializer_list<Vec<double>*>, double);

}  // namespace pcp::nn
