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
#include "pcp/nn/gemm.hpp"

#include "pcp/error.hpp"

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

#if defined(PCP_WITH_BLAS)
#include <cblas.h>
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

GemmBackend gemm_backend() {
    int b = g_backend.load(std::memory_order_relaxed);
    if (b == kUnresolved) {
        int expected = kUnresolved;
        g_backend.compare_exchange_strong(expected, int(default_backend()));
        b = g_backend.load();
    }
    return GemmBackend(b);
}

const char* gemm_backend_name(GemmBackend backend) {
    return backend == GemmBackend::Blas ? "blas" : "eigen";
}

GemmBackend parse_gemm_backend(const char* name) {
    if (std::strcmp(name, "eigen") == 0) return GemmBackend::Eigen;
    if (std::strcmp(name, "blas") == 0) return GemmBackend::Blas;
    PCP_CHECK(false, "unknown GEMM back end '" << name << "': expected eigen or blas");
    return GemmBackend::Eigen;
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
