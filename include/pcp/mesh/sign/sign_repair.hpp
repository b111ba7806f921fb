// Sign repair: removes the zero crossings of a fitted field that lie away from the data.
//
// The pulling loss (METHOD.md §3) constrains only |F| and the direction of its gradient: the
// projection q - F(q) g/|g| is the same for F and -F, so nothing in training fixes the sign of a
// region that no query reaches. A fitted field therefore may turn negative in a pocket outside the
// shape (a "bulge") or positive inside it (a bubble), and the zero level set then has sheets where
// there is no data (docs/NOTEBOOK.md, "Sign repair"). The release only
// decides one global sign (METHOD.md §5); issue 5 asks for a more robust rule. This is ours (not
// in the paper):
//
//  1. Sample the field on a coarse dense grid (its own evaluations; default 64 cells per axis).
//  2. Mark the samples within a distance tau of an input point ("near the data"). Every true
//     surface of the shape runs through the near samples, so they separate the other samples into
//     regions of one sign each: the connected components (6-neighbours, same sign, not near).
//  3. A component whose boundary touches samples of the other sign directly, without near samples
//     in between, owes that boundary to a zero crossing away from the data. When more than
//     `max_unsupported` of its boundary is such, the component's sign is wrong: it is flipped (it
//     merges with its neighbours), smallest first, never a component that touches the grid's box.
//     A hole in the data that the field closes by itself is left alone: there the component's
//     boundary is mostly near samples.
//  3'. With visibility labels (pcp/cloud/visibility.hpp): a negative region away from the data
//     whose labelled samples mostly say outside is flipped too (the label vote), unless it
//     touches the box: a membrane that closes an open part, a plug in a through-hole.
//  4. apply() negates a value of the field wherever the coarse cell around its
//     point has flipped corners of the value's own sign; |F| is unchanged everywhere.
#pragma once

#include "pcp/cloud/kdtree.hpp"
#include "pcp/cloud/visibility.hpp"
#include "pcp/mesh/grid/sdf_grid.hpp"
#include "pcp/core/types.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <vector>

namespace pcp {

struct SignRepairOptions {
    static constexpr int kMinResolution = 2, kMaxResolution = 256;  ///< the accepted coarse resolutions
    bool enabled = true;           ///< off: apply() is the identity and no evaluation happens
    int resolution = 64;           ///< coarse grid cells along each axis of the fine grid's box (2..256; memory ~ 30 bytes x (R+1)^3)
    double near_cells = 1.5;       ///< tau = max(near_cells * largest coarse spacing,
    double near_spacings = 2.0;    ///<           near_spacings * median distance between neighbouring points)
    double max_unsupported = 0.5;  ///< flip a component when more than this fraction of its boundary is away from data
    /// With visibility labels (pcp/cloud/visibility.hpp, given to the constructor): after the
    /// component flips, a negative region whose labelled coarse samples mostly say outside (at
    /// least `min_label_votes` of them, more than say inside) is flipped, unless it touches the box:
    /// membranes that close an open part, plugs in holes. (Positive regions labelled inside are the
    /// cavity fill's.)
    /// 0 = off. Measured in docs/NOTEBOOK.md, "Visibility labels" (an open part that the fit had
    /// closed into a box of membranes: L2-CD x 100 0.319 -> 0.027).
    int min_label_votes = 4;
    /// The coarse grid's cells far from the zero set are interpolated from their corners, not
    /// evaluated (SdfGridOptions::far_factor, far_levels): only signs are used here, and those the
    /// certification keeps. 0 = evaluate every sample.
    double far_factor = 2.0;
    int far_levels = 3;
};

struct SignRepairStats {
    std::int64_t evaluations = 0;       ///< field values computed on the coarse grid
    int components = 0;                 ///< connected regions of one sign away from the data
    int flipped_components = 0;         ///< of which flipped
    std::int64_t flipped_samples = 0;   ///< coarse samples whose sign was flipped
    int label_flipped = 0;              ///< regions flipped by the visibility labels (min_label_votes)
    double tau = 0;                     ///< the "near the data" distance used (unit-box units)
};

/// The sign correction of one field on one box. Default-constructed: the identity.
class SignRepair {
public:
    SignRepair() = default;

    /// Evaluates `field` on a coarse grid over `box` and decides which regions to flip.
    /// @param field   the fitted field (thread-safe batches, as for evaluate_sdf_grid)
    /// @param box     the box of the fine grid (unit-box coordinates)
    /// @param cloud   a tree over the input cloud (its points: N x 3, same frame, N >= 2)
    /// The zero level set is repaired (pass the field minus the level for another one).
    /// Throws pcp::Error on bad options or a non-finite field value.
    /// @param labels  visibility labels in the same frame, or null
    SignRepair(const SdfBatchFn& field, const Aabb& box, const KdTree& cloud, const SignRepairOptions& options = {},
               const VisibilityLabels* labels = nullptr);

    /// values(i) = field at points.row(i), corrected in place (negated where flipped).
    void apply(const Eigen::Ref<const PointsF>& points, Eigen::Ref<Eigen::VectorXf> values) const;

    const SignRepairStats& stats() const { return stats_; }

private:
    GridSpec spec_;
    /// Per coarse sample: 0 near the data, +-1 kept with that sign, +-2 flipped (original sign +-);
    /// empty when nothing is flipped.
    std::vector<std::int8_t> state_;
    SignRepairStats stats_;
};

}  // namespace pcp
