// Cavity fill: enclosed pockets of "outside" in the fitted field are filled (not in the paper).
//
// The pulling loss fixes |F| near the data, never the sign of a region (sign_repair.hpp). On noisy
// scans the fitted field is often a hollow shell: negative in a layer as thick as the noise band,
// positive again in the interior, so marching cubes meshes a second, inward-facing sheet under the
// surface (a noisy scan: 343k faces, 204k after the fill; docs/NOTEBOOK.md, "Cavity fill").
// Both sheets lie within the noise of the data, so the repairs that look for zero crossings away from
// the data cannot see the inner one. A scanner, though, cannot see a closed cavity: a positive region
// that the outside cannot reach is not outside. On the dense fine grid:
//
//  1. The outside: the positive samples reachable from the grid box's faces through samples with
//     F > delta (delta = core_cells x the largest cell spacing): a ball of radius about delta must
//     pass, so the pinholes and tunnels through a thin shell do not let the outside in.
//  2. Cavity cores: the other samples with F > delta.
//  3. Both grow together, one 6-neighbour layer at a time, through the positive samples that remain
//     (so a narrow pocket joined to the outside stays outside, and each tunnel is split where the
//     two fronts meet); positive samples neither reaches are bubbles.
//  4. Pockets: the connected regions of the positive samples not labelled outside (cores, what they
//     grew into, bubbles). A pocket whose boundary is at most max_open open to the outside (pairs
//     with outside samples; the rest are pairs with negative ones) is a cavity behind holes and is
//     negated (|F| kept): the inner sheet and the bubbles vanish, the outer surface stays where the
//     field put it. A pocket more open than that is a bay of the outside the core threshold cut off:
//     filling it would put a sheet where the two fronts met, away from the data, so it stays.
//
// A region of the outside joined to the rest only through a passage narrower than about 2 delta (a
// bottle's inside behind a thin neck) is filled too.
//
// With visibility labels (pcp/cloud/visibility.hpp), what the rays saw bounds the two fronts:
//  - every positive sample labelled outside starts the outside front (step 1): a through-hole whose
//    plug the sign repair flipped keeps the plug's small |F| there, below delta, and its walls
//    make most of its boundary, yet its middle is seen from outside and stays open (the built-in
//    shape's hole, closed by the fill before);
//  - the outside front never enters a sample labelled inside, and the positive samples labelled
//    inside are cavity cores (step 2): the solid between two walls of a noisy scan that the fit
//    left hollow, perforated by tunnels too wide for delta to stop the outside (a noisy scan of a
//    clamp: 226 components and genus 261 without the labels, one component of genus 5 with them);
//  - a pocket whose samples the labels call inside (at least min_label_votes, and at most 1/20 as
//    many called outside) is filled when at most labelled_max_open of its boundary is open: its
//    walls are perforated, not absent. An island of inside labels in the open (most of its
//    boundary open) is a wrong label, not a solid the field missed, and stays;
//  - a pocket the labels call inside that is more open than that is still filled when nearly all
//    of its openings (the outside samples next to it) lie on the data, within support_k x the
//    sampling scale of an input point (`data` given): a wall the field perforated all over, its
//    holes where the data shows a surface (the built-in shape with `--preset fast --seed 2`: the
//    block's interior 0.502 open, 99.8 % of its openings on the data; an island of wrong labels
//    in a noisy scan 0.59 open, none of its openings within one sampling scale).
// Needs every sample of the lattice (a dense grid); otherwise, and above max_samples, nothing is
// done (stats.skipped).
#pragma once

#include "pcp/cloud/kdtree.hpp"
#include "pcp/cloud/visibility.hpp"
#include "pcp/mesh/grid/sdf_grid.hpp"

#include <cstdint>

namespace pcp {

struct CavityFillOptions {
    bool enabled = true;
    double core_cells = 2.0;    ///< delta in units of the largest cell spacing (> 0)
    /// A pocket is filled when at most this fraction of its boundary is open to the outside: 0.5
    /// on clean clouds (a hollow body behind the holes of its shell is filled); pcp::reconstruct
    /// uses less on the clouds it denoised (NoisyCloudOptions::cavity_max_open), where pockets
    /// among the sheets of a noise band are that open too.
    double max_open = 0.5;
    std::int64_t max_samples = std::int64_t(1) << 24;  ///< (R + 1)^3 above this: skipped (R = 128: 2.1e6)
    /// With labels: a pocket with at least this many samples in inside cells (and at most 1/20 as
    /// many in outside cells) is filled up to labelled_max_open. 0 = the labels are ignored.
    int min_label_votes = 4;
    /// A pocket the labels call inside is filled when at most this fraction of its boundary is
    /// open (max_open if that is larger). Measured on the shared cases (docs/NOTEBOOK.md,
    /// "Hollow walls filled by the visibility labels"): the pockets of the wall interiors are
    /// 0.18-0.31 open, the wrong islands of inside labels 0.5-1.0.
    double labelled_max_open = 0.5;
    /// A pocket the labels call inside and more open than labelled_max_open is filled when at
    /// least this fraction of its openings lie within support_k x the data's sampling scale of an
    /// input point (needs the data; above 1: never).
    double supported_openings = 0.9;
    double support_k = 1.0;
};

struct CavityFillStats {
    bool skipped = false;              ///< not a dense grid, or larger than max_samples
    std::int64_t cavity_samples = 0;   ///< lattice samples negated (cavities and bubbles)
    int pockets = 0;                   ///< connected positive regions the outside did not reach
    int cavities = 0;                  ///< of which filled (closed enough)
    int labelled_cavities = 0;         ///< of which filled only because the labels call them inside
    int supported_cavities = 0;        ///< of which more open than labelled_max_open, open only on the data
    double delta = 0;                  ///< the core threshold used (unit-box units)
};

/// Negates the values of the enclosed positive regions of `grid` described above, in place (every
/// stored copy of a sample). `labels`: visibility labels in the grid's frame, or null; `data`: the
/// input points in the grid's frame, or null (then no pocket is filled by its openings' support).
/// Throws pcp::Error for bad options.
CavityFillStats fill_cavities(SdfGrid& grid, const CavityFillOptions& options = {}, const VisibilityLabels* labels = nullptr,
                              const KdTree* data = nullptr);

}  // namespace pcp
