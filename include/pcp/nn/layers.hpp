// Layers of the neural core as free functions with explicit buffers, outputs first (STYLE.md
// habit 1): dense (linear) forward and backward, ReLU forward/backward through its mask, and the
// PointNet max-pool over the points of one region. Batches are column-major `features x N`.
// Sizes come from the Eigen dimensions and are checked on entry (pcp::Error on mismatch). Every
// matrix product goes through nn::gemm. Nothing here allocates.
//
// Letters: N = batch (columns), D = input width, H = output width.
#pragma once

#include "pcp/nn/common.hpp"

namespace pcp::nn {

/// Z = W * A + b (b added to every column).
/// @param[out] Z  H x N pre-activations.
/// @param[in]  A  D x N inputs.
/// @param[in]  W  H x D weights.
/// @param[in]  b  H x 1 biases.
template <class S>
void linear_forward(MatRef<S> Z, const CMatRef<S>& A, const CMatRef<S>& W, const CMatRef<S>& b);

/// Z = max(W * A + b, 0): linear_forward and relu_forward in one pass over Z after the product
/// (the bias and the ReLU fused; the same numbers as the two calls).
template <class S>
void linear_relu_forward(MatRef<S> Z, const CMatRef<S>& A, const CMatRef<S>& W, const CMatRef<S>& b);

/// In place Z = max(Z + b, 0), b added to every column: the bias and ReLU of a layer whose product
/// is already in Z, in one pass.
template <class S>
void bias_relu(MatRef<S> Z, const CMatRef<S>& b);

/// In place a = max(z, 0). The mask m = [z > 0] is recovered later as [a > 0].
/// @param[in,out] Z  H x N, pre-activations in, activations out.
template <class S>
void relu_forward(MatRef<S> Z);

/// In place dL_dz = dL_da .* [a > 0] (METHOD.md §4: multiplication by the mask m_k).
/// @param[in,out] G  H x N, dL/da in, dL/dz out (also used for the tangent: u = m .* (W u)).
/// @param[in]     a  H x N post-ReLU activations of the same layer (or H x 1, broadcast).
template <class S>
void relu_backward(MatRef<S> G, const CMatRef<S>& a);

/// Parameter gradients of a dense layer: dL_dW (+)= dL_dz * A^T, dL_db (+)= sum over columns.
/// @param[in,out] dL_dW  H x D.
/// @param[in,out] dL_db  H x 1 (skipped if it has no columns).
/// @param[in]     dL_dz  H x N.
/// @param[in]     A      D x N, the layer's input in the forward pass.
template <class S>
void linear_backward_params(MatRef<S> dL_dW, MatRef<S> dL_db, const CMatRef<S>& dL_dz,
                            const CMatRef<S>& A, GradMode mode);

/// Input gradient of a dense layer: dL_dA (+)= W^T * dL_dz.
/// @param[in,out] dL_dA  D x N.
/// @param[in]     dL_dz  H x N.
/// @param[in]     W      H x D.
template <class S>
void linear_backward_input(MatRef<S> dL_dA, const CMatRef<S>& dL_dz, const CMatRef<S>& W,
                           GradMode mode);

/// Max-pool over columns (the points of one region): out(r) = max_j A(r, j), argmax(r) = the
/// first j reaching it.
/// @param[out] out     H.
/// @param[out] argmax  H column indices.
/// @param[in]  A       H x M, M >= 1.
template <class S>
void maxpool_forward(VecRef<S> out, Eigen::Ref<Eigen::VectorXi> argmax, const CMatRef<S>& A);

/// Dense max-pool backward: dL_dA (+)= scatter of dL_dout to (r, argmax(r)).
/// @param[in,out] dL_dA    H x M.
/// @param[in]     dL_dout  H.
/// @param[in]     argmax   H.
template <class S>
void maxpool_backward(MatRef<S> dL_dA, const CVecRef<S>& dL_dout,
                      const Eigen::Ref<const Eigen::VectorXi>& argmax, GradMode mode);

}  // namespace pcp::nn
