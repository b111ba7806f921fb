// Oriented normals of the input points from the fitted field (not in the paper): what normal
// orientation tools (Hoppe et al.'s MST, Open3D's tangent-plane orientation, iPSR, GCNO) exist to
// produce, read off the field PCP fits anyway.
//
// Each point gets its PCA normal (normal_k neighbours: the direction, robust to the field's small
// ripples) and a vote of the field on its orientation: s = sum over k in {1, 2, 4} of
// (F(p + k h n) - F(p - k h n)) / (k h), weighted 1, 1/2, 1/4 and scaled so that a signed distance
// growing along n votes 1, with h = probe x scale, or noise_probe standard deviations of the
// neighbours along the normal when that is more. A point where |F| exceeds max(zero_set x scale, h)
// is not on the field's zero set and does not vote. Points whose vote is weak (|s| <
// confident_vote: the field is flat or unsigned there, as across a plugged hole or inside a noise
// band) take the orientation of their neighbours, spread best-first (most parallel normals first)
// from the confident points; a point no spread reaches keeps the sign of its own vote.
//
// With a field positive outside (the pipeline's convention after its global sign decision) the
// normals point outward. The winding-number sign (winding_sign.hpp) orients its points this way.
#pragma once

#include "pcp/cloud/kdtree.hpp"
#include "pcp/cloud/visibility.hpp"
#include "pcp/core/types.hpp"
#include "pcp/mesh/grid/sdf_grid.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <string>

namespace pcp {

/// Where pcp::reconstruct takes the oriented normals of the input points from (pcp/reconstruct.hpp).
enum class NormalSource { Mesh, PcaByMesh, Field };
/// "mesh" | "pca" | "field"; throws pcp::Error on anything else.
NormalSource parse_normal_source(const std::string& name);
std::string to_string(NormalSource source);

struct FieldNormalsOptions {
    int normal_k = 16;      ///< neighbours of the PCA normal (3..64)
    double probe = 0.25;    ///< orientation probe step h in units of the sampling scale (> 0)
    double noise_probe = 3.0;  ///< ... or this many standard deviations of the points along the normal, when more (>= 0)
    double zero_set = 0.25;  ///< a point votes only when |F| there is at most this (units of the sampling scale, >= 0)
    double confident_vote = 0.5;  ///< a point whose vote is below this (1: a signed distance) takes its neighbours' orientation (>= 0)
};

struct FieldNormalsStats {
    std::int64_t points = 0;             ///< oriented points
    std::int64_t confident = 0;          ///< of which with a confident vote of their own
    std::int64_t weak_orientation = 0;   ///< of which oriented by their neighbours (their own vote below confident_vote)
    std::int64_t against_own_vote = 0;   ///< of which oriented against the sign of their own vote
    double seconds = 0;
};

struct FieldNormals {
    PointsF normals;          ///< N x 3 unit normals, in the order of the tree's points
    Eigen::VectorXd votes;    ///< N, each point's own vote (0: off the zero set)
    Eigen::VectorXf thickness;  ///< N, the standard deviation of the neighbours along the normal
    NeighborIndices neighbours;  ///< N x normal_k, the PCA neighbourhoods (each point first)
    FieldNormalsStats stats;
};

/// Orients the PCA normals of the tree's points by `field` (thread-safe batches, the tree's frame,
/// negative inside). Throws pcp::Error on bad options, fewer than normal_k + 1 points, or a
/// non-finite field value near the points.
FieldNormals orient_normals_by_field(const SdfBatchFn& field, const KdTree& cloud, const FieldNormalsOptions& options = {});

/// Orients the PCA normals of the tree's points by visibility labels over the same frame
/// (pcp/cloud/visibility.hpp) instead of a field: a point's vote is the mean over probes at 1, 2, 3
/// and 4 label cells along +n and -n of (label(p + t n) - label(p - t n)) / 2, so outside along +n
/// and inside along -n votes 1, outside against unknown 0.5, and a thin part seen from both sides
/// (outside on both) 0; weak votes are spread as in orient_normals_by_field. Normals point to the
/// outside. Throws pcp::Error on bad options, an empty label grid or too few points.
FieldNormals orient_normals_by_labels(const VisibilityLabels& labels, const KdTree& cloud, const FieldNormalsOptions& options = {});

/// The fraction of the tree's points whose own vote is confident (|vote| >= confident_vote, as
/// counted in FieldNormalsStats::confident), estimated on at most `max_points` of them, drawn
/// uniformly without replacement (a fixed seed): each vote is the one orient_normals_by_field gives that point
/// (up to the rounding of the field's batches), at a fraction of its cost. Throws pcp::Error as
/// orient_normals_by_field does, and for max_points < 1.
double confident_vote_fraction(const SdfBatchFn& field, const KdTree& cloud, const FieldNormalsOptions& options,
                               Eigen::Index max_points);

/// The outward normals of a closed, outward-oriented mesh (counter-clockwise faces) at the mesh
/// points nearest to `points` (N x 3, the mesh's frame): the area-weighted vertex normals
/// interpolated barycentrically on the nearest triangle, normalised. Throws pcp::Error for a mesh
/// without faces.
Points mesh_normals_at(const Mesh& mesh, const Eigen::Ref<const Points>& points);

/// The unit PCA normals (unoriented) of the tree's points from their k nearest points (3..64).
PointsF pca_normals(const KdTree& cloud, int k);

/// Throws pcp::Error naming `what` when an option is out of range.
void check_field_normals_options(const FieldNormalsOptions& options, const char* what);

}  // namespace pcp
