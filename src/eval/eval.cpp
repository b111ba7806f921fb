// Surface sampling and the comparison metrics of METHOD.md section 6. Nearest-sample queries go
// through KdTree (float, in the evaluation frame whose size is about 1, so float's 6e-8 relative
// precision is far below any distance we report); point-to-triangle distances go through CGAL
// (src/detail/triangle_distance.cpp).
#include "pcp/eval/eval.hpp"

#include "eval/eval_frame.hpp"
#include "core/triangle_distance.hpp"
#include "pcp/core/error.hpp"
#include "pcp/cloud/kdtree.hpp"
#include "pcp/cloud/normalize.hpp"
#include "pcp/core/rng.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace pcp {

EvalProtocol parse_eval_protocol(const std::string& name) {
    if (name == "p2s") return EvalProtocol::P2S;
    if (name == "shapenet") return EvalProtocol::ShapeNet;
    if (name == "scene") return EvalProtocol::Scene;
    PCP_FAIL("unknown evaluation protocol '" << name << "' (use p2s, shapenet or scene)");
}

std::string to_string(EvalProtocol protocol) {
    switch (protocol) {
        case EvalProtocol::P2S: return "p2s";
        case EvalProtocol::ShapeNet: return "shapenet";
        case EvalProtocol::Scene: return "scene";
    }
    return "?";
}

Eigen::Index resolved_samples(const EvalOptions& options) {
    if (options.samples > 0) return options.samples;
    return options.protocol == EvalProtocol::P2S ? 10000 : 100000;
}

std::vector<double> resolved_thresholds(const EvalOptions& options) {
    if (!options.fscore_thresholds.empty()) return options.fscore_thresholds;
    switch (options.protocol) {
        case EvalProtocol::P2S:
        case EvalProtocol::ShapeNet: return {0.002, 0.004};
        case EvalProtocol::Scene: return {0.025};
    }
    return {};
}

SurfaceSamples sample_mesh_surface(const Mesh& mesh, Eigen::Index n, std::uint64_t seed) {
    PCP_CHECK(n >= 1, "surface sampling: n must be >= 1");
    const Eigen::Index faces = mesh.faces.rows();
    PCP_CHECK(faces > 0, "surface sampling: the mesh has no faces");
    std::vector<double> cumulative(static_cast<std::size_t>(faces));
    Points face_normals(faces, 3);
    double total = 0.0;
    for (Eigen::Index f = 0; f < faces; ++f) {
        const Eigen::Vector3d a = mesh.vertices.row(mesh.faces(f, 0)), b = mesh.vertices.row(mesh.faces(f, 1)),
                              c = mesh.vertices.row(mesh.faces(f, 2));
        const Eigen::Vector3d cross = (b - a).cross(c - a);
        const double area = 0.5 * cross.norm();
        total += std::isfinite(area) ? area : 0.0;
        cumulative[static_cast<std::size_t>(f)] = total;
        face_normals.row(f) = area > 0 ? Eigen::RowVector3d(cross.normalized().transpose()) : Eigen::RowVector3d::Zero();
    }
    PCP_CHECK(total > 0.0, "surface sampling: the mesh has zero area");
    SurfaceSamples s;
    s.points.resize(n, 3);
    s.normals.resize(n, 3);
    s.faces.resize(n);
    Rng rng(seed, 17);
    for (Eigen::Index i = 0; i < n; ++i) {
        const double u = rng.uniform() * total;
        const auto it = std::upper_bound(cumulative.begin(), cumulative.end(), u);
        const Eigen::Index f = std::min<Eigen::Index>(it - cumulative.begin(), faces - 1);
        double r1 = rng.uniform(), r2 = rng.uniform();
        if (r1 + r2 > 1.0) {  // fold the square onto the triangle
            r1 = 1.0 - r1;
            r2 = 1.0 - r2;
        }
        const Eigen::RowVector3d a = mesh.vertices.row(mesh.faces(f, 0)), b = mesh.vertices.row(mesh.faces(f, 1)),
                                 c = mesh.vertices.row(mesh.faces(f, 2));
        s.points.row(i) = a + r1 * (b - a) + r2 * (c - a);
        s.normals.row(i) = face_normals.row(f);
        s.faces(i) = static_cast<std::int32_t>(f);
    }
    return s;
}

