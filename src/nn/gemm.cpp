// Back ends of pcp::nn::gemm (pcp/nn/gemm.hpp), their run-time selection, and the three-loop
// reference the tests use. This is the only file of libpcp that knows about BLAS or about Eigen's
// GEMM internals. The Eigen back end calls Eigen 3.4's packed kernel
// (internal::general_matrix_matrix_product, sequential version) with a level3_blocking whose
// packing buffers belong to the calling thread and persist (grown once to the largest shape, then
// reused): Eigen's own product would allocate them on every call once they exceed
// EIGEN_STACK_ALLOCATION_LIMIT, and always when it runs multi-threaded. Threads: when
// Eigen::nbThreads() > 1 and we are not already inside an OpenMP parallel region, C is cut into one
// slab per thread (columns when n >= m, else rows) and each thread runs the sequential kernel on
// its slab with its own buffers; only the operand that is shared by all slabs is packed once per
// thread (a cost of 1/slab-width of the FLOPs). The BLAS back end (PCP_WITH_BLAS, OpenBLAS) runs
// cblas_?gemm single-threaded on the same slabs; OpenBLAS packs into its own persistent pool.
// The oneDNN part (PCP_WITH_DNNL) serves Precision::Bf16: it rounds op(A) and op(B) to bf16 into
// per-thread buffers that persist like the packing buffers, and runs a oneDNN matmul primitive
// that each thread creates once per shape and keeps (with its memory objects, argument map and
// scratchpad), so that a step with fixed shapes creates nothing after its first call.
#include "pcp/nn/gemm.hpp"

#include "pcp/core/error.hpp"

#include <Eigen/Core>
#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <limits>
#include <mutex>
#include <new>
#include <string>
#include <type_traits>

#if defined(PCP_WITH_BLAS)
#include <cblas.h>
#endif

#if defined(PCP_WITH_DNNL)
#include <oneapi/dnnl/dnnl.hpp>
#if defined(__AVX512BF16__)
#include <immintrin.h>
#endif

#include <cstdint>
#include <memory>
#include <unordered_map>
#include <vector>
#endif

#if !EIGEN_VERSION_AT_LEAST(3, 4, 0) || EIGEN_VERSION_AT_LEAST(3, 4, 90)
#error "src/nn/gemm.cpp drives Eigen 3.4's internal GEMM kernel; check its use of general_matrix_matrix_product and level3_blocking against this Eigen version"
#endif

