// One cloud made ready for a reconstruction, once: checked (count, finite, not degenerate),
// normalised into the unit box (with the exact inverse back to the input frame), and one KD-tree
// over the unit-box points. The self-prior, the query-network fit and the sign repair all take it,
// so a reconstruction checks, normalises and indexes its cloud one time.
#pragma once

#include "pcp/cloud/kdtree.hpp"
#include "pcp/cloud/normalize.hpp"
#include "pcp/core/types.hpp"

#include <cstdint>
#include <string>

namespace pcp {

class PreparedCloud {
public:
    /// @param[in] points      N x 3, the input frame
    /// @param[in] name        for messages and provenance ("input cloud", a file name)
    /// @param[in] min_points  fewer points are refused (e.g. min_points_for(sampling))
    PreparedCloud(const Eigen::Ref<const Points>& points, std::string name, Eigen::Index min_points);

    const std::string& name() const { return name_; }
    Eigen::Index size() const { return tree_.size(); }
    const Normalization& normalization() const { return norm_; }
    /// N x 3 in the unit box: the tree's own copy. Row-major, so `columns()` sees the same
    /// memory as the 3 x N feature matrix the networks take.
    const PointsF& unit() const { return tree_.points(); }
    Eigen::Map<const Eigen::Matrix<float, 3, Eigen::Dynamic>> columns() const {
        return {unit().data(), 3, unit().rows()};
    }
    const KdTree& tree() const { return tree_; }
    /// FNV-1a 64 of the input's coordinates (double): what checkpoint fingerprints name.
    std::uint64_t input_hash() const { return input_hash_; }

private:
    std::string name_;
    Normalization norm_;
    KdTree tree_;
    std::uint64_t input_hash_ = 0;
};

}  // namespace pcp
