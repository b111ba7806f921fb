// Surface fit: the extracted mesh brought onto the data it was made from (not in the paper).
//
// The zero level set of the fitted field carries the network's own error: ripples of a few tenths
// of a point spacing on flat faces (the "roughness" of pcp_eval --diagnose), a small systematic
// offset, and pieces of surface where the field crosses zero away from any input point (floating
// components). Both are measured on the shared cases (docs/NOTEBOOK.md, "The surface fit").
// This stage, run on the marching-cubes mesh in the unit box, removes them using the input cloud
// only:
//
//  1. Support filter. A vertex is supported when an input point lies within support_k x scale
//     (scale: the median over the input points of the distance to their 10th nearest point, about
//     3.7 x the nearest-neighbour spacing of an even sampling, which the denoiser's collapsed
//     pairs do not shrink; 0.8 x scale is pcp_eval --diagnose's 3 spacings). A connected component
//     whose supported vertices are fewer than min_supported of its vertices
//     has no data under it and is removed. So is a component (not the largest) whose bounding box's
//     diagonal is under min_extent_k x scale: a few points' worth of surface, a bubble or a sliver
//     of the field along a sharp edge, no shape the data can resolve. So is a component (not the
//     largest) whose every vertex lies within blister_k x scale of the largest one's vertices: a
//     blister, a second sheet where the largest already has the surface. Nothing else is removed.
//  2. Normal mean-shift, `iterations` times. For each supported vertex v with unit normal n (area
//     weighted, averaged over its one-ring) take its `neighbors` nearest input points p_i, their
//     offsets o_i = (p_i - v) . n and distances d_i, h = the largest d_i and b = bandwidth x the
//     10th smallest d_i. The new offset is the mode of the o_i nearest to 0 found by mean shift
//     with weights exp(-(d_i/h)^2) exp(-((o_i - m)/b)^2): the average of the data of the vertex's
//     own sheet, so noise averages out and the other side of a thin part (at an offset of its
//     thickness) carries little weight. A move the data cannot tell from noise is shrunk
//     (`shrink`). v moves by m along n (|m| <= h). Vertices with no input point within move_k x
//     scale do not move along n.
//  3. Then a tangential relaxation (a fraction `relax` of the one-ring Laplacian with its normal
//     part removed) keeps the triangles well shaped without moving the surface.
//
// Topology is unchanged by steps 2-3 (vertices move, faces stay).
#pragma once

#include "pcp/cloud/kdtree.hpp"
#include "pcp/core/types.hpp"

#include <cstdint>

