// Portable GEMM back end of pcp::nn::gemm (Eigen), plus the three-loop reference the tests use.
// The four transpose cases are spelled out so that Eigen sees plain (transposed) maps and goes
// straight to its packed GEMM kernel with no temporary; beta in {0, 1} avoids a separate scaling
// pass over C. Note: Eigen's GEMM allocates its own packing buffers on the heap when they exceed
// EIGEN_STACK_ALLOCATION_LIMIT (large layers) and when it runs multi-threaded; every buffer of
// libpcp itself is preallocated (see MlpCache / step workspaces).
#include "pcp/nn/gemm.hpp"

#include "pcp/error.hpp"

namespace pcp::nn {

namespace {

template <class S, class ProdA, class ProdB>
void gemm_eigen(MatRef<S>& C, const ProdA& a, const ProdB& b, S alpha, S beta) {
    if (a.cols() == 0) {  // k == 0: the product is zero
        if (beta == S(0))
            C.setZero();
        else if (beta != S(1))
            C *= beta;
        return;
    }
    if (beta == S(0)) {
        if (alpha == S(1))
            C.noalias() = a * b;
        else
            C.noalias() = alpha * a * b;
    } else {
        if (beta != S(1)) C *= beta;
        if (alpha == S(1))
            C.noalias() += a * b;
        else
            C.noalias() += alpha * a * b;
    }
}

template <class S>
void check_shapes(const char* who, const MatRef<S>& C, const CMatRef<S>& A, const CMatRef<S>& B,
                  Trans ta, Trans tb) {
    const Eigen::Index m = ta == Trans::No ? A.rows() : A.cols();
    const Eigen::Index ka = ta == Trans::No ? A.cols() : A.rows();
    const Eigen::Index kb = tb == Trans::No ? B.rows() : B.cols();
    const Eigen::Index n = tb == Trans::No ? B.cols() : B.rows();
    PCP_CHECK(m == C.rows() && n == C.cols() && ka == kb,
              who << ": shape mismatch: C is " << C.rows() << "x" << C.cols() << ", op(A) is " << m
                  << "x" << ka << ", op(B) is " << kb << "x" << n);
}

}  // namespace

template <class S>
void gemm(MatRef<S> C, const CMatRef<S>& A, const CMatRef<S>& B, S alpha, S beta, Trans ta,
          Trans tb) {
    check_shapes("nn::gemm", C, A, B, ta, tb);
    if (C.size() == 0) return;
    if (ta == Trans::No && tb == Trans::No)
        gemm_eigen(C, A, B, alpha, beta);
    else if (ta == Trans::Yes && tb == Trans::No)
        gemm_eigen(C, A.transpose(), B, alpha, beta);
    else if (ta == Trans::No && tb == Trans::Yes)
        gemm_eigen(C, A, B.transpose(), alpha, beta);
    else
        gemm_eigen(C, A.transpose(), B.transpose(), alpha, beta);
}

template <class S>
void gemm_reference(MatRef<S> C, const CMatRef<S>& A, const CMatRef<S>& B, S alpha, S beta,
                    Trans ta, Trans tb) {
    check_shapes("nn::gemm_reference", C, A, B, ta, tb);
    const Eigen::Index k = ta == Trans::No ? A.cols() : A.rows();
    for (Eigen::Index j = 0; j < C.cols(); ++j)
        for (Eigen::Index i = 0; i < C.rows(); ++i) {
            double acc = 0.0;
            for (Eigen::Index l = 0; l < k; ++l) {
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
