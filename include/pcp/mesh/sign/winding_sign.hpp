// Winding-number sign: the inside/outside of the fitted field decided away from the data by the
// generalised winding number of the input points, oriented by the field itself (not in the paper).
//
// The pulling loss fixes |F| and the direction of its gradient near the data, never the sign of a
// region (sign_repair.hpp): a fitted field may leave a layer of the wrong sign under the surface (an
// inner sheet), a plug of "inside" across a through-hole, or a bubble. Those are decided here by a
// global, hole-tolerant vote instead of a local one:
//
//  1. Oriented normals: the PCA normals of the input points oriented by visibility labels
//     (orient_normals_by_labels, field_normals.hpp: the side of a point whose label cells the rays
//     see outside; the pipeline's default), or by the field's own votes (orient_normals_by_field:
//     where the field is a signed distance near the data the vote gives the outward normal). The
//     field is the weaker witness in practice: around noisy data it fits a thin negative shell with
//     no growth across the points, and on every shared case fewer than half of them vote
//     confidently (docs/NOTEBOOK.md, "The winding number of points oriented by visibility"),
//     where the labels orient 69-88 % of the points of clean statues, clean CAD parts and the
//     noisy scans whose parts are thick.
//     When fewer than min_confident of the points vote confidently (thin parts seen from both
//     sides, a very noisy cloud) nothing is corrected (stats.skipped).
//     When the oriented points enclose a negative volume (the field is negative outside), every
//     normal is turned, so that w below is 1 inside whatever the field's convention.
//  2. The generalised winding number of the oriented points (Barill et al. 2018, for point clouds):
//     w(q) = sum_i a_i n_i . (p_i - q) / (4 pi |p_i - q|^3), a_i = pi r_i^2 with r_i the distance to
//     the 8th nearest other point over sqrt(8) (the share of the surface one point stands for).
//     About 1 inside a closed surface and 0 outside; a hole in the data only blurs it near the hole.
//     Evaluated by a Barnes-Hut tree (first-order dipoles, opening ratio `opening`).
//  3. apply(): a value of the field at a point farther than tau = near_k x sampling_scale from every
//     input point is given the sign the winding number says when it is clear (w > 0.5 + margin:
//     inside, negative; w < 0.5 - margin: outside, positive); |F| is unchanged. Nearer the data, and
//     where w is unclear, the field keeps its own sign, so the surface through the data stays where
//     F puts it; but with labels, a cell labelled outside is outside whatever w (a bore whose
//     wall the scanner missed: the part around it makes its middle look half enclosed).
//
// The pipeline applies it to the sign repair's result, not before the repair: the repair's regions
// are the fitted field's (src/pipeline/reconstruct.cpp).
#pragma once

#include "pcp/cloud/kdtree.hpp"
#include "pcp/core/types.hpp"
#include "pcp/mesh/sign/field_normals.hpp"
#include "pcp/mesh/grid/sdf_grid.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <memory>

