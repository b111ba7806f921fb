// Oriented normals of the input points from the fitted field (see include/pcp/mesh/sign/field_normals.hpp).
#include "pcp/mesh/sign/field_normals.hpp"

#include "core/triangle_distance.hpp"
#include "pcp/core/error.hpp"
#include "pcp/core/rng.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <queue>
#include <vector>

namespace pcp {

namespace {

/// PCA normals (unit, unoriented) at `queries` (points of the tree, or any) from their k nearest tree
/// points (also returned), and the spread of those points along the normal (the standard
/// deviation: noise, or curvature).
PointsF pca_normals_at(const KdTree& tree, const PointsF& queries, int k, NeighborIndices& idx, Eigen::VectorXf& thickness) {
    const PointsF& pts = tree.points();
    NeighborDistances dist;
    tree.knn(queries, k, idx, dist);
    PointsF normals(queries.rows(), 3);
    thickness.resize(queries.rows());
#pragma omp parallel for schedule(static)
    for (Eigen::Index i = 0; i < queries.rows(); ++i) {
        Eigen::Vector3d mean = Eigen::Vector3d::Zero();
        for (int j = 0; j < k; ++j) mean += pts.row(idx(i, j)).transpose().cast<double>();
        mean /= k;
        Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
        for (int j = 0; j < k; ++j) {
            const Eigen::Vector3d d = pts.row(idx(i, j)).transpose().cast<double>() - mean;
            cov += d * d.transpose();
        }
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
        normals.row(i) = eig.eigenvectors().col(0).cast<float>().transpose();  // smallest eigenvalue first
        thickness(i) = static_cast<float>(std::sqrt(std::max(0.0, eig.eigenvalues()(0)) / k));
    }
    return normals;
}

PointsF pca_normals(const KdTree& tree, int k, NeighborIndices& idx, Eigen::VectorXf& thickness) {
    return pca_normals_at(tree, tree.points(), k, idx, thickness);
}

/// The field's vote on the orientation of each of `pts` (header: 1 for a signed distance growing
/// along the normal, -1 against it, 0 off the zero set), from its unoriented normal and the spread
/// of its neighbours along it.
Eigen::VectorXd field_votes(const SdfBatchFn& field, const PointsF& pts, const PointsF& normals, const Eigen::VectorXf& thickness,
                            double scale, const FieldNormalsOptions& options) {
    const Eigen::Index n = pts.rows();
    constexpr int kProbes = 3;
    // The first probe step: probe x scale, or beyond the local noise (noise_probe standard
    // deviations of the points along the normal) where that is more.
    Eigen::VectorXf step(n);
    for (Eigen::Index i = 0; i < n; ++i)
        step(i) = std::max(static_cast<float>(options.probe * scale), static_cast<float>(options.noise_probe) * thickness(i));
    PointsF probes((2 * kProbes + 1) * n, 3);
    probes.bottomRows(n) = pts;
    for (Eigen::Index i = 0; i < n; ++i)
        for (int s = 0; s < kProbes; ++s) {
            const float h = step(i) * static_cast<float>(1 << s);
            probes.row((2 * s) * n + i) = pts.row(i) + h * normals.row(i);
            probes.row((2 * s + 1) * n + i) = pts.row(i) - h * normals.row(i);
        }
    Eigen::VectorXf values(probes.rows());
    field(probes, values);
    PCP_CHECK(values.allFinite(), "oriented normals: the field is not finite at a probe near the input points");
    Eigen::VectorXd votes(n);
    for (Eigen::Index i = 0; i < n; ++i) {
        double vote = 0, clean = 0;
        for (int s = 0; s < kProbes; ++s) {
            const double h = step(i) * double(1 << s), w = 1.0 / double(1 << s);
            vote += w * (double(values((2 * s) * n + i)) - double(values((2 * s + 1) * n + i))) / h;
            clean += w * 2.0;  // a signed distance grows by 2h over the probe pair
        }
        // A point the field's zero set does not pass near is no witness of its orientation.
        const bool on_zero_set = std::abs(values(2 * kProbes * n + i)) <= std::max(options.zero_set * scale, double(step(i)));
        votes(i) = on_zero_set ? vote / clean : 0.0;
    }
    return votes;
}

/// Orientation signs (+1 keep, -1 negate) of the unoriented `normals` from the field's votes: a point
/// whose vote is at least `confident` (1 for a true signed distance) keeps its own; the others take
/// theirs from the neighbours, most parallel normal first (a best-first spread from every confident
/// point, as in Hoppe et al.'s orientation but seeded by the field); a point no spread reaches keeps
/// the sign of its own vote. Returns how many points took a neighbour's orientation.
std::int64_t orient_by_votes(const PointsF& normals, const NeighborIndices& idx, const Eigen::VectorXd& votes,
                             double confident, std::vector<std::int8_t>& sign) {
    const Eigen::Index n = normals.rows();
    sign.assign(static_cast<std::size_t>(n), 0);
    struct Edge {
        float weight;
        std::int32_t to;
        std::int8_t sign;
        bool operator<(const Edge& o) const { return weight < o.weight; }
    };
    std::priority_queue<Edge> queue;
    auto spread_from = [&](Eigen::Index i) {
        for (Eigen::Index j = 1; j < idx.cols(); ++j) {
            const std::int32_t k = idx(i, j);
            if (sign[static_cast<std::size_t>(k)] != 0) continue;
            const float dot = normals.row(i).dot(normals.row(k));
            queue.push({std::abs(dot), k, static_cast<std::int8_t>(dot < 0 ? -sign[static_cast<std::size_t>(i)] : sign[static_cast<std::size_t>(i)])});
        }
    };
    for (Eigen::Index i = 0; i < n; ++i)
        if (std::abs(votes(i)) >= confident) sign[static_cast<std::size_t>(i)] = votes(i) < 0 ? -1 : 1;
    for (Eigen::Index i = 0; i < n; ++i)
        if (sign[static_cast<std::size_t>(i)] != 0) spread_from(i);
    std::int64_t spread = 0;
    while (!queue.empty()) {
        const Edge e = queue.top();
        queue.pop();
        if (sign[static_cast<std::size_t>(e.to)] != 0) continue;
        sign[static_cast<std::size_t>(e.to)] = e.sign;
        ++spread;
        spread_from(e.to);
    }
    for (Eigen::Index i = 0; i < n; ++i)
        if (sign[static_cast<std::size_t>(i)] == 0) sign[static_cast<std::size_t>(i)] = votes(i) < 0 ? -1 : 1;
    return spread;
}

}  // namespace

NormalSource parse_normal_source(const std::string& name) {
    if (name == "mesh") return NormalSource::Mesh;
    if (name == "pca") return NormalSource::PcaByMesh;
    if (name == "field") return NormalSource::Field;
    PCP_FAIL("unknown normal source '" << name << "' (use mesh, pca or field)");
}

std::string to_string(NormalSource source) {
    return source == NormalSource::Mesh ? "mesh" : source == NormalSource::PcaByMesh ? "pca" : "field";
}

PointsF pca_normals(const KdTree& cloud, int k) {
    PCP_CHECK(k >= 3 && k <= 64, "PCA normals: k must be in 3..64");
    PCP_CHECK(cloud.size() > k, "PCA normals: the cloud has " << cloud.size() << " points; k = " << k << " needs more");
    NeighborIndices idx;
    Eigen::VectorXf thickness;
    return pca_normals(cloud, k, idx, thickness);
}

Points mesh_normals_at(const Mesh& mesh, const Eigen::Ref<const Points>& points) {
    PCP_CHECK(mesh.faces.rows() > 0, "mesh normals: the mesh has no faces");
    // Area-weighted vertex normals: the sum of the (unnormalised) cross products of the faces around.
    Points vertex_normals = Points::Zero(mesh.vertices.rows(), 3);
    for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
        const Eigen::RowVector3d a = mesh.vertices.row(mesh.faces(f, 0)), b = mesh.vertices.row(mesh.faces(f, 1)),
                                 c = mesh.vertices.row(mesh.faces(f, 2));
        const Eigen::RowVector3d n = (b - a).cross(c - a);
        for (int k = 0; k < 3; ++k) vertex_normals.row(mesh.faces(f, k)) += n;
    }
    Points closest;
    const Eigen::VectorXi faces = detail::TriangleDistance(mesh).nearest_faces(points, closest);
    Points normals(points.rows(), 3);
#pragma omp parallel for schedule(static)
    for (Eigen::Index i = 0; i < points.rows(); ++i) {
        const int f = faces(i);
        Eigen::RowVector3d n = Eigen::RowVector3d::Zero();
        if (f >= 0) {
            const Eigen::RowVector3d a = mesh.vertices.row(mesh.faces(f, 0)), b = mesh.vertices.row(mesh.faces(f, 1)),
                                     c = mesh.vertices.row(mesh.faces(f, 2));
            const Eigen::RowVector3d face = (b - a).cross(c - a);
            const double area2 = face.squaredNorm();
            // Barycentric coordinates of the closest point (on the triangle, so all in [0, 1]).
            const Eigen::RowVector3d p = closest.row(i);
            const double wa = (b - p).cross(c - p).dot(face) / area2, wb = (c - p).cross(a - p).dot(face) / area2;
            const double wc = 1.0 - wa - wb;
            auto unit = [&](int k) {
                const Eigen::RowVector3d v = vertex_normals.row(mesh.faces(f, k));
                const double len = v.norm();
                return len > 0 ? Eigen::RowVector3d(v / len) : Eigen::RowVector3d::Zero();
            };
            n = wa * unit(0) + wb * unit(1) + wc * unit(2);
            if (!(n.norm() > 1e-12)) n = face;  // opposite vertex normals cancel: the face's own
        }
        const double len = n.norm();
        normals.row(i) = len > 0 ? Eigen::RowVector3d(n / len) : Eigen::RowVector3d(0, 0, 1);
    }
    return normals;
}

