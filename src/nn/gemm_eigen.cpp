// The Eigen back end of pcp::nn::gemm (always built, the portable path; declared in
// src/nn/gemm_backends.hpp). The only file of libpcp that knows about Eigen's GEMM internals: it
// calls Eigen 3.4's packed kernel (internal::general_matrix_matrix_product, sequential version)
// with a level3_blocking whose packing buffers belong to the calling thread and persist (grown
// once to the largest shape, then reused): Eigen's own product would allocate them on every call
// once they exceed EIGEN_STACK_ALLOCATION_LIMIT, and always when it runs multi-threaded. Threads:
// when Eigen::nbThreads() > 1 and we are not already inside an OpenMP parallel region, run_split
// cuts C into one slab per thread (columns when n >= m, else rows) and each thread runs the
// sequential kernel on its slab with its own buffers; only the operand that is shared by all slabs
// is packed once per thread (a cost of 1/slab-width of the FLOPs).
#include "gemm_backends.hpp"

#include <Eigen/Core>

#include <cstdlib>
#include <new>

#if !EIGEN_VERSION_AT_LEAST(3, 4, 0) || EIGEN_VERSION_AT_LEAST(3, 4, 90)
#error "src/nn/gemm_eigen.cpp drives Eigen 3.4's internal GEMM kernel; check its use of general_matrix_matrix_product and level3_blocking against this Eigen version"
#endif

namespace pcp::nn::gemm_detail {

namespace {

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

template <class S, int LhsOrder, int RhsOrder>
void eigen_kernel(const GemmArgs<S>& g) {
    PersistentBlocking<S> blocking(g.m, g.n, g.k, t_pack);
    Eigen::internal::general_matrix_matrix_product<Index, S, LhsOrder, false, S, RhsOrder, false,
                                                   Eigen::ColMajor, 1>::run(g.m, g.n, g.k, g.a, g.lda,
                                                                            g.b, g.ldb, g.c, 1, g.ldc,
                                                                            g.alpha, blocking, nullptr);
}

}  // namespace

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

template <class S>
void gemm_eigen(const GemmArgs<S>& g) {
    run_split(g, [](const GemmArgs<S>& s) { eigen_sequential(s); });
}

template void eigen_sequential<float>(const GemmArgs<float>&);
template void eigen_sequential<double>(const GemmArgs<double>&);
template void gemm_eigen<float>(const GemmArgs<float>&);
template void gemm_eigen<double>(const GemmArgs<double>&);

}  // namespace pcp::nn::gemm_detail
