// Benchmark of the neural core: steps/s, queries/s and GFLOP/s of the stage-1 and stage-2 training
// steps at the paper's sizes (H = 512, L = 8, C = 256 and 512; batch 400, 2000, 5000; 1 and 2
// threads), for every GEMM back end of the build side by side (nn::gemm with Eigen, and with
// OpenBLAS when built), next to each back end's SGEMM rate measured in the same run (512 x 512
// times 512 x N; also Eigen's own `C.noalias() = A * B` for reference), and the heap allocations
// per step (all of the process's mallocs, counted over the timed steps). Prints Markdown tables
// for docs/BENCHMARKS.md.
//
// FLOPs are counted as 2 x the multiply-adds the method needs (what the code computes; skipped work
// is not counted). Per step, N queries, M = N encoder points, H, L, C, P = 1024 pool width, Hp = 512
// encoder hidden width:
//   stage 1, decoder (one shared condition per region):
//     forward      N (3H + L H^2 + H)                   + C H + H^2   (f-branch, f-half of hidden 1)
//     input grad   N (L H^2 + 3H)
//     double bwd   N (2 L H^2 + 6H + (L + 1) H + H)     + 2 H^2 + 2 C H
//              (tangent L H^2 + weight grads L H^2 per query; branch-a tangent and dW_a 3H each;
//               D_k lambda for the biases H per layer; dw_o H)
//   stage 1, encoder: forward M 3P + P Hp + Hp C; backward 2 (P Hp + Hp C) + 3P (sparse pool)
//   stage 2 (per query):
//     Q forward    3H + L H^2 + (3 + C) H
//     F forward    3H + C H + 2H^2 + (L - 1) H^2 + H
//     F input grad (L - 1) H^2 + 2H^2 + 3H + C H
//     Q backward   2 (3 + C) H + 2 (L - 1) H^2 + 2 H^2 + 3H
// Configurations ("gemm" column): every fp32 back end of the build, and "bf16" (Precision::Bf16:
// the large products in oneDNN bf16, the rest on the default back end) where bf16_available();
// bf16's "SGEMM" reference is nn::gemm's bf16 rate on the same 512 x 512 x N product (including
// the rounding of both operands to bf16).
// Last, where bf16 is available: one stage-1 and one stage-2 step from the same state in fp32 and
// in bf16, and how far apart their gradients are (relative L2 difference, cosine).
// Then the default preset's stage-2 step (H = 128, L = 6, C = 128; batch 500 and 2000), the whole
// batch against the batch in parts (one per thread), next to the SGEMM rate at the same N.
// Usage: bench_nn [--quick] [--gemm eigen|blas|bf16] [--gradients]
//   --quick: batch 400 and 2000 only; --gemm: only that configuration (default: every one built);
//   --gradients: only the bf16-against-fp32 gradient table
#include "../tests/support/alloc_counter.hpp"
#include "pcp/nn/gemm.hpp"
#include "pcp/nn/steps.hpp"

#include <Eigen/Core>
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

using namespace pcp::nn;
using Clock = std::chrono::steady_clock;