void check_field_normals_options(const FieldNormalsOptions& o, const char* what) {
    PCP_CHECK(o.normal_k >= 3 && o.normal_k <= 64, what << ": normal_k must be in 3..64");
    PCP_CHECK(o.probe > 0 && std::isfinite(o.probe), what << ": probe must be > 0");
    PCP_CHECK(o.noise_probe >= 0 && std::isfinite(o.noise_probe), what << ": noise_probe must be >= 0");
    PCP_CHECK(o.zero_set >= 0 && std::isfinite(o.zero_set), what << ": zero_set must be >= 0");
    PCP_CHECK(o.confident_vote >= 0 && std::isfinite(o.confident_vote), what << ": confident_vote must be >= 0");
}

namespace {

/// The PCA normals of the tree's points oriented by `vote(points, normals, thickness)` (N votes, 1
/// along the normal): the common part of orient_normals_by_field and orient_normals_by_labels.
template <class Vote>
FieldNormals orient_normals_by_votes(const KdTree& cloud, const FieldNormalsOptions& options, Vote&& vote) {
    check_field_normals_options(options, "oriented normals");
    PCP_CHECK(cloud.size() > options.normal_k,
              "oriented normals: the cloud has " << cloud.size() << " points; normal_k = " << options.normal_k << " needs more");
    const auto t0 = std::chrono::steady_clock::now();
    FieldNormals out;
    const PointsF& pts = cloud.points();
    const Eigen::Index n = pts.rows();
    out.stats.points = n;
    out.normals = pca_normals(cloud, options.normal_k, out.neighbours, out.thickness);
    out.votes = vote(pts, out.normals, out.thickness);
    for (Eigen::Index i = 0; i < n; ++i) out.stats.confident += std::abs(out.votes(i)) >= options.confident_vote;
    std::vector<std::int8_t> sign;
    out.stats.weak_orientation = orient_by_votes(out.normals, out.neighbours, out.votes, options.confident_vote, sign);
    for (Eigen::Index i = 0; i < n; ++i) {
        if (sign[static_cast<std::size_t>(i)] < 0) out.normals.row(i) = -out.normals.row(i);
        if (double(sign[static_cast<std::size_t>(i)]) * out.votes(i) < 0) ++out.stats.against_own_vote;
    }
    out.stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return out;
}

}  // namespace

