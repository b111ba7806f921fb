// The thin level: the field's level raised near the data, so that thin parts come out whole (not in
// the paper; ReconstructOptions::thin_offset and thin_probe).
//
// Where a part is thinner than the field's error, F_g between its two sides stays just above zero
// and its zero level set is torn into holes and specks. Near the data every mesh stage therefore
// sees F_g - iso - level(q): level = offset within `near_radius` of an input point, fading linearly
// to nothing at twice that radius (a field hovering just above zero away from the data grows no
// sheet there), and the extracted mesh is moved back along its normals by the level at each vertex.
//
// A sheet sampled as one layer of points (a zero-thickness shell: a moulded seat, a bowl) needs
// more: its field has no inside at all, and a slab raised by a fixed offset is thinner than the
// grid's cells where F_g grows fast, so the lattice samples fall on both sides of it and miss it
// (holes in stripes, the moire of the sheet against the lattice). raise_where_thin reads the
// repaired grid (its inside known: the cavity fill has made a hollow solid's inside negative, which
// the raw field, blind to the sign, may leave positive) at each input point p and at two probes
// p +- reach n along its PCA normal. Where p lies outside the extracted solid but not far out (0 <=
// F < reach there: the mesh would miss a point of the data) in a valley of the field (F larger at
// both probes: a sheet that the level does not reach, not a point on the outer fringe of a noisy
// scan's band, where the field falls inward), that point's level becomes offset + the larger probe
// value (at most reach in all), which puts both probes inside. A point inside the solid is never
// raised, nor one where the field falls on one side, nor one with fewer than min_company of its 8
// nearest points (itself included) such candidates: a sheet's points come in patches, the few a
// noisy scan's field gives are scattered (noisy CAD scans: 45-2,400 candidates, most alone;
// raising them cost a thin noisy plate 0.0005 of L2-CD x 100); and nothing at all when fewer than
// min_share of all points are left (a one-layer sheet is a sizeable part of a surface; the few
// patches of a solid's field, raised, add handles: the built-in shape's 16 points, genus 1 -> 6).
// Each point then takes the largest level among
// its 8 nearest points (the points of a sheet that the solid holds between its holes rise with
// them), and those are averaged over the same neighbours (a seam would be a step in the level).
// The grid's samples near the zero set are shifted by the change of the level at their position,
// as if evaluated with it.
#pragma once

#include "pcp/cloud/kdtree.hpp"
#include "pcp/mesh/grid/sdf_grid.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <vector>

namespace pcp {

class ThinLevel {
public:
    /// `offset` >= 0 and `near_radius` >= 0 in the cloud's frame (the unit box); `cloud` must
    /// outlive this object.
    ThinLevel(const KdTree& cloud, float offset, float near_radius);

    /// The level at `p` (0 where offset is 0).
    float operator()(const Eigen::Vector3f& p) const;

    /// Whether the level at the input point nearest to `p`, or at one of that point's 8 nearest, was
    /// raised (false before raise_where_thin).
    bool raised_at(const Eigen::Vector3f& p) const;

    /// Raises the level where the solid of `grid` (values F_g - iso - level, negative inside) has
    /// nothing within `reach` (> 0) of an input point along its PCA normal, and shifts the grid's
    /// samples with |value| <= 2 reach by the change (see above). Returns the points raised (before
    /// averaging). A candidate point with fewer than `min_company` (1..8) of its 8 nearest points
    /// (itself included) candidates is not raised; nothing is raised when fewer than `min_share` of
    /// all points would be. Nothing happens when offset is 0.
    std::int64_t raise_where_thin(SdfGrid& grid, float reach, int min_company = 3, double min_share = 0.0);

    /// Shifts another grid of the same lattice as raise_where_thin shifted its own, by the levels
    /// it raised and with its reach (nothing before it, or when it raised nothing). pcp::reconstruct applies it to the grid the shell centring keeps from before
    /// the cavity fill, which would otherwise take a raised sheet for a hollow the fill closed.
    void shift_like_raise(SdfGrid& grid) const;

private:
    float level_at(const Eigen::Vector3f& p, const std::vector<float>* levels) const;
    void shift_samples(SdfGrid& grid, float reach, const std::vector<float>& levels) const;

    const KdTree& cloud_;
    float offset_, near_;
    std::vector<float> levels_;  // per input point; empty: offset everywhere
    float reach_ = 0;            // raise_where_thin's, once it raised
    std::vector<std::uint8_t> near_raised_;  // per input point: its level or a neighbour's raised
};

}  // namespace pcp