namespace {

struct Directed {
    Eigen::VectorXd distance;
    Eigen::VectorXd abs_cos;
};

/// For each sample of `from`, the distance to and |cos| with its nearest sample of `to`.
Directed directed(const SurfaceSamples& from, const SurfaceSamples& to, const KdTree& to_tree) {
    Eigen::VectorXf dist;
    const IndexVector nn = to_tree.nearest(from.points.cast<float>(), &dist);
    Directed d;
    d.distance = dist.cast<double>();
    d.abs_cos.resize(nn.size());
    for (Eigen::Index i = 0; i < nn.size(); ++i) d.abs_cos(i) = std::abs(from.normals.row(i).dot(to.normals.row(nn(i))));
    return d;
}

}  // namespace

Metrics compare_samples(const SurfaceSamples& pred, const SurfaceSamples& gt, const std::vector<double>& thresholds) {
    PCP_CHECK(pred.points.rows() > 0 && gt.points.rows() > 0, "evaluation: empty sample set");
    const KdTree pred_tree(pred.points.cast<float>()), gt_tree(gt.points.cast<float>());
    const Directed p2g = directed(pred, gt, gt_tree), g2p = directed(gt, pred, pred_tree);
    Metrics m;
    m.chamfer_l1 = 0.5 * (p2g.distance.mean() + g2p.distance.mean());
    m.chamfer_l2 = 0.5 * (p2g.distance.squaredNorm() / static_cast<double>(p2g.distance.size()) +
                          g2p.distance.squaredNorm() / static_cast<double>(g2p.distance.size()));
    m.normal_consistency = 0.5 * (p2g.abs_cos.mean() + g2p.abs_cos.mean());
    m.hausdorff = std::max(p2g.distance.maxCoeff(), g2p.distance.maxCoeff());
    for (double t : thresholds) {
        FScore f;
        f.threshold = t;
        f.precision = static_cast<double>((p2g.distance.array() <= t).count()) / static_cast<double>(p2g.distance.size());
        f.recall = static_cast<double>((g2p.distance.array() <= t).count()) / static_cast<double>(g2p.distance.size());
        f.fscore = f.precision + f.recall > 0 ? 2.0 * f.precision * f.recall / (f.precision + f.recall) : 0.0;
        m.fscores.push_back(f);
    }
    return m;
}

namespace detail {

Normalization eval_frame(const Points& gt_points, EvalProtocol protocol) {
    if (protocol == EvalProtocol::Scene) return Normalization{};
    return fit_unit_box(gt_points);
}

Mesh to_frame(const Mesh& mesh, const Normalization& frame) {
    return Mesh{frame.to_unit_double(mesh.vertices), mesh.faces};
}

void check_mesh(const Mesh& mesh, const char* which) {
    PCP_CHECK(mesh.vertices.rows() > 0 && mesh.faces.rows() > 0, "evaluation: the " << which << " mesh is empty");
    PCP_CHECK(mesh.vertices.allFinite(), "evaluation: the " << which << " mesh has non-finite vertices");
    PCP_CHECK(mesh.faces.minCoeff() >= 0 && mesh.faces.maxCoeff() < mesh.vertices.rows(),
              "evaluation: the " << which << " mesh has face indices out of range");
}

}  // namespace detail

using detail::check_mesh;
using detail::eval_frame;
using detail::to_frame;

EvalResult evaluate(const Mesh& pred, const Mesh& gt, const EvalOptions& options) {
    check_mesh(pred, "predicted");
    check_mesh(gt, "ground-truth");
    const Normalization frame = eval_frame(gt.vertices, options.protocol);
    const Mesh pred_f = to_frame(pred, frame), gt_f = to_frame(gt, frame);
    const Eigen::Index n = resolved_samples(options);
    const std::vector<double> thresholds = resolved_thresholds(options);
    EvalResult r;
    r.frame_scale = 1.0 / frame.scale;
    r.samples = n;
    const SurfaceSamples gt_samples = sample_mesh_surface(gt_f, n, options.seed + 1);
    r.metrics = compare_samples(sample_mesh_surface(pred_f, n, options.seed), gt_samples, thresholds);
    if (options.with_floor)
        r.floor = compare_samples(sample_mesh_surface(gt_f, n, options.seed + 2), gt_samples, thresholds);
    r.scene_error = point_to_mesh_distance(gt_f, pred_f.vertices).mean();
    return r;
}

