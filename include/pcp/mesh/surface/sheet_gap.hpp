// The two sides of a thin part kept apart (not in the paper).
//
// A part thinner than the data resolves (a zero-thickness shell: a chair's moulded seat, a bowl, a
// lamp shade sampled as one layer of points) comes out of marching cubes as a thin closed slab
// around the data: the thin offset (ReconstructOptions::thin_offset) extracts at F = d near the
// data. The stages after it then bring both sides back onto the data: the move back by d, the
// surface fit, which puts every vertex on the plane of the points under it. Both sides end on the
// same plane, crossed about half the time (a scratch shell chair and bowl: median separation 0, 48-53 %
// of the vertices with an opposite side near them on its wrong side): a self-intersecting mesh that
// every renderer shows as a mottle of front and back faces, and that no mesh tool accepts as a
// solid's boundary.
//
// This stage moves the two sides apart to a gap of at least min_gap, symmetrically about where they
// are, in a few Jacobi passes. Per pass and vertex i (unit normal n_i, area weighted over the
// one-ring): the partner is the nearest vertex j (within search x the gap plus an edge) whose normal
// opposes n_i (n_i . n_j <= opposite_cos) and that lies at most `lateral` mean edge lengths off the
// line through i along n_i. Their separation along n_i is s = (p_i - p_j) . n_i: positive for a thin
// solid, negative when the sides crossed. A narrow gap between two walls facing each other looks
// the same locally as a crossing (s < 0 either way); the two differ in what lies between them,
// which the `solid` callback tells: the midpoint is inside the solid that marching cubes extracted
// (its value < 0) for a crossed or thin solid, outside for a gap. Where s < min_gap and the midpoint
// is inside, i moves by (min_gap - s) / 2 along n_i (its partner, finding i, the other way), by at
// most max_move x min_gap in all: sides crossed deeper than that are not a thin part's sides laid
// on the same data but a crumpled pocket of a noisy scan, whose walls would walk.
//
// Parts thicker than min_gap are not touched, nor gaps between walls, nor vertices without an
// opposite side near them.
#pragma once

#include "pcp/core/types.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <functional>

namespace pcp {

struct SheetGapOptions {
    bool enabled = true;
    /// pcp::reconstruct: only near the points whose thin level ReconstructOptions::thin_probe
    /// raised (the solid callback says NaN elsewhere); set for the clouds it denoised, where the
    /// sides that meet elsewhere are a noisy field's crumpled pockets, which moving apart roughens.
    bool where_raised_only = false;
    double min_gap = 0.002;       ///< least separation of the two sides (unit-box units, the cloud's longest edge 1; > 0)
    int passes = 4;               ///< Jacobi passes (1..100)
    double opposite_cos = -0.7;   ///< n_i . n_j at most this for a partner ([-1, 0))
    double lateral = 1.0;         ///< partner at most this x the mean edge length off i's normal line (> 0)
    double search = 3.0;          ///< partners within search x min_gap + 2 mean edge lengths of i (> 0)
    double max_move = 1.5;        ///< a vertex moves at most this x min_gap in all passes (> 0)
};

struct SheetGapStats {
    std::int64_t paired = 0;      ///< vertices with a partner in the first pass
    std::int64_t crossed = 0;     ///< of which on the wrong side of it (s < 0) with the solid between them
    std::int64_t moved = 0;       ///< vertices moved in any pass
    double max_move = 0;          ///< the largest total move of a vertex (unit-box units)
    double seconds = 0;
};

/// Value of the extracted solid at a point: negative inside, positive outside, NaN unknown (then
/// nothing moves there). Called from several threads at once.
using SolidFn = std::function<float(const Eigen::Vector3d&)>;

/// `unit_mesh` with the sides of its thin parts at least options.min_gap apart (see above). Faces
/// unchanged. Throws pcp::Error for bad options or a face index out of range.
Mesh keep_sheets_apart(const Mesh& unit_mesh, const SolidFn& solid, const SheetGapOptions& options = {},
                       SheetGapStats* stats = nullptr);

}  // namespace pcp
