// Inside / outside from the cloud alone, by visibility (not in the paper): the labels of the sign
// repair's label vote (pcp/mesh/sign/sign_repair.hpp), the cavity fill (cavity_fill.hpp) and the
// winding sign's orientation (winding_sign.hpp).
//
// The pulling loss (METHOD.md §3) is blind to the sign of the field: q - F g/|g| is the same for F
// and -F, so a fit may settle with the inside of a shape positive under a thin negative shell, or
// with a wall's orientation reversed (rounding alone can decide between a good and a bad
// outcome; the built-in shape's hole came out plugged: docs/NOTEBOOK.md, "Visibility labels").
// Which side a point of space is on can be read from the cloud without normals: grow every input
// point into a small ball, so that the sampled surface becomes a closed
// wall of voxels, and cast rays from the point. From the inside of a closed surface no ray gets out;
// from the outside many do. Concretely:
//
//  1. An occupancy grid over the box (occupancy_resolution voxels along its longest edge): a voxel
//     is blocked when it meets the ball of radius dilation x sampling_scale (kdtree.hpp) around an
//     input point. That radius is about twice the distance between neighbouring points, enough to
//     close the gaps of an even sampling, not a hole of the shape.
//  2. Label cells (resolution along the longest edge) whose centre lies farther than
//     min_distance x sampling_scale plus half a cell diagonal from every input point, so that the
//     whole cell is away from the data. From each, `rays` directions (a Fibonacci sphere turned by
//     a random rotation per cell, seeded) are marched through the occupancy grid to the box's faces.
//  3. No ray escapes: inside (-1). At least outside_fraction of them escape, or at least
//     min_through_lines of them escape at both ends (the cell lies on lines that cross no wall: a
//     through-hole): outside (+1). Otherwise (a view out through a hole in the scan, the bottom
//     of a deep slot): unknown (0), and the labels say nothing there.
//  4. The cells not outside then are counted again by ThroughLines (below), exactly, in
//     line_directions fixed directions: with min_free_lines of them free of the balls, outside. A
//     narrow bore's middle sees out along a cone of a few degrees only, which 64 random rays rarely
//     hit (unknown, or inside when none did): the bores of noisy scans whose walls the scanner
//     barely saw. 12 of 1024, not 6: at 6, lines
//     through the gaps of an even sampling (the balls do not close every gap at grazing angles)
//     labelled 11 cells inside a sampled sphere outside.
//
// Wrong labels are possible where no ray can see a true outside (an enclosed cavity, which no
// scanner sees either; thin walls closing small pockets) and where the data has a
// gap wider than the dilation; their users therefore act on a majority of a region's labels (the
// votes) or only near points they orient with confidence.
#pragma once

#include "pcp/cloud/kdtree.hpp"
#include "pcp/core/types.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <memory>
#include <vector>

namespace pcp {

struct VisibilityOptions {
    int resolution = 64;              ///< label cells along the box's longest edge (4..256)
    int occupancy_resolution = 160;   ///< voxels along the longest edge (8..1024)
    double dilation = 0.5;            ///< ball radius around each point, x sampling_scale (> 0)
    double min_distance = 0.5;        ///< cells at least this x sampling_scale (+ half a cell diagonal) from the data (>= 0)
    int rays = 64;                    ///< directions per cell (8..1024)
    /// Escaping fraction that makes a cell outside (0, 1]. 0.5, not less: the inside of a scan seen
    /// through a hole in it (a statue's open base) is otherwise labelled outside.
    double outside_fraction = 0.5;
    /// A cell is outside too when this many of its ray directions escape at both ends (d and -d):
    /// a line through the cell that crosses no wall, which no closed surface of the data allows.
    /// The middle of a through-hole sees out along about a sixth of the directions only (unknown by
    /// outside_fraction), but every one of them is such a line; the inside of a scan seen through
    /// one opening (a statue's open base) has none. 0 = off.
    int min_through_lines = 3;
    /// Step 4: line directions of the exact count (0 = off; else 8..4096) and the free lines among
    /// them that make a cell outside (1..line_directions).
    int line_directions = 1024;
    int min_free_lines = 12;
    std::uint64_t seed = 1;           ///< the per-cell rotations of the ray directions
    double margin = 0.05;             ///< the labelled box: the cloud's box grown by this on every side (>= 0)
};

struct VisibilityStats {
    std::int64_t inside = 0, outside = 0, unknown = 0;  ///< labelled cells (away from the data)
    std::int64_t near = 0;                              ///< cells too near the data to label
    double radius = 0;                                  ///< the dilation radius used (unit-box units)
    double seconds = 0;
};

/// Cells of a regular grid over a box, each -1 (inside), +1 (outside) or 0 (unknown / near the data).
struct VisibilityLabels {
    Eigen::Vector3d origin = Eigen::Vector3d::Zero();  ///< the box's min corner
    double cell = 0;                                   ///< cell edge (cubic cells)
    Eigen::Vector3i dims = Eigen::Vector3i::Zero();    ///< cells per axis
    std::vector<std::int8_t> label;                    ///< x fastest
    std::vector<std::int32_t> inside_cells, outside_cells;  ///< indices of the labelled cells
    VisibilityStats stats;