namespace {

constexpr int kH = 512, kL = 8, kP = 1024, kHp = 512;

double stage1_flops(double N, double H, double L, double C) {
    const double M = N;
    const double fwd = N * (3 * H + L * H * H + H) + C * H + H * H;
    const double grad = N * (L * H * H + 3 * H);
    const double dbl = N * (2 * L * H * H + 6 * H + (L + 1) * H + H) + 2 * H * H + 2 * C * H;
    const double enc = M * 3 * kP + kP * kHp + kHp * C + 2 * (kP * kHp + kHp * C) + 3 * kP;
    return 2.0 * (fwd + grad + dbl + enc);
}

double stage2_flops(double N, double H, double L, double C) {
    const double qf = 3 * H + L * H * H + (3 + C) * H;
    const double ff = 3 * H + C * H + 2 * H * H + (L - 1) * H * H + H;
    const double fg = (L - 1) * H * H + 2 * H * H + 3 * H + C * H;
    const double qb = 2 * (3 + C) * H + 2 * (L - 1) * H * H + 2 * H * H + 3 * H;
    return 2.0 * N * (qf + ff + fg + qb);
}

struct Timing {
    double seconds;      // median wall time of one call
    double allocations;  // heap allocations per call (mean over the timed calls)
};

// Median wall time of one call over at least `min_calls` calls and `min_seconds` (after one
// warm-up call), and the allocations per timed call. The median keeps a burst of load from
// another process on the shared machine from skewing either the SGEMM reference or the steps.
template <class F>
Timing time_calls(F&& f, double min_seconds, int min_calls) {
    f();  // warm-up (first touch of buffers, the GEMM's per-thread packing buffers)
    std::vector<double> times;
    times.reserve(100000);  // no allocation while counting
    long allocations;
    {
        alloc_counter::CountAllocations count;
        const auto t0 = Clock::now();
        do {
            const auto a = Clock::now();
            f();
            times.push_back(std::chrono::duration<double>(Clock::now() - a).count());
        } while (std::chrono::duration<double>(Clock::now() - t0).count() < min_seconds ||
                 int(times.size()) < min_calls);
        allocations = count.count();
    }
    std::sort(times.begin(), times.end());
    const std::size_t n = times.size();
    const double median = n % 2 ? times[n / 2] : 0.5 * (times[n / 2 - 1] + times[n / 2]);
    return {median, double(allocations) / double(n)};
}

Mat<float> randn(int r, int c, Rng& rng, double sd) {
    Mat<float> m(r, c);
    for (int j = 0; j < c; ++j)
        for (int i = 0; i < r; ++i) m(i, j) = float(rng.normal(0.0, sd));
    return m;
}

}  // namespace

namespace {

/// The networks at the paper's sizes for condition size C, initialised from `init` (F, E, Q in
/// this order).
struct PaperNets {
    BranchMlp<float> F, Q;
    PointNet<float> E;
    PaperNets(int C, Rng& init)
        : F(decoder_shape(C, kH, kL)), Q(query_net_shape(C, kH, kL)), E(pointnet_shape(C, kP, kHp)) {
        init_decoder_geometric(F, init);
        init_pointnet(E, init);
        init_query_net(Q, init, true);
    }
};

/// One column of the tables: an fp32 back end, or bf16 (on the default back end for the rest).
struct Config {
    GemmBackend backend;
    Precision precision;
    const char* name() const { return precision == Precision::Bf16 ? "bf16" : gemm_backend_name(backend); }
    void apply() const {
        set_gemm_backend(backend);
        set_gemm_precision(precision);
    }
};

}  // namespace

