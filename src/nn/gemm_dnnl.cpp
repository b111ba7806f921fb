// The oneDNN back end of pcp::nn::gemm (declared in src/nn/gemm_backends.hpp), compiled only when
// CMake finds oneDNN (PCP_DNNL=AUTO|ON): the bf16 products of Precision::Bf16, and the only file of
// libpcp that includes oneDNN. It rounds op(A) and op(B) to bf16 into per-thread buffers that
// persist like the Eigen back end's packing buffers, and runs a oneDNN matmul primitive that each
// thread creates once per shape and keeps (with its memory objects, argument map and scratchpad),
// so that a step with fixed shapes creates nothing after its first call.
#include "gemm_backends.hpp"

#include "pcp/core/error.hpp"

#include <Eigen/Core>
#include <oneapi/dnnl/dnnl.hpp>
#include <omp.h>
#if defined(__AVX512BF16__)
#include <immintrin.h>
#endif

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cstring>
#include <memory>
#include <unordered_map>
#include <vector>

namespace pcp::nn::gemm_detail {

namespace {

// fp32 -> bf16, round to nearest even; NaN stays a (quiet) NaN. Plain integer arithmetic that
// the compiler vectorises; no bf16 intrinsics needed.
inline std::uint16_t to_bf16(float x) {
    std::uint32_t u;
    std::memcpy(&u, &x, sizeof u);
    if ((u & 0x7fffffffu) > 0x7f800000u) return std::uint16_t((u >> 16) | 0x40u);
    u += 0x7fffu + ((u >> 16) & 1u);
    return std::uint16_t(u >> 16);
}

// Rounds one run of `count` floats to bf16. Where the compiler targets AVX512-BF16 (-march=native
// on such a CPU), 32 at a time with the hardware's round-to-nearest-even (VCVTNE2PS2BF16, which
// also quiets NaNs), the tail with to_bf16; elsewhere to_bf16 throughout. Both round identically.
inline void to_bf16_run(const float* s, Index count, std::uint16_t* d) {
    Index i = 0;
#if defined(__AVX512BF16__)
    for (; i + 32 <= count; i += 32) {
        const __m512bh packed = _mm512_cvtne2ps_pbh(_mm512_loadu_ps(s + i + 16), _mm512_loadu_ps(s + i));
        std::memcpy(d + i, &packed, sizeof packed);
    }
#endif
    for (; i < count; ++i) d[i] = to_bf16(s[i]);
}

// Rounds `outer` runs of `inner` contiguous floats (run o starts at src + o * ld) into the dense
// bf16 array dst (run o at dst + o * inner). Split over `threads` threads when that pays.
void to_bf16_runs(const float* src, Index ld, Index outer, Index inner, std::uint16_t* dst, int threads) {
    const bool split = threads > 1 && double(outer) * double(inner) >= 65536.0;
#pragma omp parallel for schedule(static) num_threads(threads) if (split)
    for (Index o = 0; o < outer; ++o) to_bf16_run(src + o * ld, inner, dst + o * inner);
}

std::atomic<long> g_primitives_created{0};

// One cached matmul: oneDNN computes, row-major, C^T (n x m, row stride ldc) = op(B)^T (n x k) *
// op(A)^T (k x m), which is column-major C = op(A) op(B); alpha is its output scale and beta a sum
// post-op (absent when beta == 0, so old NaNs in C are not read).
struct DnnlKey {
    Index m, n, k, ldc;
    Trans ta, tb;
    float alpha, beta;
    int threads;
    bool operator==(const DnnlKey& o) const {
        return m == o.m && n == o.n && k == o.k && ldc == o.ldc && ta == o.ta && tb == o.tb &&
               alpha == o.alpha && beta == o.beta && threads == o.threads;
    }
};

struct DnnlMatmul {
    DnnlKey key;
    dnnl::matmul primitive;
    dnnl::memory src, weights, dst, scratchpad;
    std::unordered_map<int, dnnl::memory> args;
};

// Per-thread oneDNN state: a stream, the bf16 copies of the operands (grown, never shrunk) and
// the primitives created so far (at most kMaxPrimitives; the oldest is dropped beyond that).
class DnnlThreadState {
public:
    static constexpr std::size_t kMaxPrimitives = 64;

    explicit DnnlThreadState(const dnnl::engine& engine) : engine_(engine), stream_(engine) {}

    dnnl::stream& stream() { return stream_; }

    std::uint16_t* buffer(int which, std::size_t elements) {
        std::vector<std::uint16_t>& b = buffers_[which];
        if (b.size() < elements) b.resize(elements);
        return b.data();
    }