EvalResult evaluate(const Mesh& pred, const SurfaceSamples& gt_points, const EvalOptions& options) {
    check_mesh(pred, "predicted");
    PCP_CHECK(gt_points.points.rows() > 0, "evaluation: the ground-truth point set is empty");
    PCP_CHECK(gt_points.normals.rows() == gt_points.points.rows(), "evaluation: ground-truth points need normals");
    const Normalization frame = eval_frame(gt_points.points, options.protocol);
    const Eigen::Index n = resolved_samples(options);
    SurfaceSamples gt;
    const Eigen::Index m = gt_points.points.rows();
    if (m > n) {  // a seeded random subset of n ground-truth points
        std::vector<Eigen::Index> ids(static_cast<std::size_t>(m));
        std::iota(ids.begin(), ids.end(), Eigen::Index{0});
        Rng rng(options.seed, 23);
        for (Eigen::Index i = 0; i < n; ++i)
            std::swap(ids[static_cast<std::size_t>(i)], ids[static_cast<std::size_t>(i + static_cast<Eigen::Index>(rng.below(static_cast<std::uint64_t>(m - i))))]);
        ids.resize(static_cast<std::size_t>(n));
        gt.points = gt_points.points(ids, Eigen::all);
        gt.normals = gt_points.normals(ids, Eigen::all);
    } else {
        gt = gt_points;
    }
    gt.points = frame.to_unit_double(gt.points);
    EvalResult r;
    r.frame_scale = 1.0 / frame.scale;
    r.samples = n;
    r.metrics = compare_samples(sample_mesh_surface(to_frame(pred, frame), n, options.seed), gt,
                                resolved_thresholds(options));
    return r;
}

Eigen::VectorXd winding_numbers(const Mesh& mesh, const Eigen::Ref<const Points>& points) {
    check_mesh(mesh, "reference");
    Eigen::VectorXd w(points.rows());
#pragma omp parallel for schedule(dynamic, 16)
    for (Eigen::Index i = 0; i < points.rows(); ++i) {
        const Eigen::Vector3d p = points.row(i).transpose();
        double total = 0.0;
        for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
            const Eigen::Vector3d a = mesh.vertices.row(mesh.faces(f, 0)).transpose() - p;
            const Eigen::Vector3d b = mesh.vertices.row(mesh.faces(f, 1)).transpose() - p;
            const Eigen::Vector3d c = mesh.vertices.row(mesh.faces(f, 2)).transpose() - p;
            const double la = a.norm(), lb = b.norm(), lc = c.norm();
            const double numerator = a.dot(b.cross(c));
            const double denominator = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
            total += 2.0 * std::atan2(numerator, denominator);
        }
        w(i) = total / (4.0 * 3.14159265358979323846);
    }
    return w;
}

namespace {

SignAgreement count_agreement(const Eigen::VectorXd& winding, const Eigen::VectorXd& sdf, SdfConvention convention,
                              const std::vector<double>& bin_edges) {
    SignAgreement result;
    std::vector<double> edges = bin_edges;
    if (edges.empty() || edges.front() > 0) edges.insert(edges.begin(), 0.0);
    for (std::size_t b = 0; b < edges.size(); ++b)
        result.bins.push_back({edges[b], b + 1 < edges.size() ? edges[b + 1] : std::numeric_limits<double>::infinity(), 0, 0});
    for (Eigen::Index i = 0; i < sdf.size(); ++i) {
        const bool truth_inside = convention == SdfConvention::NegativeInside ? sdf(i) < 0 : sdf(i) > 0;
        const bool ok = (winding(i) > 0.5) == truth_inside;
        std::size_t b = 0;
        while (b + 1 < result.bins.size() && std::abs(sdf(i)) >= result.bins[b + 1].lower) ++b;
        ++result.samples;
        ++result.bins[b].samples;
        result.agree += ok;
        result.bins[b].agree += ok;
    }
    return result;
}

Eigen::VectorXd checked_winding(const Mesh& mesh, const Eigen::Ref<const Points>& points, const Eigen::VectorXd& sdf) {
    PCP_CHECK(sdf.size() == points.rows(), "sign agreement: " << points.rows() << " points but " << sdf.size() << " sdf values");
    PCP_CHECK(sdf.allFinite(), "sign agreement: the sdf values are not all finite");
    return winding_numbers(mesh, points);
}

}  // namespace