int main(int argc, char** argv) {
    bool quick = false, gradients_only = false;
    std::vector<Config> backends{{GemmBackend::Eigen, Precision::Fp32}};
    const GemmBackend fastest = gemm_backend_available(GemmBackend::Blas) ? GemmBackend::Blas : GemmBackend::Eigen;
    if (fastest == GemmBackend::Blas) backends.push_back({GemmBackend::Blas, Precision::Fp32});
    if (bf16_available()) backends.push_back({fastest, Precision::Bf16});
    for (int i = 1; i < argc; ++i) {
        if (std::strcmp(argv[i], "--quick") == 0) {
            quick = true;
        } else if (std::strcmp(argv[i], "--gradients") == 0) {
            gradients_only = true;
        } else if (std::strcmp(argv[i], "--gemm") == 0 && i + 1 < argc) {
            const std::string want = argv[++i];
            std::vector<Config> chosen;
            for (const Config& c : backends)
                if (want == c.name()) chosen.push_back(c);
            if (chosen.empty()) {
                std::fprintf(stderr, "bench_nn: %s is not in this build (or bf16 not on this CPU)\n", argv[i]);
                return 2;
            }
            backends = chosen;
        } else {
            std::fprintf(stderr, "usage: bench_nn [--quick] [--gemm eigen|blas|bf16] [--gradients]\n");
            return 2;
        }
    }
    const std::vector<int> batches = quick ? std::vector<int>{400, 2000} : std::vector<int>{400, 2000, 5000};
    const std::vector<int> threads = {1, 2};
    const std::vector<int> conds = {256, 512};
    const int nb = int(backends.size());

    Rng rng(1, 0);
    if (!gradients_only) {
        // SGEMM reference: C (512 x N) = A (512 x 512) * B (512 x N), per back end; and Eigen's own
        // product expression (what nn::gemm ran before it drove Eigen's kernel itself).
        std::printf("## SGEMM (512 x 512 times 512 x N, float, GFLOP/s; Eigen %d.%d.%d)\n\n",
                    EIGEN_WORLD_VERSION, EIGEN_MAJOR_VERSION, EIGEN_MINOR_VERSION);
        if (gemm_backend_available(GemmBackend::Blas)) {
            const std::string declined = blas_default_declined_reason();
            std::printf("OpenBLAS kernel: %s; default back end: %s%s%s\n\n", blas_core_name().c_str(),
                        declined.empty() ? "blas" : "eigen", declined.empty() ? "" : " (", declined.empty() ? "" : (declined + ")").c_str());
        }
        std::printf("| threads | N |");
        for (const Config& b : backends) std::printf(" nn::gemm %s |", b.name());
        std::printf(" Eigen `A * B` |\n| --- | --- |");
        for (int i = 0; i <= nb; ++i) std::printf(" --- |");
        std::printf("\n");
        double sgemm[3][3][8] = {};  // [configuration][threads][batch]
        for (int t : threads) {
            Eigen::setNbThreads(t);
            for (std::size_t b = 0; b < batches.size(); ++b) {
                const int N = batches[b];
                Mat<float> A = randn(kH, kH, rng, 0.05), B = randn(kH, N, rng, 1.0), C(kH, N);
                // Three interleaved rounds, the best median of each: the machine is shared, and a
                // burst of load during one round must not lower the reference of every step row.
                double eigen_expr = 0;
                for (int round = 0; round < 3; ++round) {
                    for (int k = 0; k < nb; ++k) {
                        backends[k].apply();
                        const Timing tm = time_calls([&] { gemm<float>(C, A, B, 1.0f, 0.0f); }, 0.4, 7);
                        sgemm[k][t][b] = std::max(sgemm[k][t][b], gemm_flops(kH, N, kH) / tm.seconds * 1e-9);
                    }
                    const Timing te = time_calls([&] { C.noalias() = A * B; }, 0.4, 7);
                    eigen_expr = std::max(eigen_expr, gemm_flops(kH, N, kH) / te.seconds * 1e-9);
                }
                std::printf("| %d | %d |", t, N);
                for (int k = 0; k < nb; ++k) std::printf(" %.1f |", sgemm[k][t][b]);
                std::printf(" %.1f |\n", eigen_expr);
                std::fflush(stdout);
            }
        }

        std::printf("\n## Training steps (H = %d, L = %d, float)\n\n", kH, kL);
        std::printf("| stage | C | threads | batch N | gemm | ms/step | steps/s | queries/s | GFLOP/step | "
                    "GFLOP/s | %% of its SGEMM | mallocs/step |\n"
                    "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n");
        for (int C : conds) {
            Rng init(2, std::uint64_t(C));
            const PaperNets nets(C, init);
            const BranchMlp<float>& F = nets.F;
            const PointNet<float>& E = nets.E;
            const BranchMlp<float>& Q = nets.Q;
            const int nmax = batches.back();
            Mat<float> pts = randn(3, nmax, rng, 0.3);
            Mat<float> q = pts + randn(3, nmax, rng, 0.03);
            Stage1Trainer<float> s1(E, F, nmax, nmax);
            Stage2Trainer<float> s2(Q, F, nmax);
            const Mat<float> no_codes;
            for (int stage : {1, 2}) {
                for (int t : threads) {
                    Eigen::setNbThreads(t);
                    for (std::size_t b = 0; b < batches.size(); ++b) {
                        const int N = batches[b];
                        const auto qb = q.leftCols(N);
                        const auto tb = pts.leftCols(N);
                        for (int k = 0; k < nb; ++k) {
                            backends[k].apply();
                            const Timing tm =
                                stage == 1 ? time_calls([&] { s1.step(qb, tb, tb); }, 1.5, 3)
                                           : time_calls([&] { s2.step(qb, tb, no_codes); }, 1.5, 3);
                            const double s = tm.seconds;
                            const double fl = stage == 1 ? stage1_flops(N, kH, kL, C) : stage2_flops(N, kH, kL, C);
                            const double gfs = fl / s * 1e-9;
                            std::printf("| %d | %d | %d | %d | %s | %.1f | %.2f | %.0f | %.1f | %.1f | %.0f%% | %.1f |\n",
                                        stage, C, t, N, backends[k].name(), s * 1e3, 1.0 / s,
                                        N / s, fl * 1e-9, gfs, 100.0 * gfs / sgemm[k][t][b], tm.allocations);
                            std::fflush(stdout);
                        }
                    }
                }
            }
        }

        // The default preset's stage 2 (width 128, depth 6, C = 128: the built-in prior and its
        // query network; 500 queries a step), the whole batch (products split over the threads)
        // against the batch in parts (one per thread, Stage2Trainer::batch_parts), next to the SGEMM
        // rate at the same N.
        constexpr int kHd = 128, kLd = 6, kCd = 128;
        std::printf("\n## Stage-2 step at the default preset's sizes (H = %d, L = %d, C = %d, float)\n\n"
                    "| threads | batch N | gemm | batch parts | ms/step | GFLOP/step | GFLOP/s | SGEMM 512 x 512 x N GFLOP/s | %% of it |\n"
                    "| --- | --- | --- | --- | --- | --- | --- | --- | --- |\n", kHd, kLd, kCd);
        Rng init(4, 0);
        BranchMlp<float> Fd(decoder_shape(kCd, kHd, kLd)), Qd(query_net_shape(kCd, kHd, kLd));
        init_decoder_geometric(Fd, init);
        init_query_net(Qd, init, true);
        for (int t : threads) {
            Eigen::setNbThreads(t);
            for (int N : {500, 2000}) {
                Mat<float> pts = randn(3, N, rng, 0.3);
                Mat<float> q = pts + randn(3, N, rng, 0.03);
                Mat<float> A = randn(kH, kH, rng, 0.05), B = randn(kH, N, rng, 1.0), C(kH, N);
                const Mat<float> no_codes;
                for (int k = 0; k < nb; ++k) {
                    backends[k].apply();
                    const double ref = gemm_flops(kH, N, kH) /
                                       time_calls([&] { gemm<float>(C, A, B, 1.0f, 0.0f); }, 0.4, 7).seconds * 1e-9;
                    for (int parts : {1, 0}) {
                        Stage2Trainer<float> tr(Qd, Fd, N);
                        tr.batch_parts = parts;
                        if (parts == 0 && tr.parts_for(N) == 1) continue;  // one thread: the same as 1 part
                        const double sec = time_calls([&] { tr.step(q, pts, no_codes); }, 1.5, 3).seconds;
                        const double fl = stage2_flops(N, kHd, kLd, kCd), gfs = fl / sec * 1e-9;
                        std::printf("| %d | %d | %s | %d | %.2f | %.3f | %.1f | %.1f | %.0f%% |\n", t, N, backends[k].name(),
                                    tr.parts_for(N), sec * 1e3, fl * 1e-9, gfs, ref, 100.0 * gfs / ref);
                        std::fflush(stdout);
                    }
                }
            }
        }
    }

    // The grid's evaluations at the default preset's sizes: F(q + dq, f') forward only, each thread
    // running its own batches in turn (as QueryNetFitter::sdf does), by the batch size.
    {
        constexpr int kHd = 128, kLd = 6, kCd = 128, kPoints = 65536;
        const double flops_per_point = 2.0 * (3.0 * kHd + double(kLd) * kHd * kHd + double(kHd) * (3 + kCd)) +
                                       2.0 * (3.0 * kHd + double(kCd) * kHd + 2.0 * kHd * kHd + double(kLd - 1) * kHd * kHd + kHd);
        std::printf("\n## SDF evaluation at the default preset's sizes (H = %d, L = %d, C = %d, float; %d points, "
                    "one batch per thread at a time)\n\n"
                    "| threads | batch | gemm | points/s | GFLOP/s |\n| --- | --- | --- | --- | --- |\n", kHd, kLd, kCd, kPoints);
        Rng init(5, 0);
        BranchMlp<float> Fd(decoder_shape(kCd, kHd, kLd)), Qd(query_net_shape(kCd, kHd, kLd));
        init_decoder_geometric(Fd, init);
        init_query_net(Qd, init, true);
        const Mat<float> pts = randn(3, kPoints, rng, 0.3);
        const Mat<float> no_codes;
        for (int t : threads) {
            for (int k = 0; k < nb; ++k) {
                backends[k].apply();
                for (int batch : {256, 512, 1024, 4096}) {
                    std::vector<GlobalSdfCache<float>> caches;
                    for (int i = 0; i < t; ++i) caches.emplace_back(Qd.shape, Fd.shape, batch);
                    const int n_batches = kPoints / batch;
                    const double sec = time_calls([&] {
                        Eigen::setNbThreads(1);
#pragma omp parallel for schedule(dynamic, 1) num_threads(t)
                        for (int b = 0; b < n_batches; ++b)
                            global_sdf_eval<float>(Qd, Fd, pts.middleCols(Eigen::Index(b) * batch, batch), no_codes,
                                                   caches[std::size_t(omp_get_thread_num())]);
                    }, 1.0, 3).seconds;
                    std::printf("| %d | %d | %s | %.0f | %.1f |\n", t, batch, backends[k].name(), kPoints / sec,
                                kPoints * flops_per_point / sec * 1e-9);
                    std::fflush(stdout);
                }
            }
        }
        Eigen::setNbThreads(threads.back());
    }

    // The same step from the same state in fp32 and in bf16: how far bf16 moves the gradient.
    if (bf16_available()) {
        const int C = 256, N = 2000;
        std::printf("\n## One step's gradient, bf16 against fp32 (H = %d, L = %d, C = %d, batch %d, same state and "
                    "inputs)\n\n| stage | loss fp32 | loss bf16 | gradient norm fp32 | relative L2 difference | cosine |\n"
                    "| --- | --- | --- | --- | --- | --- |\n", kH, kL, C, N);
        Rng init(3, 0);
        const PaperNets nets(C, init);
        const BranchMlp<float>& F = nets.F;
        const PointNet<float>& E = nets.E;
        const BranchMlp<float>& Q = nets.Q;
        const Mat<float> pts = randn(3, N, rng, 0.3);
        const Mat<float> q = pts + randn(3, N, rng, 0.03);
        const Mat<float> no_codes;
        Eigen::setNbThreads(2);
        for (int stage : {1, 2}) {
            double loss[2];
            Vec<float> grad[2];
            for (int k = 0; k < 2; ++k) {
                set_gemm_precision(k == 0 ? Precision::Fp32 : Precision::Bf16);
                if (stage == 1) {
                    Stage1Trainer<float> tr(E, F, N, N);
                    loss[k] = tr.step(q, pts, pts);
                    grad[k].resize(tr.grad_encoder.size() + tr.grad_decoder.size());
                    grad[k] << tr.grad_encoder, tr.grad_decoder;
                } else {
                    Stage2Trainer<float> tr(Q, F, N);
                    loss[k] = tr.step(q, pts, no_codes);
                    grad[k] = tr.grad_query;
                }
            }
            const double n32 = grad[0].cast<double>().norm();
            const double diff = (grad[1] - grad[0]).cast<double>().norm() / n32;
            const double cosine = grad[0].cast<double>().dot(grad[1].cast<double>()) / (n32 * grad[1].cast<double>().norm());
            std::printf("| %d | %.6g | %.6g | %.4g | %.3g | %.6f |\n", stage, loss[0], loss[1], n32, diff, cosine);
        }
        set_gemm_precision(Precision::Fp32);
    }
    return 0;
}
