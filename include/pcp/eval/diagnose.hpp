// The error budget of one reconstruction (pcp_eval --diagnose): where the Chamfer distance of
// evaluate() comes from. The predicted surface is split into its connected components (area,
// Euler characteristic, genus) and, given the input cloud, into area near the data and area away
// from it ("unsupported"; a component mostly unsupported is "floating"). The accuracy half of
// L2-CD is split into the part on unsupported / floating area and the rest, whose signed offset
// and roughness against the GT are reported; the completeness half into missing surface (GT area
// with no predicted surface near it) and the rest. Distances are in evaluate()'s frame, so the
// pieces add up to its L2-CD for the same protocol, sample count and seed.
#pragma once

#include "pcp/core/types.hpp"
#include "pcp/eval/eval.hpp"

#include <cstdint>
#include <vector>

namespace pcp {

struct DiagnoseOptions {
    EvalProtocol protocol = EvalProtocol::P2S;  ///< the frame and default sample count, as in EvalOptions
    Eigen::Index samples = 0;                   ///< surface samples per side; 0 = the protocol's count
    std::uint64_t seed = 1;                     ///< pred samples use seed, GT samples seed + 1 (as evaluate())
    /// "Near the data": a predicted sample is supported when an input point lies within
    /// support_k x spacing, where spacing is the input's median nearest-neighbour distance (without
    /// an input cloud: the median nearest-neighbour distance of the GT samples).
    double support_k = 3.0;
    /// Missing surface: a GT sample is missing when the predicted mesh (exact point-to-triangle
    /// distance) is farther than near_k x spacing.
    double near_k = 3.0;
    /// A predicted component is floating when more than this fraction of its area is unsupported.
    double floating_fraction = 0.5;
};

/// One connected component of a mesh (faces connected through shared vertices, after welding
/// vertices at exactly equal positions).
struct ComponentInfo {
    Eigen::Index faces = 0, vertices = 0, edges = 0;
    double area = 0;                    ///< in the evaluation frame
    std::int64_t euler = 0;             ///< V - E + F
    std::int64_t boundary_edges = 0;    ///< edges not shared by exactly two faces (boundary or non-manifold)
    bool closed = false;                ///< closed, edge-manifold, consistently oriented (MeshTopology)
    int genus = -1;                     ///< (2 - euler) / 2 when closed; -1 when not (not meaningful)
    double unsupported_fraction = -1;   ///< of its area; -1 without an input cloud
    bool floating = false;              ///< unsupported_fraction > floating_fraction
};

/// Connected components of `mesh` sorted by decreasing area (faces index its vertices; vertices at
/// exactly equal positions are welded first, so meshes with duplicated positions count correctly).
std::vector<ComponentInfo> mesh_components(const Mesh& mesh);

struct Diagnosis {
    double frame_scale = 1;         ///< as EvalResult::frame_scale
    Eigen::Index samples = 0;       ///< per side
    bool has_input = false;
    double spacing = 0;             ///< input (or GT-sample) median nearest-neighbour distance, evaluation frame
    double support_radius = 0;      ///< support_k x spacing
    double near_threshold = 0;      ///< near_k x spacing

    std::vector<ComponentInfo> pred_components, gt_components;  ///< sorted by decreasing area
    double pred_area = 0, gt_area = 0;

    // Support (input cloud given; zero otherwise).
    double unsupported_area_fraction = 0;  ///< of the predicted area, by samples
    Eigen::Index floating_components = 0;
    double floating_area = 0;              ///< total area of the floating components
    double floating_area_fraction = 0;     ///< of the predicted area

    // The Chamfer split, squared distances as in Metrics::chamfer_l2 (each piece is
    // 0.5 x sum of d^2 / samples), so that the four pieces add up to chamfer_l2.
    double chamfer_l2 = 0;
    double accuracy_l2 = 0;            ///< pred -> GT half
    double accuracy_away_l2 = 0;       ///< ... from samples that are unsupported or on floating components
    double accuracy_main_l2 = 0;       ///< ... from the rest (the main surface)
    double away_sample_fraction = 0;   ///< fraction of pred samples counted as away
    double offset = 0;                 ///< main surface: mean signed distance to the GT (+ = outside)
    double roughness = 0;              ///< main surface: standard deviation of that signed distance
    double mean_abs_distance = 0;      ///< main surface: mean exact distance to the GT
    bool offset_signed_by_closed_gt = false;  ///< sign from a closed oriented GT (else the GT normals as they are)
    double completeness_l2 = 0;        ///< GT -> pred half
    double completeness_missing_l2 = 0;  ///< ... from missing GT samples
    double completeness_rest_l2 = 0;     ///< ... from the rest
    double missing_area_fraction = 0;    ///< fraction of GT area (by samples) with no predicted surface near it
};

/// The error budget of `pred` against `gt` (both meshes in the same frame, any units; they are
/// mapped into the protocol's evaluation frame). `input` (N x 3, same frame as the meshes, may be
/// null) is the cloud the reconstruction was made from; without it nothing counts as unsupported.
Diagnosis diagnose(const Mesh& pred, const Mesh& gt, const Eigen::Ref<const Points>* input,
                   const DiagnoseOptions& options = {});

}  // namespace pcp