namespace pcp::nn {

namespace {

using Eigen::Index;

// ------------------------------------------------------------------------------------------------
// Back-end selection
// ------------------------------------------------------------------------------------------------

#if defined(PCP_WITH_BLAS)
constexpr bool kHaveBlas = true;
#else
constexpr bool kHaveBlas = false;
#endif

constexpr int kUnresolved = -1;
std::atomic<int> g_backend{kUnresolved};

#if defined(PCP_WITH_DNNL)
constexpr bool kHaveDnnl = true;
#else
constexpr bool kHaveDnnl = false;
#endif

std::atomic<int> g_precision{kUnresolved};

Precision default_precision() {
    const char* env = std::getenv("PCP_PRECISION");
    if (env != nullptr && *env != '\0') {
        try {
            return parse_precision(env);
        } catch (const Error& e) {
            PCP_CHECK(false, "PCP_PRECISION=" << env << ": " << e.what());
        }
    }
    return Precision::Fp32;
}

GemmBackend default_backend() {
    const char* env = std::getenv("PCP_GEMM");
    if (env != nullptr && *env != '\0') {
        const GemmBackend b = parse_gemm_backend(env);
        PCP_CHECK(gemm_backend_available(b),
                  "PCP_GEMM=" << env << ": this build of libpcp has no BLAS back end (configure "
                                        "with -DPCP_BLAS=ON and OpenBLAS installed), or unset PCP_GEMM");
        return b;
    }
    return kHaveBlas ? GemmBackend::Blas : GemmBackend::Eigen;
}

// ------------------------------------------------------------------------------------------------
// Eigen back end: persistent per-thread packing buffers
// ------------------------------------------------------------------------------------------------

// Packing buffers of one thread: blockA (packed panel of op(A)) and blockB (packed panel of
// op(B)), in bytes, 64-byte aligned. They only grow; a thread that has run the largest product of
// a training step once never allocates again.
class PackBuffers {
public:
    PackBuffers() = default;
    PackBuffers(const PackBuffers&) = delete;
    PackBuffers& operator=(const PackBuffers&) = delete;
    ~PackBuffers() {
        std::free(a_);
        std::free(b_);
    }
    void* a(std::size_t bytes) { return grow(a_, a_bytes_, bytes); }
    void* b(std::size_t bytes) { return grow(b_, b_bytes_, bytes); }

private:
    static void* grow(void*& p, std::size_t& have, std::size_t want) {
        if (want > have) {
            const std::size_t bytes = (want + 63) / 64 * 64;
            void* q = std::aligned_alloc(64, bytes);
            if (q == nullptr) throw std::bad_alloc();
            std::free(p);
            p = q;
            have = bytes;
        }
        return p;
    }
    void* a_ = nullptr;
    void* b_ = nullptr;
    std::size_t a_bytes_ = 0, b_bytes_ = 0;
};

thread_local PackBuffers t_pack;

// Eigen's blocking parameters (kc, mc, nc from its cache-size model, as its own sequential
// product computes them) pointing at this thread's persistent buffers. Eigen's kernel uses
// blockA/blockB when they are non-null instead of allocating.
template <class S>
class PersistentBlocking : public Eigen::internal::level3_blocking<S, S> {
public:
    PersistentBlocking(Index m, Index n, Index k, PackBuffers& buffers) {
        Index kc = k, mc = m, nc = n;
        // Sequential sizing also for a slab: each thread runs the sequential algorithm on its
        // own slab (Eigen's multi-thread sizing assumes a packed lhs shared by all threads).
        Eigen::internal::computeProductBlockingSizes<S, S, 1>(kc, mc, nc, Index(1));
        this->m_kc = kc;
        this->m_mc = mc;
        this->m_nc = nc;
        this->m_blockA = static_cast<S*>(buffers.a(sizeof(S) * std::size_t(kc) * std::size_t(mc)));
        this->m_blockB = static_cast<S*>(buffers.b(sizeof(S) * std::size_t(kc) * std::size_t(nc)));
    }
};

// Raw operands of C = alpha op(A) op(B) + beta C, all column-major storage. op(A) is read as a
// row-major matrix when ta == Yes (A^T in place), likewise op(B).
template <class S>
struct GemmArgs {
    Index m, n, k;
    const S* a;
    Index lda;
    const S* b;
    Index ldb;
    S* c;
    Index ldc;
    S alpha, beta;
    Trans ta, tb;
};

// C := beta C on the m x n block at c (column-major, stride ldc). beta == 0 writes zeros (NaN in
// the old contents is not propagated).
template <class S>
void scale_block(S* c, Index ldc, Index m, Index n, S beta) {
    if (beta == S(1)) return;
    for (Index j = 0; j < n; ++j) {
        S* col = c + j * ldc;
        if (beta == S(0))
            std::fill(col, col + m, S(0));
        else
            for (Index i = 0; i < m; ++i) col[i] *= beta;
    }
}

template <class S, int LhsOrder, int RhsOrder>
void eigen_kernel(const GemmArgs<S>& g) {
    PersistentBlocking<S> blocking(g.m, g.n, g.k, t_pack);
    Eigen::internal::general_matrix_matrix_product<Index, S, LhsOrder, false, S, RhsOrder, false,
                                                   Eigen::ColMajor, 1>::run(g.m, g.n, g.k, g.a, g.lda,
                                                                            g.b, g.ldb, g.c, 1, g.ldc,
                                                                            g.alpha, blocking, nullptr);
}

// One thread's product on the whole of g (a slab when called from the parallel split).
template <class S>
void eigen_sequential(const GemmArgs<S>& g) {
    scale_block(g.c, g.ldc, g.m, g.n, g.beta);
    constexpr int Col = Eigen::ColMajor, Row = Eigen::RowMajor;
    if (g.ta == Trans::No && g.tb == Trans::No)
        eigen_kernel<S, Col, Col>(g);
    else if (g.ta == Trans::Yes && g.tb == Trans::No)
        eigen_kernel<S, Row, Col>(g);
    else if (g.ta == Trans::No && g.tb == Trans::Yes)
        eigen_kernel<S, Col, Row>(g);
    else
        eigen_kernel<S, Row, Row>(g);
}

// The slab [lo, hi) of C's columns (by_cols) or rows, as its own product.
template <class S>
GemmArgs<S> slab(const GemmArgs<S>& g, bool by_cols, Index lo, Index hi) {
    GemmArgs<S> s = g;
    if (by_cols) {  // op(B)'s columns lo..hi: B's columns (No) or rows (Yes)
        s.n = hi - lo;
        s.b = g.tb == Trans::No ? g.b + lo * g.ldb : g.b + lo;
        s.c = g.c + lo * g.ldc;
    } else {  // op(A)'s rows lo..hi: A's rows (No) or columns (Yes)
        s.m = hi - lo;
        s.a = g.ta == Trans::No ? g.a + lo : g.a + lo * g.lda;
        s.c = g.c + lo;
    }
    return s;
}

// Below this many multiply-adds per thread a split does not pay for the threads' wake-up (the
// same order as Eigen's own minimum task size).
constexpr double kMinMaddsPerThread = 65536.0;

// Runs `sequential` (one thread's product, any back end) on g: directly, or on one slab of C per
// thread in an OpenMP region of min(Eigen::nbThreads(), what the size supports) threads. Inside an
// enclosing parallel region it runs on the calling thread alone.
template <class S, class Sequential>
void run_split(const GemmArgs<S>& g, Sequential sequential) {
    int threads = omp_in_parallel() ? 1 : std::max(1, Eigen::nbThreads());
    const bool by_cols = g.n >= g.m;
    const Index dim = by_cols ? g.n : g.m;
    // Slab widths in multiples of the micro-kernels' panels (8 columns, 32 rows cover every
    // nr/mr of the float and double AVX2 kernels) so that no slab ends in a ragged panel.
    const Index grain = by_cols ? 8 : 32;
    const double madds = double(g.m) * double(g.n) * double(g.k);
    threads = int(std::min<double>({double(threads), double(std::max<Index>(1, dim / grain)),
                                    std::max(1.0, madds / kMinMaddsPerThread)}));
    if (threads <= 1) {
        sequential(g);
        return;
    }
    std::exception_ptr error;
#pragma omp parallel num_threads(threads)
    {
        const Index nt = omp_get_num_threads(), t = omp_get_thread_num();
        const Index panels = (dim + grain - 1) / grain;
        const Index lo = std::min(dim, panels * t / nt * grain);
        const Index hi = std::min(dim, panels * (t + 1) / nt * grain);
        try {
            if (hi > lo) sequential(slab(g, by_cols, lo, hi));
        } catch (...) {
#pragma omp critical(pcp_gemm_error)
            if (!error) error = std::current_exception();
        }
    }
    if (error) std::rethrow_exception(error);
}

// ------------------------------------------------------------------------------------------------
// BLAS back end
// ------------------------------------------------------------------------------------------------

#if defined(PCP_WITH_BLAS)

inline CBLAS_TRANSPOSE cblas_trans(Trans t) { return t == Trans::No ? CblasNoTrans : CblasTrans; }

inline void blas_call(const GemmArgs<float>& g) {
    cblas_sgemm(CblasColMajor, cblas_trans(g.ta), cblas_trans(g.tb), blasint(g.m), blasint(g.n),
                blasint(g.k), g.alpha, g.a, blasint(g.lda), g.b, blasint(g.ldb), g.beta, g.c,
                blasint(g.ldc));
}

inline void blas_call(const GemmArgs<double>& g) {
    cblas_dgemm(CblasColMajor, cblas_trans(g.ta), cblas_trans(g.tb), blasint(g.m), blasint(g.n),
                blasint(g.k), g.alpha, g.a, blasint(g.lda), g.b, blasint(g.ldb), g.beta, g.c,
                blasint(g.ldc));
}

// OpenBLAS always runs single-threaded under us; the threads are run_split's (the same slabs and
// thread count as the Eigen back end). Why not OpenBLAS's own threading: its threaded level-3
// driver mallocs its job table on every call (measured: 40-49 mallocs per training step with 2
// threads, none with 1). OpenBLAS runs on one thread inside an active parallel region; outside one
// the OpenMP build takes its count from omp_get_max_threads() at the call, so that ICV is 1 for
// the call and restored after it; openblas_set_num_threads(1), once, covers the pthread build.
template <class S>
void blas_sequential(const GemmArgs<S>& g) {
    // OpenBLAS 0.3.21 on AVX-512 CPUs (its SkylakeX kernels, measured on Zen 4) mallocs on every
    // call of the plain (No, No) product for many m that are not multiples of 16 (1-8, 17, 65,
    // 129, 257, ...; k >= 32), never for the transposed forms; the Eigen kernel, which allocates
    // nothing after its first call, takes those (in the method: the 1-row output layers).
    if (g.ta == Trans::No && g.tb == Trans::No && g.m % 16 != 0) {
        eigen_sequential(g);
        return;
    }
    if (omp_in_parallel()) {
        blas_call(g);
        return;
    }
    static std::once_flag once;
    const int saved = omp_get_max_threads();
    std::call_once(once, [] { openblas_set_num_threads(1); });
    if (omp_get_max_threads() != 1) omp_set_num_threads(1);
    blas_call(g);
    if (omp_get_max_threads() != saved) omp_set_num_threads(saved);
}

template <class S>
void gemm_blas(const GemmArgs<S>& g) {
    constexpr Index kMax = std::numeric_limits<blasint>::max();
    PCP_CHECK(g.m <= kMax && g.n <= kMax && g.k <= kMax && g.lda <= kMax && g.ldb <= kMax &&
                  g.ldc <= kMax,
              "nn::gemm: " << g.m << "x" << g.n << "x" << g.k
                           << " exceeds the BLAS back end's 32-bit sizes; use the Eigen back end");
    run_split(g, [](const GemmArgs<S>& s) { blas_sequential(s); });
}

#endif  // PCP_WITH_BLAS


// ------------------------------------------------------------------------------------------------
// oneDNN bf16 back end (Precision::Bf16)
// ------------------------------------------------------------------------------------------------

#if defined(PCP_WITH_DNNL)

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

bool cpu_has_bf16_units() {
    const dnnl::cpu_isa isa = dnnl::get_effective_cpu_isa();
    return isa == dnnl::cpu_isa::avx512_core_bf16 || isa == dnnl::cpu_isa::avx512_core_amx;
}

// C = alpha op(A) op(B) + beta C with both operands rounded to bf16, fp32 accumulation. Runs on
// Eigen::nbThreads() threads (oneDNN's OpenMP threading; the ICV is set for the call and restored
// after it), or on the calling thread alone inside a parallel region.
void dnnl_gemm(const GemmArgs<float>& g) {
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

#endif  // PCP_WITH_DNNL

template <class S>
void gemm_eigen(const GemmArgs<S>& g) {
    run_split(g, [](const GemmArgs<S>& s) { eigen_sequential(s); });
}

template <class S>
void check_shapes(const char* who, const MatRef<S>& C, const CMatRef<S>& A, const CMatRef<S>& B,
                  Trans ta, Trans tb) {
    const Index m = ta == Trans::No ? A.rows() : A.cols();
    const Index ka = ta == Trans::No ? A.cols() : A.rows();
    const Index kb = tb == Trans::No ? B.rows() : B.cols();
    const Index n = tb == Trans::No ? B.cols() : B.rows();
    PCP_CHECK(m == C.rows() && n == C.cols() && ka == kb,
              who << ": shape mismatch: C is " << C.rows() << "x" << C.cols() << ", op(A) is " << m
                  << "x" << ka << ", op(B) is " << kb << "x" << n);
}

// A stride BLAS accepts (>= rows, >= 1) also for a single-column operand.
template <class M>
Index leading_dim(const M& X) {
    return std::max<Index>({X.outerStride(), X.rows(), Index(1)});
}

}  // namespace

bool gemm_backend_available(GemmBackend backend) {
    return backend == GemmBackend::Eigen || kHaveBlas;
}

void set_gemm_backend(GemmBackend backend) {
    PCP_CHECK(gemm_backend_available(backend),
              "nn::set_gemm_backend: this build of libpcp has no BLAS back end (configure with "
              "-DPCP_BLAS=ON and OpenBLAS installed)");
    g_backend.store(int(backend));
}

// The value of a process-wide setting, resolved from its default (environment) on first use.
template <class E, class Default>
E resolved(std::atomic<int>& setting, Default default_value) {
    int v = setting.load(std::memory_order_relaxed);
    if (v == kUnresolved) {
        int expected = kUnresolved;
        setting.compare_exchange_strong(expected, int(default_value()));
        v = setting.load();
    }
    return E(v);
}

GemmBackend gemm_backend() { return resolved<GemmBackend>(g_backend, default_backend); }

const char* gemm_backend_name(GemmBackend backend) {
    return backend == GemmBackend::Blas ? "blas" : "eigen";
}

GemmBackend parse_gemm_backend(const char* name) {
    if (std::strcmp(name, "eigen") == 0) return GemmBackend::Eigen;
    if (std::strcmp(name, "blas") == 0) return GemmBackend::Blas;
    PCP_CHECK(false, "unknown GEMM back end '" << name << "': expected eigen or blas");
    return GemmBackend::Eigen;
}

bool bf16_available() { return bf16_unavailable_reason().empty(); }

std::string bf16_unavailable_reason() {
    if (!kHaveDnnl)
        return "this build of libpcp has no oneDNN back end (install libdnnl-dev and configure with "
               "-DPCP_DNNL=AUTO or ON)";
#if defined(PCP_WITH_DNNL)
    static const bool units = cpu_has_bf16_units();
    if (!units) return "this CPU has neither AVX512-BF16 nor AMX";
#endif
    return "";
}

void set_gemm_precision(Precision precision) {
    PCP_CHECK(precision == Precision::Fp32 || bf16_available(),
              "nn::set_gemm_precision: bf16 is not available: " << bf16_unavailable_reason());
    g_precision.store(int(precision));
}

Precision gemm_precision() { return resolved<Precision>(g_precision, default_precision); }

long bf16_primitives_created() {
#if defined(PCP_WITH_DNNL)
    return g_primitives_created.load();
#else
    return 0;
#endif
}

const char* precision_name(Precision precision) { return precision == Precision::Bf16 ? "bf16" : "fp32"; }

Precision parse_precision(const std::string& name) {
    if (name == "fp32") return Precision::Fp32;
    if (name == "auto") return bf16_available() ? Precision::Bf16 : Precision::Fp32;
    PCP_CHECK(name == "bf16", "unknown precision '" << name << "': expected auto, fp32 or bf16");
    PCP_CHECK(bf16_available(), "precision bf16 is not available: " << bf16_unavailable_reason());
    return Precision::Bf16;
}

template <class S>
void gemm(MatRef<S> C, const CMatRef<S>& A, const CMatRef<S>& B, S alpha, S beta, Trans ta,
          Trans tb) {
    check_shapes("nn::gemm", C, A, B, ta, tb);
    if (C.size() == 0) return;
    const Index k = ta == Trans::No ? A.cols() : A.rows();
    if (k == 0) {  // the product is zero
        scale_block(C.data(), C.outerStride(), C.rows(), C.cols(), beta);
        return;
    }
    const GemmArgs<S> g{C.rows(), C.cols(), k,     A.data(), leading_dim(A), B.data(), leading_dim(B),
                        C.data(), leading_dim(C), alpha, beta, ta,       tb};
#if defined(PCP_WITH_DNNL)
    if constexpr (std::is_same_v<S, float>) {
        if (g.m >= kBf16MinDim && g.n >= kBf16MinDim && g.k >= kBf16MinDim &&
            gemm_precision() == Precision::Bf16) {
            dnnl_gemm(g);
            return;
        }
    }
#endif
#if defined(PCP_WITH_BLAS)
    if (gemm_backend() == GemmBackend::Blas) {
        gemm_blas(g);
        return;
    }
#endif
    gemm_eigen(g);
}

template <class S>
void gemm_reference(MatRef<S> C, const CMatRef<S>& A, const CMatRef<S>& B, S alpha, S beta,
                    Trans ta, Trans tb) {
    check_shapes("nn::gemm_reference", C, A, B, ta, tb);
    const Index k = ta == Trans::No ? A.cols() : A.rows();
    for (Index j = 0; j < C.cols(); ++j)
        for (Index i = 0; i < C.rows(); ++i) {
            double acc = 0.0;
            for (Index l = 0; l < k; ++l) {
                const double a = ta == Trans::No ? A(i, l) : A(l, i);
                const double b = tb == Trans::No ? B(l, j) : B(j, l);
                acc += a * b;
            }
            const double prev = beta == S(0) ? 0.0 : double(beta) * double(C(i, j));
            C(i, j) = S(double(alpha) * acc + prev);
        }
}

template void gemm<float>(MatRef<float>, const CMatRef<float>&, const CMatRef<float>&, float,
                          float, Trans, Trans);
template void gemm<double>(MatRef<double>, const CMatRef<double>&, const CMatRef<double>&, double,
                           double, Trans, Trans);
template void gemm_reference<float>(MatRef<float>, const CMatRef<float>&, const CMatRef<float>&,
                                    float, float, Trans, Trans);
template void gemm_reference<double>(MatRef<double>, const CMatRef<double>&,
                                     const CMatRef<double>&, double, double, Trans, Trans);

}  // namespace pcp::nn
