// Surface fit: the extracted mesh brought onto the data it was made from (not in the paper).
//
// The zero level set of the fitted field carries the network's own error: ripples of a few tenths
// of a point spacing on flat faces (the "roughness" of pcp_eval --diagnose), a small systematic
// offset, and pieces of surface where the field crosses zero away from any input point (floating
// components). Both are measured on the shared cases (docs/BENCHMARKS.md). This stage, run on the
// marching-cubes mesh in the unit box, removes them using the input cloud only:
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
    /// -0.00035 -> -0.00015; on the shared cases (docs/BENCHMARKS.md, "The fit's last round against
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
    /// clouds); 0 = off. Measured (docs/BENCHMARKS.md, "The fit without the far side of a thin
    /// part"): k = 3 against no cut and against k = 0.
    double noise_spread = 0;      ///< the noise's spread, in the cloud's units (>= 0; 0: clean data, see far_side_clean)
    /// The far side left out on clean data too (noise_spread 0): every point nearest to a vertex
    /// that faces away (normals' cosine below far_side_clean_cos) and lies more than
    /// far_side_clean_gap_k x the sampling scale behind the vertex. A part as thin as the sampling
    /// (a statue's tail or ear 1-2 spacings across) has its far side within the fit's window and
    /// its mode between the sides: the mean shift crumpled such a tail into a twisted ribbon and
    /// roughened the ears (docs/BENCHMARKS.md, "The far side left out on clean clouds"). false: no
    /// cut without a spread (the fit before).
    bool far_side_clean = true;
    /// The clean cut's cosine ([-1, 0]): only sides facing nearly opposite. With 0 (the noisy
    /// cut's) the faces meeting at fandisk's sharp edges cut each other's points: NC -0.002..-0.004.
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

/// Recentring onto the noise's middle (not in the paper), run on the marching-cubes mesh before the
/// fit (pcp::reconstruct: on the meshes of noisy, denoised clouds). On noisy scans the zero set
/// sits systematically inside the data: the denoiser, the shell centring and the fit's own-side
/// mode all lean away from the far side of a thin part, and the fit's kernel is narrower than the
/// noise, so it cannot see a bias of a few tenths of a spacing (pcp_eval --diagnose: 0.0017-0.0051
/// inside the ground truth on 7 of the 11 noisy shared cases, while the raw points lie on it or
/// outside it: median signed distance -0.0001 to +0.0021 on the four measured). Per pass:
///  1. every input point is assigned to its nearest mesh vertex and gets its signed offset along
///     that vertex's normal (positive: outside); offsets beyond clip_k x the noise's spread (1.4826
///     x the offsets' median absolute deviation from their median) are not counted (parts the
///     mesh misses, outliers);
///  2. per vertex, the offsets' sum and count are averaged over the mesh by rounds of one-ring
///     averaging, as many as make the window about window_k x the sampling scale wide
///     (2 (window_k scale / mean edge)^2 rounds, at most 400), so that hundreds of points enter
///     each mean: noise averages out and a bias common to a region is left;
///  3. every vertex with a count moves along its normal by the window's mean offset m, in full
///     while |m| <= max_move_k x the spread, fading linearly to no move at twice that: the bias is
///     a fraction of the noise (on abc_00010074's plate 99 % of the moves are under 0.7 spreads),
///     a mean offset beyond it is a sheet away from the data (an inner sheet or a membrane across
///     a bore: abc_00010071's seed 3 went 0.031 -> 0.062 when those moved in full).
/// Each point counts for the surface it is nearest to, so the far side of a thin part stays with
/// its own side. Topology is unchanged (vertices move, faces stay).
struct RecentreOptions {
    bool enabled = false;   ///< pcp::reconstruct: clean clouds' meshes (NoisyCloudOptions::recentre for the clouds it denoised)
    double window_k = 2.0;  ///< the averaging window's width in units of the sampling scale (> 0)
    int passes = 2;         ///< assignment + move rounds, in [1, 20]
    double clip_k = 2.5;    ///< offsets beyond this x the robust spread are not counted (> 0)
    double max_move_k = 0.5;  ///< moves fade from this x the spread to none at twice it (> 0)
};

struct RecentreStats {
    bool applied = false;   ///< the stage ran (pcp::reconstruct fills it)
    double spread = 0;      ///< the last pass's spread of the offsets (1.4826 x their MAD, unit-box units)
    double mean_move = 0;   ///< the mean signed move along the normals, summed over the passes (unit-box units; + outward)
    int rounds = 0;         ///< averaging rounds per pass
};

/// The mesh recentred onto `cloud` (see RecentreOptions). `unit_mesh` and `cloud` in the same frame
/// (the unit box). Throws pcp::Error for bad options or a face index out of range.
Mesh recentre_on_points(const Mesh& unit_mesh, const KdTree& cloud, const RecentreOptions& options = {},
                        RecentreStats* stats = nullptr);