FieldNormals orient_normals_by_field(const SdfBatchFn& field, const KdTree& cloud, const FieldNormalsOptions& options) {
    return orient_normals_by_votes(cloud, options, [&](const PointsF& pts, const PointsF& normals, const Eigen::VectorXf& thickness) {
        return field_votes(field, pts, normals, thickness, sampling_scale(cloud), options);
    });
}

FieldNormals orient_normals_by_labels(const VisibilityLabels& labels, const KdTree& cloud, const FieldNormalsOptions& options) {
    PCP_CHECK(!labels.label.empty() && labels.cell > 0, "oriented normals: the visibility labels are empty");
    return orient_normals_by_votes(cloud, options, [&](const PointsF& pts, const PointsF& normals, const Eigen::VectorXf&) {
        // The mean over probes at 1..4 label cells of (label(p + t n) - label(p - t n)) / 2.
        constexpr int kProbes = 4;
        Eigen::VectorXd votes(pts.rows());
#pragma omp parallel for schedule(static)
        for (Eigen::Index i = 0; i < pts.rows(); ++i) {
            const Eigen::Vector3d p = pts.row(i).transpose().cast<double>(), nn = normals.row(i).transpose().cast<double>();
            double vote = 0;
            for (int s = 1; s <= kProbes; ++s) {
                const double t = s * labels.cell;
                vote += 0.5 * double(labels.label_at(p + t * nn) - labels.label_at(p - t * nn));
            }
            votes(i) = vote / kProbes;
        }
        return votes;
    });
}