SignAgreement sign_agreement(const Mesh& mesh, const Eigen::Ref<const Points>& points, const Eigen::VectorXd& sdf,
                             SdfConvention convention, const std::vector<double>& bin_edges) {
    for (std::size_t b = 0; b < bin_edges.size(); ++b)
        PCP_CHECK(std::isfinite(bin_edges[b]) && bin_edges[b] >= 0 && (b == 0 || bin_edges[b] > bin_edges[b - 1]),
                  "sign agreement: bin edges must be finite, non-negative and increasing");
    return count_agreement(checked_winding(mesh, points, sdf), sdf, convention, bin_edges);
}

SdfConvention detect_sdf_convention(const Mesh& reference, const Eigen::Ref<const Points>& points,
                                    const Eigen::VectorXd& sdf, double* agreement) {
    const Eigen::VectorXd w = checked_winding(reference, points, sdf);
    const SignAgreement negative = count_agreement(w, sdf, SdfConvention::NegativeInside, {});
    const SignAgreement positive = count_agreement(w, sdf, SdfConvention::PositiveInside, {});
    const bool positive_inside = positive.agree > negative.agree;
    if (agreement) *agreement = positive_inside ? positive.fraction() : negative.fraction();
    return positive_inside ? SdfConvention::PositiveInside : SdfConvention::NegativeInside;
}

Eigen::VectorXd point_to_mesh_distance(const Mesh& mesh, const Eigen::Ref<const Points>& points) {
    check_mesh(mesh, "reference");
    return detail::TriangleDistance(mesh).distances(points);
}

NormalOrientation normal_orientation(const Eigen::Ref<const Points>& points, const Eigen::Ref<const Points>& normals, const Mesh& gt) {
    check_mesh(gt, "ground-truth");
    PCP_CHECK(points.rows() == normals.rows(), "normal orientation: " << points.rows() << " points but " << normals.rows() << " normals");
    PCP_CHECK(points.rows() > 0, "normal orientation: no points");
    PCP_CHECK(points.allFinite() && normals.allFinite(), "normal orientation: a point or normal is not finite");
    const Points reference = detail::TriangleDistance(gt).nearest_face_normals(points);
    NormalOrientation r;
    r.points = points.rows();
    std::vector<double> angles(static_cast<std::size_t>(points.rows()));
    Eigen::Index correct = 0;
    double sum = 0, sum_unoriented = 0;
    for (Eigen::Index i = 0; i < points.rows(); ++i) {
        const double len = normals.row(i).norm();
        PCP_CHECK(len > 0, "normal orientation: the normal of point " << i << " is zero");
        const double c = std::clamp(normals.row(i).dot(reference.row(i)) / len, -1.0, 1.0);
        const double angle = std::acos(c) * 180.0 / 3.14159265358979323846;
        correct += c > 0;
        angles[static_cast<std::size_t>(i)] = angle;
        sum += angle;
        sum_unoriented += std::min(angle, 180.0 - angle);
    }
    const auto n = static_cast<double>(points.rows());
    r.correct_side = static_cast<double>(correct) / n;
    r.mean_angle_deg = sum / n;
    r.mean_unoriented_deg = sum_unoriented / n;
    const auto mid = angles.begin() + static_cast<std::ptrdiff_t>(angles.size() / 2);
    std::nth_element(angles.begin(), mid, angles.end());
    r.median_angle_deg = *mid;
    return r;
}

}  // namespace pcp