/// Fairing where there is no data (not in the paper), run last on the meshes of objects. Where no
/// input point lies under the surface, its shape is the fitted field's guess: on the shared cases
/// crumpled sheets and ragged rims at the scans' borders (abc_00010071's barely scanned bore end,
/// the gargoyle's edges, docs/BENCHMARKS.md "Fairing where there is no data"). Every vertex with
/// fewer than support_count input points within support_k x the sampling scale (the surface fit's
/// support radius) is placed instead as the smoothest surface that joins the supported rest: the solution of
/// L A^-1 L x = 0 on those vertices with the supported ones fixed, L the cotangent Laplacian and A
/// the vertex areas (the thin-plate energy), so that the patch continues its border's position and
/// slope. Measured against it (docs/BENCHMARKS.md): the membrane L x = 0 flattens the patches
/// (worse on the shared cases), and the graph Laplacian (uniform weights) depends on the
/// triangles' shapes (a raw marching-cubes sphere's unsupported cap came out twice as flat). A
/// patch of free vertices that touches no supported vertex has nothing to join and stays where it
/// is (the surface fit removes such components before). Topology is unchanged (vertices move,
/// faces stay). Cost: a sparse Cholesky factorisation over the free vertices (0.1 s for 10,000).
struct FairOptions {
    bool enabled = true;     ///< pcp::reconstruct runs it on every mesh but the scene mode's (which trims those faces)
    double support_k = 0.8;  ///< a vertex is supported with support_count input points within this x the sampling scale (> 0)
    /// Input points a supported vertex needs within that radius (>= 1; an even sampling puts about
    /// 6 there). One stray point of a noisy scan's spread is not data under the surface: with 1,
    /// the strays scattered inside abc_00010071's barely scanned bore held the field's guess of its
    /// wall in place, a bulge into the bore on seed 2 (docs/BENCHMARKS.md, "Two points under a
    /// supported vertex").
    int support_count = 2;
    /// A patch is left as it was if a vertex of its solution leaves the box of the patch's vertices
    /// and their one-rings grown by this x the box's diagonal (>= 0; an ill-conditioned solve, never
    /// seen at 128 cells on the shared cases).
    double guard = 0.5;
};

struct FairStats {
    std::int64_t free_vertices = 0;  ///< vertices placed by the fairing
    std::int64_t patches = 0;        ///< connected patches of them
    std::int64_t unanchored = 0;     ///< unsupported vertices left in place: their patch touches no supported vertex
    std::int64_t reverted = 0;       ///< patches left as they were by the guard (FairOptions::guard); not in patches
    double mean_move = 0;            ///< mean distance the placed vertices moved (unit-box units)
    bool failed = false;             ///< the sparse solve failed (not seen on any shared case): the mesh was left as it was
};

/// The mesh faired where it has no data under it (see FairOptions). `unit_mesh` and `cloud` in the
/// same frame (the unit box). Throws pcp::Error for bad options, a face index out of range or a
/// vertex that is not finite.
Mesh fair_unsupported(const Mesh& unit_mesh, const KdTree& cloud, const FairOptions& options = {}, FairStats* stats = nullptr);

/// Every vertex moved by `distance` along its unit normal (area weighted, averaged over its
/// one-ring, as the fit's; positive: outward). Faces unchanged. pcp::reconstruct uses it to
/// bring a mesh extracted at the level F = d back by d (ReconstructOptions::thin_offset).
Mesh offset_along_normals(const Mesh& mesh, double distance);

/// The same with a distance per vertex (`distances`: one per vertex, finite).
Mesh offset_along_normals(const Mesh& mesh, const Eigen::VectorXd& distances);

/// The unit vertex normals those moves use (area weighted, averaged over the one-ring; zero where
/// undefined), V x 3.
Points mesh_vertex_normals(const Mesh& mesh);

/// Open boundaries where the data ends (the scene mode, ReconstructOptions::scene): keeps the faces
/// whose centroid has an input point within `radius` (unit-box units, like `unit_mesh` and
/// `cloud`), drops the others and the vertices no kept face uses. A signed field closes every
/// surface; a room's walls are seen from one side and its data ends at doors and wall tops, so
/// the faces that close it there rest on no data. `removed` (if not null) gets the faces dropped.
Mesh trim_unsupported_faces(const Mesh& unit_mesh, const KdTree& cloud, double radius, std::int64_t* removed = nullptr);

/// The components (connected by faces), all but the one with the most vertices, whose bounding-box
/// diagonal is under `min_diagonal`, removed; unused vertices dropped. pcp::reconstruct runs it
/// last with SurfaceFitOptions::min_extent_k x the sampling scale: the fit's support filter
/// applies that rule to the extracted mesh, but the fit and the smoothing then shrink a marching
/// cubes octahedron around a lone inside sample beside the data to a point (abc_00016513, seed 2:
/// an 8-face component of area 2e-32 in the output). `removed` (optional) receives the number of
/// components removed. Throws pcp::Error for a negative or non-finite `min_diagonal` or a face
/// index out of range.
Mesh remove_small_components(const Mesh& mesh, double min_diagonal, std::int64_t* removed = nullptr);

}  // namespace pcp
