// Reconstruction metrics of METHOD.md section 6 (the paper's tables): Chamfer L1 / L2, normal
// consistency, F-score, Hausdorff distance, and the 3D Scene "error" (mean distance from each
// predicted vertex to the nearest ground-truth triangle). Surfaces are compared through
// area-weighted random samples, seeded; the "floor" (ground truth against an independent sampling
// of itself) shows what finite sampling cannot go below.
#pragma once

#include "pcp/core/types.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace pcp {

/// Points sampled on a surface with their unit normals.
struct SurfaceSamples {
    Points points;   ///< N x 3
    Points normals;  ///< N x 3, unit length (zero where unknown)
    Eigen::Matrix<std::int32_t, Eigen::Dynamic, 1> faces;  ///< N, the face each sample lies on (empty when not sampled from a mesh)
};

/// `n` points uniform by area on `mesh` (degenerate faces get no samples), with face normals and
/// the index of the face each lies on.
SurfaceSamples sample_mesh_surface(const Mesh& mesh, Eigen::Index n, std::uint64_t seed);

enum class EvalProtocol {
    P2S,       ///< ABC/FAMOUS tables: 10,000 samples, frame scaled so the GT bbox's longest edge is 1
    ShapeNet,  ///< 100,000 samples, same unit frame, F-score at 0.002 and 0.004
    Scene,     ///< metres (no scaling), 100,000 samples, F-score at 0.025
};

/// "p2s" | "shapenet" | "scene"; throws pcp::Error otherwise.
EvalProtocol parse_eval_protocol(const std::string& name);
std::string to_string(EvalProtocol protocol);

struct EvalOptions {
    EvalProtocol protocol = EvalProtocol::P2S;
    Eigen::Index samples = 0;               ///< 0 = the protocol's count
    std::vector<double> fscore_thresholds;  ///< empty = the protocol's thresholds
    std::uint64_t seed = 1;
    bool with_floor = true;                 ///< also evaluate GT against an independent GT sampling
};

/// Samples counts and F-score thresholds that `options` resolves to for its protocol.
Eigen::Index resolved_samples(const EvalOptions& options);
std::vector<double> resolved_thresholds(const EvalOptions& options);

struct FScore {
    double threshold = 0, precision = 0, recall = 0, fscore = 0;
};

struct Metrics {
    double chamfer_l1 = 0;          ///< (mean d(pred->gt) + mean d(gt->pred)) / 2
    double chamfer_l2 = 0;          ///< the same with squared distances
    double normal_consistency = 0;  ///< mean |cos| to the nearest sample's normal, both ways averaged
    double hausdorff = 0;           ///< max of both directed maxima
    std::vector<FScore> fscores;
};

struct EvalResult {
    Metrics metrics;
    Metrics floor;                  ///< GT vs. an independent GT sampling (if options.with_floor)
    double scene_error = -1;        ///< mean pred-vertex-to-GT-triangle distance (-1: GT is points)
    double frame_scale = 1;         ///< the factor applied to both shapes (1 / GT's longest bbox edge)
    Eigen::Index samples = 0;
};

/// Compares the samples `pred` and `gt` (already in the evaluation frame).
Metrics compare_samples(const SurfaceSamples& pred, const SurfaceSamples& gt,
                        const std::vector<double>& thresholds);

/// Evaluates a predicted mesh against a ground-truth mesh.
EvalResult evaluate(const Mesh& pred, const Mesh& gt, const EvalOptions& options = {});

/// Evaluates a predicted mesh against ground-truth points with normals (a random subset of
/// `samples` of them is used if there are more).
EvalResult evaluate(const Mesh& pred, const SurfaceSamples& gt_points, const EvalOptions& options = {});

/// Generalised winding number of `mesh` at each row of `points` (N x 3): the sum of the signed
/// solid angles of its triangles / 4 pi (Van Oosterom-Strackee formula). About 1 inside and 0
/// outside a closed, outward-oriented mesh. O(N x faces), OpenMP-parallel over points.
Eigen::VectorXd winding_numbers(const Mesh& mesh, const Eigen::Ref<const Points>& points);

/// How often a mesh puts signed-distance samples on the right side, overall and by |sdf|.
struct SignAgreement {
    struct Bin {
        double lower = 0, upper = 0;  ///< |sdf| in [lower, upper)
        Eigen::Index samples = 0, agree = 0;
        double fraction() const { return samples ? static_cast<double>(agree) / static_cast<double>(samples) : 0.0; }
    };
    Eigen::Index samples = 0, agree = 0;
    std::vector<Bin> bins;
    double fraction() const { return samples ? static_cast<double>(agree) / static_cast<double>(samples) : 0.0; }
};

/// Which sign of a signed-distance file means inside.
enum class SdfConvention { NegativeInside, PositiveInside };

/// Compares the side of `mesh` (inside: winding number > 0.5) with the sign of `sdf` at `points`
/// (N x 3, same frame), binned by |sdf| at `bin_edges` (increasing; the last bin is open). A
/// sample with sdf exactly 0 counts as outside.
SignAgreement sign_agreement(const Mesh& mesh, const Eigen::Ref<const Points>& points, const Eigen::VectorXd& sdf,
                             SdfConvention convention, const std::vector<double>& bin_edges = {});

/// The convention of `sdf` judged by a reference mesh: the one that agrees with its winding
/// numbers on more samples. `agreement` (optional) receives that convention's agreement fraction.
SdfConvention detect_sdf_convention(const Mesh& reference, const Eigen::Ref<const Points>& points,
                                    const Eigen::VectorXd& sdf, double* agreement = nullptr);

/// How well oriented normals of points agree with a ground-truth mesh (outward, counter-clockwise
/// faces): each point is compared with the normal of its nearest GT triangle.
struct NormalOrientation {
    Eigen::Index points = 0;
    double correct_side = 0;        ///< fraction of points with n . n_gt > 0 (the normal points to the GT's outside)
    double mean_angle_deg = 0;      ///< mean angle between n and n_gt, 0..180
    double median_angle_deg = 0;
    double mean_unoriented_deg = 0; ///< mean of min(angle, 180 - angle): the direction alone, whatever the orientation
};

/// Compares `normals` (N x 3, unit or not) of `points` (N x 3, the GT's frame) with `gt`. Throws
/// pcp::Error on mismatched sizes, non-finite or zero normals, or a mesh without faces.
NormalOrientation normal_orientation(const Eigen::Ref<const Points>& points, const Eigen::Ref<const Points>& normals, const Mesh& gt);

/// Distance from each row of `points` (N x 3) to the nearest triangle of `mesh` (exact).
Eigen::VectorXd point_to_mesh_distance(const Mesh& mesh, const Eigen::Ref<const Points>& points);

}  // namespace pcp