    DnnlMatmul& matmul(const DnnlKey& key) {
        for (auto& p : cache_)
            if (p->key == key) return *p;
        if (cache_.size() >= kMaxPrimitives) cache_.erase(cache_.begin());
        cache_.push_back(create(key));
        ++g_primitives_created;
        return *cache_.back();
    }

private:
    std::unique_ptr<DnnlMatmul> create(const DnnlKey& key) {
        using dnnl::memory;
        using dt = memory::data_type;
        const memory::dim m = key.m, n = key.n, k = key.k;
        // Dense bf16 copies that keep each operand's storage order (see dnnl_gemm).
        const memory::desc src_md({n, k}, dt::bf16, key.tb == Trans::No ? memory::dims{k, 1} : memory::dims{1, n});
        const memory::desc wei_md({k, m}, dt::bf16, key.ta == Trans::No ? memory::dims{m, 1} : memory::dims{1, k});
        const memory::desc dst_md({n, m}, dt::f32, memory::dims{memory::dim(key.ldc), 1});
        dnnl::primitive_attr attr;
        attr.set_scratchpad_mode(dnnl::scratchpad_mode::user);
        if (key.alpha != 1.0f) attr.set_output_scales(0, {key.alpha});
        if (key.beta != 0.0f) {
            dnnl::post_ops ops;
            ops.append_sum(key.beta);
            attr.set_post_ops(ops);
        }
        const dnnl::matmul::primitive_desc pd(dnnl::matmul::desc(src_md, wei_md, dst_md), attr, engine_);
        auto mm = std::make_unique<DnnlMatmul>();
        mm->key = key;
        mm->primitive = dnnl::matmul(pd);
        mm->src = memory(src_md, engine_, DNNL_MEMORY_NONE);
        mm->weights = memory(wei_md, engine_, DNNL_MEMORY_NONE);
        mm->dst = memory(dst_md, engine_, DNNL_MEMORY_NONE);
        mm->scratchpad = memory(pd.scratchpad_desc(), engine_);  // owned, allocated once
        mm->args = {{DNNL_ARG_SRC, mm->src},
                    {DNNL_ARG_WEIGHTS, mm->weights},
                    {DNNL_ARG_DST, mm->dst},
                    {DNNL_ARG_SCRATCHPAD, mm->scratchpad}};
        return mm;
    }

    dnnl::engine engine_;
    dnnl::stream stream_;
    std::vector<std::uint16_t> buffers_[2];
    std::vector<std::unique_ptr<DnnlMatmul>> cache_;
};

const dnnl::engine& dnnl_engine() {
    static const dnnl::engine engine(dnnl::engine::kind::cpu, 0);
    return engine;
}

thread_local std::unique_ptr<DnnlThreadState> t_dnnl;

}  // namespace

bool dnnl_cpu_has_bf16_units() {
    const dnnl::cpu_isa isa = dnnl::get_effective_cpu_isa();
    return isa == dnnl::cpu_isa::avx512_core_bf16 || isa == dnnl::cpu_isa::avx512_core_amx;
}

long dnnl_primitives_created() { return g_primitives_created.load(); }

// C = alpha op(A) op(B) + beta C with both operands rounded to bf16, fp32 accumulation. Runs on
// Eigen::nbThreads() threads (oneDNN's OpenMP threading; the ICV is set for the call and restored
// after it), or on the calling thread alone inside a parallel region.
void gemm_dnnl_bf16(const GemmArgs<float>& g) {
    const bool nested = omp_in_parallel() != 0;
    const int threads = nested ? 1 : std::max(1, Eigen::nbThreads());
    try {
        if (!t_dnnl) t_dnnl = std::make_unique<DnnlThreadState>(dnnl_engine());
        DnnlThreadState& state = *t_dnnl;
        // op(A)^T (k x m): A's columns (ta == No: k runs of m) or rows as stored (ta == Yes: m
        // runs of k) copied densely in storage order; likewise op(B)^T (n x k).
        std::uint16_t* wa = state.buffer(0, std::size_t(g.m) * std::size_t(g.k));
        std::uint16_t* wb = state.buffer(1, std::size_t(g.n) * std::size_t(g.k));
        if (g.ta == Trans::No)
            to_bf16_runs(g.a, g.lda, g.k, g.m, wa, threads);
        else
            to_bf16_runs(g.a, g.lda, g.m, g.k, wa, threads);
        if (g.tb == Trans::No)
            to_bf16_runs(g.b, g.ldb, g.n, g.k, wb, threads);
        else
            to_bf16_runs(g.b, g.ldb, g.k, g.n, wb, threads);
        struct ThreadsForCall {  // the OpenMP ICV oneDNN reads (at creation and execution), restored also on an exception
            int saved;
            bool set;
            ThreadsForCall(int want, bool nested_call) : saved(omp_get_max_threads()), set(!nested_call && saved != want) {
                if (set) omp_set_num_threads(want);
            }
            ~ThreadsForCall() {
                if (set) omp_set_num_threads(saved);
            }
        } for_call(threads, nested);
        DnnlMatmul& mm = state.matmul(DnnlKey{g.m, g.n, g.k, g.ldc, g.ta, g.tb, g.alpha, g.beta, threads});
        mm.src.set_data_handle(wb);
        mm.weights.set_data_handle(wa);
        mm.dst.set_data_handle(g.c);
        mm.primitive.execute(state.stream(), mm.args);
        state.stream().wait();
    } catch (const dnnl::error& e) {
        PCP_CHECK(false, "nn::gemm bf16 (oneDNN) " << g.m << "x" << g.n << "x" << g.k << ": " << e.what());
    }
}

}  // namespace pcp::nn::gemm_detail