namespace pcp {

struct SurfaceFitOptions {
    bool enabled = true;          ///< off: the mesh is returned as it is
    double support_k = 0.8;       ///< support radius in units of the sampling scale (0.8: about 3 spacings of an even sampling)
    double min_supported = 0.1;   ///< a component with fewer supported vertices than this fraction is removed
    double min_extent_k = 1.0;    ///< a component (not the largest) whose bounding-box diagonal is under this x scale is removed
    double blister_k = 1.0;       ///< a component (not the largest) within this x scale of the largest everywhere is removed (0: never)
    double move_k = 1.5;          ///< a vertex moves only when an input point lies within move_k x scale
    int iterations = 10;          ///< normal mean-shift + relaxation rounds (0: support filter only)
    /// Input points per vertex (>= 3): 16 on clean clouds; pcp::reconstruct uses more on the
    /// clouds it denoised (NoisyCloudOptions::fit_neighbors).
    int neighbors = 16;
    double bandwidth = 1.0;       ///< the offset kernel's width, in units of the vertex's distance to its 10th nearest point
    double relax = 0.5;           ///< tangential relaxation per round, in [0, 1]
    /// The last this many rounds (>= 0) take each input point's offset to the mesh's surface
    /// instead: its signed distance to the mesh, negative behind its nearest face (not in the
    /// paper). The points within h of a vertex on a curved surface lie below its tangent plane
    /// by about d^2 / 2R, so the mean shift along the normal pulls a convex surface in (shrinkage;
    /// a rounded edge is the extreme case), while the offsets to the surface are zero on average
    /// where the surface is on the data. They do not see a single vertex's step, which the
    /// tangent-plane rounds smooth, so only the last round uses them: on a noisy sphere the bias
    /// -0.00035 -> -0.00015; on the shared cases (docs/NOTEBOOK.md, "The fit's last round against
    /// the surface") L2-CD lower on 11 of 13 with NC unchanged; two such rounds cost NC.
    int surface_rounds = 1;
    bool shrink = true;           ///< scale each move m by max(0, 1 - se^2 / m^2), se the standard error of the mean offset
    /// The far side of a thin part left out (not in the paper): with noise_spread > 0 (or 0 and
    /// far_side_clean), every round
    /// assigns each input point to its nearest mesh vertex, and a vertex's mean shift skips the
    /// neighbours assigned to a vertex whose normal faces the other way and that lies more than
    /// far_side_k x noise_spread behind it along its normal. Within the noise the two sides' points
    /// overlap (a plate whose thickness is a few deviations of its noise) and the far side's pull
    /// the mode inward; nearer than that (a bar about as thick as its noise) the cut would
    /// truncate each side's own noise and push the surface out, so it is left alone there.
    /// pcp::reconstruct passes the spread the recentring measured (RecentreStats::spread; noisy
    /// clouds); 0 = off. Measured (docs/NOTEBOOK.md, "The fit without the far side of a thin
    /// part"): k = 3 against no cut and against k = 0.
    double noise_spread = 0;      ///< the noise's spread, in the cloud's units (>= 0; 0: clean data, see far_side_clean)
    /// The far side left out on clean data too (noise_spread 0): every point nearest to a vertex
    /// that faces away (normals' cosine below far_side_clean_cos) and lies more than
    /// far_side_clean_gap_k x the sampling scale behind the vertex. A part as thin as the sampling
    /// (a statue's tail or ear 1-2 spacings across) has its far side within the fit's window and
    /// its mode between the sides: the mean shift crumpled such a tail into a twisted ribbon and
    /// roughened the ears (docs/NOTEBOOK.md, "Thin limbs of clean statues"). false: no
    /// cut without a spread (the fit before).
    bool far_side_clean = true;
    /// The clean cut's cosine ([-1, 0]): only sides facing nearly opposite. With 0 (the noisy
    /// cut's) the faces meeting at a CAD part's sharp edges cut each other's points: NC -0.002..-0.004.
    double far_side_clean_cos = -0.8;
    /// The clean cut's gap (>= 0, sampling scales). With none, the two sides of a sheet sampled as
    /// one layer, which the move back lays on the same points, split those points between them
    /// (the scratch shell chair's NC -0.002); 1 scale leaves a tail one spacing thick crumpled.
    double far_side_clean_gap_k = 0.25;
    double far_side_k = 3.0;      ///< (>= 0)
};

struct SurfaceFitStats {
    std::int64_t components = 0;          ///< connected components before the filter
    std::int64_t removed_components = 0;  ///< removed by the support filter (with the small ones)
    std::int64_t removed_small = 0;       ///< of which smaller than min_extent_k x scale
    std::int64_t removed_blisters = 0;    ///< of which lying within blister_k x scale of the largest
    std::int64_t removed_faces = 0;
    std::int64_t supported_vertices = 0;  ///< vertices within move_k x scale of the data (those the last round moved)
    double mean_shift = 0;                ///< mean |m| of the last round (unit-box units)
    double scale = 0;                     ///< the cloud's sampling scale (pcp::sampling_scale)
};

/// The mesh after the support filter and the fit (see above). `unit_mesh` and `cloud` are in the
/// same frame (the unit box). Throws pcp::Error for bad options, a face index out of range or a
/// vertex that is not finite.
Mesh fit_surface_to_points(const Mesh& unit_mesh, const KdTree& cloud, const SurfaceFitOptions& options = {},
                           SurfaceFitStats* stats = nullptr);

}  // namespace pcp