double confident_vote_fraction(const SdfBatchFn& field, const KdTree& cloud, const FieldNormalsOptions& options,
                               Eigen::Index max_points) {
    check_field_normals_options(options, "oriented normals");
    PCP_CHECK(max_points >= 1, "oriented normals: max_points must be >= 1");
    PCP_CHECK(cloud.size() > options.normal_k,
              "oriented normals: the cloud has " << cloud.size() << " points; normal_k = " << options.normal_k << " needs more");
    const PointsF& all = cloud.points();
    const Eigen::Index n = all.rows(), m = std::min(n, max_points);
    // A uniform sample without replacement (a fixed seed: the same points every run). Not a stride
    // over the tree's order: a scan's points come in rows, and a stride can alias with them (on one
    // scan a stride of 42 estimated 0.40 where the count is 0.32).
    std::vector<Eigen::Index> order(static_cast<std::size_t>(n));
    std::iota(order.begin(), order.end(), Eigen::Index(0));
    Rng rng(0x9E3779B97F4A7C15ull, 7);
    for (Eigen::Index j = 0; j < m; ++j)
        std::swap(order[static_cast<std::size_t>(j)], order[static_cast<std::size_t>(j + static_cast<Eigen::Index>(rng.below(std::uint64_t(n - j))))]);
    std::sort(order.begin(), order.begin() + m);
    PointsF pts(m, 3);
    for (Eigen::Index j = 0; j < m; ++j) pts.row(j) = all.row(order[static_cast<std::size_t>(j)]);
    NeighborIndices idx;
    Eigen::VectorXf thickness;
    const PointsF normals = pca_normals_at(cloud, pts, options.normal_k, idx, thickness);
    const Eigen::VectorXd votes = field_votes(field, pts, normals, thickness, sampling_scale(cloud), options);
    Eigen::Index confident = 0;
    for (Eigen::Index j = 0; j < m; ++j) confident += std::abs(votes(j)) >= options.confident_vote;
    return double(confident) / double(m);
}

}  // namespace pcp
