// Dense, ReLU and max-pool layers of the neural core (see pcp/nn/layers.hpp). Products go
// through nn::gemm; the element-wise parts are single passes over column-major memory.
#include "pcp/nn/layers.hpp"

#include "pcp/core/error.hpp"
#include "pcp/nn/gemm.hpp"

namespace pcp::nn {

namespace {

/// Z = W A + b's shapes, checked; `who` names the caller in the error.
template <class S>
void check_linear_shapes(const char* who, const MatRef<S>& Z, const CMatRef<S>& A, const CMatRef<S>& W, const CMatRef<S>& b) {
    PCP_CHECK(W.rows() == Z.rows() && W.cols() == A.rows() && A.cols() == Z.cols() &&
                  b.rows() == Z.rows() && b.cols() == 1,
              who << ": shapes: Z " << Z.rows() << "x" << Z.cols() << ", W " << W.rows() << "x" << W.cols()
                  << ", A " << A.rows() << "x" << A.cols() << ", b " << b.rows() << "x" << b.cols());
}

}  // namespace

template <class S>
void linear_forward(MatRef<S> Z, const CMatRef<S>& A, const CMatRef<S>& W, const CMatRef<S>& b) {
    check_linear_shapes<S>("nn::linear_forward", Z, A, W, b);
    gemm<S>(Z, W, A, S(1), S(0));
    Z.colwise() += b.col(0);
}

template <class S>
void bias_relu(MatRef<S> Z, const CMatRef<S>& b) {
    PCP_CHECK(b.rows() == Z.rows() && b.cols() == 1,
              "nn::bias_relu: Z is " << Z.rows() << "x" << Z.cols() << ", b " << b.rows() << "x" << b.cols());
    // Column by column: each column is one contiguous vectorised pass (a whole-matrix replicate of
    // b would index rows modulo the height, element by element).
    const auto bias = b.col(0);
    for (Eigen::Index j = 0; j < Z.cols(); ++j) Z.col(j) = (Z.col(j) + bias).cwiseMax(S(0));
}

template <class S>
void linear_relu_forward(MatRef<S> Z, const CMatRef<S>& A, const CMatRef<S>& W, const CMatRef<S>& b) {
    check_linear_shapes<S>("nn::linear_relu_forward", Z, A, W, b);
    gemm<S>(Z, W, A, S(1), S(0));
    bias_relu<S>(Z, b);
}

template <class S>
void relu_forward(MatRef<S> Z) {
    Z = Z.cwiseMax(S(0));
}

template <class S>
void relu_backward(MatRef<S> G, const CMatRef<S>& a) {
    PCP_CHECK(G.rows() == a.rows() && (a.cols() == G.cols() || a.cols() == 1),
              "nn::relu_backward: G is " << G.rows() << "x" << G.cols() << ", a is " << a.rows()
                                         << "x" << a.cols());
    if (a.cols() == G.cols()) {
        G = (a.array() > S(0)).select(G, S(0));
    } else {
        for (Eigen::Index j = 0; j < G.cols(); ++j)
            G.col(j) = (a.col(0).array() > S(0)).select(G.col(j), S(0));
    }
}

template <class S>
void linear_backward_params(MatRef<S> dL_dW, MatRef<S> dL_db, const CMatRef<S>& dL_dz,
                            const CMatRef<S>& A, GradMode mode) {
    PCP_CHECK(dL_dW.rows() == dL_dz.rows() && dL_dW.cols() == A.rows() &&
                  A.cols() == dL_dz.cols() && (dL_db.cols() == 0 || (dL_db.rows() == dL_dz.rows() && dL_db.cols() == 1)),
              "nn::linear_backward_params: shapes: dL_dW " << dL_dW.rows() << "x" << dL_dW.cols()
                                                           << ", dL_dz " << dL_dz.rows() << "x"
                                                           << dL_dz.cols() << ", A " << A.rows()
                                                           << "x" << A.cols());
    const S beta = mode == GradMode::Overwrite ? S(0) : S(1);
    gemm<S>(dL_dW, dL_dz, A, S(1), beta, Trans::No, Trans::Yes);
    if (dL_db.cols() > 0) {
        if (mode == GradMode::Overwrite)
            dL_db.col(0).noalias() = dL_dz.rowwise().sum();
        else
            dL_db.col(0).noalias() += dL_dz.rowwise().sum();
    }
}

template <class S>
void linear_backward_input(MatRef<S> dL_dA, const CMatRef<S>& dL_dz, const CMatRef<S>& W,
                           GradMode mode) {
    gemm<S>(dL_dA, W, dL_dz, S(1), mode == GradMode::Overwrite ? S(0) : S(1), Trans::Yes,
            Trans::No);
}

template <class S>
void maxpool_forward(VecRef<S> out, Eigen::Ref<Eigen::VectorXi> argmax, const CMatRef<S>& A) {
    PCP_CHECK(A.cols() >= 1 && out.size() == A.rows() && argmax.size() == A.rows(),
              "nn::maxpool_forward: A is " << A.rows() << "x" << A.cols() << ", out " << out.size()
                                           << ", argmax " << argmax.size()
                                           << " (a region needs at least one point)");
    out = A.col(0);
    argmax.setZero();
    for (Eigen::Index j = 1; j < A.cols(); ++j)
        for (Eigen::Index r = 0; r < A.rows(); ++r)
            if (A(r, j) > out(r)) {
                out(r) = A(r, j);
                argmax(r) = static_cast<int>(j);
            }
}

template <class S>
void maxpool_backward(MatRef<S> dL_dA, const CVecRef<S>& dL_dout,
                      const Eigen::Ref<const Eigen::VectorXi>& argmax, GradMode mode) {
    PCP_CHECK(dL_dout.size() == dL_dA.rows() && argmax.size() == dL_dA.rows(),
              "nn::maxpool_backward: shapes: dL_dA " << dL_dA.rows() << "x" << dL_dA.cols()
                                                     << ", dL_dout " << dL_dout.size());
    if (mode == GradMode::Overwrite) dL_dA.setZero();
    for (Eigen::Index r = 0; r < dL_dA.rows(); ++r) dL_dA(r, argmax(r)) += dL_dout(r);
}

#define PCP_NN_INSTANTIATE_LAYERS(S)                                                               \
    template void linear_forward<S>(MatRef<S>, const CMatRef<S>&, const CMatRef<S>&,              \
                                    const CMatRef<S>&);                                            \
    template void linear_relu_forward<S>(MatRef<S>, const CMatRef<S>&, const CMatRef<S>&,         \
                                         const CMatRef<S>&);                                       \
    template void bias_relu<S>(MatRef<S>, const CMatRef<S>&);                                      \
    template void relu_forward<S>(MatRef<S>);                                                      \
    template void relu_backward<S>(MatRef<S>, const CMatRef<S>&);                                  \
    template void linear_backward_params<S>(MatRef<S>, MatRef<S>, const CMatRef<S>&,              \
                                            const CMatRef<S>&, GradMode);                          \
    template void linear_backward_input<S>(MatRef<S>, const CMatRef<S>&, const CMatRef<S>&,       \
                                           GradMode);                                              \
    template void maxpool_forward<S>(VecRef<S>, Eigen::Ref<Eigen::VectorXi>, const CMatRef<S>&);  \
    template void maxpool_backward<S>(MatRef<S>, const CVecRef<S>&,                               \
                                      const Eigen::Ref<const Eigen::VectorXi>&, GradMode);
PCP_NN_INSTANTIATE_LAYERS(float)
PCP_NN_INSTANTIATE_LAYERS(double)
#undef PCP_NN_INSTANTIATE_LAYERS

}  // namespace pcp::nn