    /// The cell index of (i, j, k).
    std::size_t index(int i, int j, int k) const {
        return (static_cast<std::size_t>(k) * static_cast<std::size_t>(dims.y()) + static_cast<std::size_t>(j)) *
                   static_cast<std::size_t>(dims.x()) + static_cast<std::size_t>(i);
    }
    Eigen::Vector3d center(int i, int j, int k) const {
        return origin + cell * (Eigen::Vector3d(i, j, k).array() + 0.5).matrix();
    }
    /// The label of the cell that holds p (same frame); 0 outside the grid.
    int label_at(const Eigen::Vector3d& p) const {
        const Eigen::Vector3d u = (p - origin) / cell;
        if ((u.array() < 0.0).any() || u.x() >= dims.x() || u.y() >= dims.y() || u.z() >= dims.z()) return 0;
        return label[index(int(u.x()), int(u.y()), int(u.z()))];
    }
};

/// Labels the cells of `box` (unit-box coordinates, the cloud's box plus a margin) by visibility
/// through the dilated cloud of `tree`. Throws pcp::Error on bad options, an empty or degenerate
/// box, or a tree of fewer than 2 points. OpenMP-parallel over cells; deterministic.
VisibilityLabels label_by_visibility(const KdTree& tree, const Aabb& box, const VisibilityOptions& options = {});

/// The same over the tree's own points' box grown by options.margin on every side.
VisibilityLabels label_by_visibility(const KdTree& tree, const VisibilityOptions& options = {});

/// `n` unit directions spread evenly over the half-sphere z > 0 (a Fibonacci spiral): the line
/// directions of ThroughLines. Throws pcp::Error on n < 1.
std::vector<Eigen::Vector3d> line_directions(int n);

/// The through-line rule of label_by_visibility at single points instead of cells: whether lines
/// through a point cross no wall of the dilated cloud (the balls of radius dilation x
/// sampling_scale around the input points). An occupancy grid of those balls (voxels of edge
/// box.extent().maxCoeff() / occupancy_resolution) gives each point's clearance; the lines are
/// counted without marching: a line along d meets a ball exactly when the ball's disc in the plane
/// across d covers the line's point there, so for each direction the discs are drawn into a bitmap
/// of that plane (pixels of the voxels' edge) and a point's line is free when its pixel is clear.
/// A narrow bore's lines, a cone of a few degrees, are counted by as many directions as point at it,
/// where random rays found them by chance. Thread-safe queries.
class ThroughLines {
public:
    /// `directions` line directions spread evenly over a half-sphere, the same for every point (a
    /// line and its reverse are one line); their bitmaps are drawn here, OpenMP over the directions
    /// (a bitmap's pixels are the voxels' edge, larger when all of them would pass 64 MiB). The
    /// clearance is kept on voxels clearance_factor times coarser (its two raster passes cost
    /// factor^3 times less). Throws pcp::Error on a resolution outside 8..1024, a dilation <= 0,
    /// directions outside 1..4096, a factor outside 1..4, a degenerate box or a tree of fewer than 2
    /// points (or with no spread).
    ThroughLines(const KdTree& tree, const Aabb& box, int occupancy_resolution, double dilation, int directions,
                 int clearance_factor = 1);
    ~ThroughLines();
    ThroughLines(ThroughLines&&) noexcept;
    ThroughLines& operator=(ThroughLines&&) noexcept;

    double voxel() const;   ///< the voxels' edge
    double radius() const;  ///< the dilation radius (unit-box units)
    /// 0 when the voxel holding p is blocked; else the chessboard distance (in voxels, at least 1,
    /// capped at 255) to the nearest blocked one, to the clearance's coarse voxels (a multiple of
    /// clearance_factor, at most that much short); 255 outside the grid.
    int clearance(const Eigen::Vector3d& p) const;
    /// How many of the directions give a line through p that meets no ball: exact for the balls but
    /// for the pixels' size (a line passing within a pixel of a disc counts as blocked); counting
    /// stops at `enough` (> 0).
    int count(const Eigen::Vector3d& p, int enough) const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace pcp
