// Shared vocabulary of the neural core (pcp::nn): the column-major "features x batch" matrix
// types every layer takes, the Ref aliases that let a layer write into a block of a larger
// buffer without a copy, and GradMode (whether a backward call overwrites or accumulates its
// gradient outputs). Nothing here allocates.
#pragma once

#include <Eigen/Core>

namespace pcp::nn {

/// Column-major dynamic matrix. Batches are `features x N` (one column per sample).
template <class S>
using Mat = Eigen::Matrix<S, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor>;
/// Dynamic column vector.
template <class S>
using Vec = Eigen::Matrix<S, Eigen::Dynamic, 1>;

/// Writable view of a column-major block (unit inner stride, any outer stride). Binds without a
/// copy to Mat, Map<Mat>, and blocks of them (e.g. `cache.a[k].leftCols(n)`).
template <class S>
using MatRef = Eigen::Ref<Mat<S>, 0, Eigen::OuterStride<>>;
/// Read-only view of a column-major block. Pass only expressions that are already laid out in
/// memory (matrices, maps, blocks): anything else would make Eigen copy into a temporary.
template <class S>
using CMatRef = Eigen::Ref<const Mat<S>, 0, Eigen::OuterStride<>>;
template <class S>
using VecRef = Eigen::Ref<Vec<S>>;
template <class S>
using CVecRef = Eigen::Ref<const Vec<S>>;

/// Whether a backward function writes its gradient outputs (Overwrite) or adds to them
/// (Accumulate). Every backward function takes one explicitly; there is no implicit zero_grad.
enum class GradMode { Overwrite, Accumulate };

}  // namespace pcp::nn