namespace pcp {

struct WindingSignOptions {
    /// Off here (apply() is the identity, nothing is computed); the default and fast presets turn
    /// it on, the scene preset off (docs/NOTEBOOK.md, "The winding-number sign on").
    bool enabled = false;
    /// pcp::reconstruct orients the points by its visibility labels when it has them (the label
    /// vote's, on by default), else by the field (docs/NOTEBOOK.md, "The winding number of points
    /// oriented by visibility").
    bool orient_by_labels = true;
    FieldNormalsOptions normals;  ///< the PCA normals and the field's vote on their orientation (field_normals.hpp)
    double min_confident = 0.5;   ///< fewer confident points than this fraction: the field cannot orient the cloud, nothing is corrected
    /// The skip decided first on a sample: on a cloud of more than 2 x precheck_points points the
    /// confident fraction is estimated on precheck_points of them (confident_vote_fraction), and
    /// below min_confident - precheck_slack the cloud is skipped without orienting every point
    /// (about 7 field values per point). Its standard error is at most 0.5 / sqrt(precheck_points)
    /// (0.011 at 2048): a cloud the whole count would correct lies 4.5 of them above the skip, so
    /// the sample all but never skips it. 0: every point oriented first, as before.
    int precheck_points = 2048;
    double precheck_slack = 0.05;
    double near_k = 0.4;    ///< tau in units of the sampling scale (0.4: about 1.5 spacings of an even sampling)
    /// tau near the points the labels' spread oriented (0.8: about 1.8 median spacings of a scan,
    /// 3 of an even sampling): where they oriented thin parts by their neighbours, their flips
    /// within two spacings of the data were right 80-87 % of the time, farther 97-100 % (a
    /// statue's ears got handles at 0.4). At 1.0 a positive layer the field leaves under a face of
    /// a thin part stayed, open to the air by pinholes (a CAD part with thin edges went from genus
    /// 0 to 2; docs/NOTEBOOK.md, "The sign repair before the winding number"); 0.6 and 0.8 keep
    /// both whole.
    double labels_near_k = 0.8;
    double margin = 0.2;    ///< the winding number decides where |w - 0.5| > margin (0..0.5)
    double opening = 3.0;   ///< Barnes-Hut: a node is one dipole when its distance > opening x its radius (>= 1)
};

struct WindingSignStats {
    std::int64_t points = 0;             ///< oriented input points
    std::int64_t confident = 0;          ///< of which with a confident vote of their own
    bool skipped = false;                ///< too few confident votes (min_confident): apply() is the identity
    std::int64_t sampled = 0;            ///< skipped on a sample of this many points (confident: its estimate over all points); 0: counted on all
    std::int64_t weak_orientation = 0;   ///< of which oriented by their neighbours (their own vote below confident_vote)
    std::int64_t against_own_vote = 0;   ///< of which oriented against the sign of their own vote
    bool by_labels = false;              ///< the normals were oriented by visibility labels (else by the field)
    bool inward = false;                 ///< the field oriented the normals inward (negative outside): all were turned
    double tau = 0;                      ///< the distance beyond which the winding number decides
    double seconds = 0;                  ///< normals, orientation and tree
};

/// The winding-number sign correction of one field over one cloud. Default-constructed: the identity.
class WindingSign {
public:
    WindingSign();
    /// Orients the cloud's normals by `field` (thread-safe batches, unit-box coordinates, negative
    /// inside) and builds the winding-number tree. `cloud`: the input in the same frame, N >= normal_k + 1.
    /// Throws pcp::Error on bad options, too few points or a non-finite field value.
    WindingSign(const SdfBatchFn& field, const KdTree& cloud, const WindingSignOptions& options = {});
    /// The same with the normals oriented by visibility labels over the cloud's frame instead of a
    /// field (orient_normals_by_labels in field_normals.hpp; the pipeline's default): skipped when
    /// fewer than min_confident of the points have a confident vote of their own. apply() then
    /// makes positive every value away from the data in a cell labelled outside, without the
    /// winding number: the middle of a bore whose wall the scanner missed, which the rest of the
    /// part around it makes look half enclosed (w unclear, or above 0.5 + margin: on one scan
    /// 411 of 1.67 million such samples, and those w made inside lay outside the GT, 19 of 19 in
    /// a sample of 20,000 flips); and it decides near a point
    /// whose vote was weak (oriented by its neighbours) only beyond labels_near_k (0.8 sampling
    /// scales; tau elsewhere). The labels are
    /// copied. Throws pcp::Error on bad options, empty labels or too few points.
    WindingSign(const VisibilityLabels& labels, const KdTree& cloud, const WindingSignOptions& options = {});
    ~WindingSign();
    WindingSign(WindingSign&&) noexcept;
    WindingSign& operator=(WindingSign&&) noexcept;

    /// values(i) = field at points.row(i), its sign corrected in place where the winding number
    /// decides (see above). Thread-safe.
    void apply(const Eigen::Ref<const PointsF>& points, Eigen::Ref<Eigen::VectorXf> values) const;

    /// The generalised winding number at each row of `points` (N x 3). Thread-safe; not parallel.
    Eigen::VectorXf winding(const Eigen::Ref<const PointsF>& points) const;

    /// The oriented unit normals of the cloud's points (N x 3, same order as the tree's points).
    const PointsF& normals() const;
    /// The area each point stands for (N; a_i above).
    const Eigen::VectorXf& areas() const;

    const WindingSignStats& stats() const;
    /// Whether apply() can change a value: enabled, and the points oriented (not skipped).
    bool active() const;
    /// Field values whose sign apply() changed so far (all threads).
    std::int64_t corrected() const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

/// The generalised winding number of oriented points with per-point areas, by brute force (the
/// reference of WindingSign's tree): w(q) = sum_i a_i n_i . (p_i - q) / (4 pi |p_i - q|^3).
Eigen::VectorXf winding_number_brute_force(const Eigen::Ref<const PointsF>& points, const Eigen::Ref<const PointsF>& normals,
                                           const Eigen::Ref<const Eigen::VectorXf>& areas,
                                           const Eigen::Ref<const PointsF>& queries);

}  // namespace pcp
