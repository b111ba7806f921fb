// Surface fit: support filter, normal mean-shift onto the data, tangential relaxation (see
// include/pcp/mesh/surface_fit.hpp).
#include "pcp/mesh/surface_fit.hpp"

#include "pcp/core/error.hpp"
#include "eval/triangle_distance.hpp"

#include <Eigen/Geometry>
#include <Eigen/SparseCholesky>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <vector>

namespace pcp {
namespace {

/// Vertex -> neighbouring vertices (through edges of faces), compressed rows.
struct OneRing {
    std::vector<std::int64_t> start;  ///< V + 1
    std::vector<std::int32_t> ids;

    explicit OneRing(const Mesh& mesh) {
        const Eigen::Index V = mesh.vertices.rows();
        std::vector<std::vector<std::int32_t>> adj(static_cast<std::size_t>(V));
        for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f)
            for (int k = 0; k < 3; ++k) {
                const std::int32_t a = mesh.faces(f, k), b = mesh.faces(f, (k + 1) % 3);
                if (a == b) continue;
                adj[static_cast<std::size_t>(a)].push_back(b);
                adj[static_cast<std::size_t>(b)].push_back(a);
            }
        start.assign(static_cast<std::size_t>(V) + 1, 0);
        for (Eigen::Index v = 0; v < V; ++v) {
            auto& a = adj[static_cast<std::size_t>(v)];
            std::sort(a.begin(), a.end());
            a.erase(std::unique(a.begin(), a.end()), a.end());
            start[static_cast<std::size_t>(v) + 1] = start[static_cast<std::size_t>(v)] + static_cast<std::int64_t>(a.size());
        }
        ids.reserve(static_cast<std::size_t>(start.back()));
        for (const auto& a : adj) ids.insert(ids.end(), a.begin(), a.end());
    }
};

std::int32_t find_root(std::vector<std::int32_t>& parent, std::int32_t a) {
    while (parent[static_cast<std::size_t>(a)] != a) a = parent[static_cast<std::size_t>(a)] = parent[static_cast<std::size_t>(parent[static_cast<std::size_t>(a)])];
    return a;
}

/// The connected components of a mesh (vertices joined by faces): each vertex's root (the
/// component's smallest vertex; -1 where no face uses it) and, at each root, the component's vertex
/// count and bounding box; `largest`, the root with the most vertices (the first of equals).
struct Components {
    std::vector<std::int32_t> root;
    std::vector<std::int64_t> count;
    std::vector<Eigen::Vector3d> lo, hi;
    Eigen::Index largest = -1;

    explicit Components(const Mesh& mesh) {
        const Eigen::Index V = mesh.vertices.rows();
        std::vector<std::int32_t> parent(static_cast<std::size_t>(V));
        std::iota(parent.begin(), parent.end(), 0);
        for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f)
            for (int k = 1; k < 3; ++k) {
                const std::int32_t a = find_root(parent, mesh.faces(f, 0)), b = find_root(parent, mesh.faces(f, k));
                if (a != b) parent[static_cast<std::size_t>(std::max(a, b))] = std::min(a, b);
            }
        root.assign(static_cast<std::size_t>(V), -1);
        for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f)
            for (int k = 0; k < 3; ++k) root[static_cast<std::size_t>(mesh.faces(f, k))] = 0;
        const double inf = std::numeric_limits<double>::infinity();
        count.assign(static_cast<std::size_t>(V), 0);
        lo.assign(static_cast<std::size_t>(V), Eigen::Vector3d::Constant(inf));
        hi.assign(static_cast<std::size_t>(V), Eigen::Vector3d::Constant(-inf));
        for (Eigen::Index v = 0; v < V; ++v) {
            if (root[static_cast<std::size_t>(v)] < 0) continue;
            const std::int32_t r = find_root(parent, static_cast<std::int32_t>(v));
            root[static_cast<std::size_t>(v)] = r;
            ++count[static_cast<std::size_t>(r)];
            lo[static_cast<std::size_t>(r)] = lo[static_cast<std::size_t>(r)].cwiseMin(mesh.vertices.row(v).transpose());
            hi[static_cast<std::size_t>(r)] = hi[static_cast<std::size_t>(r)].cwiseMax(mesh.vertices.row(v).transpose());
        }
        for (Eigen::Index v = 0; v < V; ++v)
            if (count[static_cast<std::size_t>(v)] > 0 && (largest < 0 || count[static_cast<std::size_t>(v)] > count[static_cast<std::size_t>(largest)]))
                largest = v;
    }
    double diagonal(Eigen::Index r) const { return (hi[static_cast<std::size_t>(r)] - lo[static_cast<std::size_t>(r)]).norm(); }
};

/// `mesh` with only the components whose root `keep_root` marks, unused vertices dropped (vertices
/// and faces in their order). `removed_faces` (optional) receives the faces removed.
Mesh keep_components(const Mesh& mesh, const Components& c, const std::vector<char>& keep_root, std::int64_t* removed_faces = nullptr) {
    const Eigen::Index V = mesh.vertices.rows();
    std::vector<std::int32_t> remap(static_cast<std::size_t>(V), -1);
    std::int32_t nv = 0;
    for (Eigen::Index v = 0; v < V; ++v) {
        const std::int32_t r = c.root[static_cast<std::size_t>(v)];
        if (r >= 0 && keep_root[static_cast<std::size_t>(r)]) remap[static_cast<std::size_t>(v)] = nv++;
    }
    Mesh out;
    out.vertices.resize(nv, 3);
    for (Eigen::Index v = 0; v < V; ++v)
        if (remap[static_cast<std::size_t>(v)] >= 0) out.vertices.row(remap[static_cast<std::size_t>(v)]) = mesh.vertices.row(v);
    std::vector<Eigen::Index> kept;
    for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f)
        if (remap[static_cast<std::size_t>(mesh.faces(f, 0))] >= 0) kept.push_back(f);
    if (removed_faces) *removed_faces = mesh.faces.rows() - static_cast<std::int64_t>(kept.size());
    out.faces.resize(static_cast<Eigen::Index>(kept.size()), 3);
    for (std::size_t i = 0; i < kept.size(); ++i)
        for (int k = 0; k < 3; ++k) out.faces(static_cast<Eigen::Index>(i), k) = remap[static_cast<std::size_t>(mesh.faces(kept[i], k))];
    return out;
}

/// Area-weighted vertex normals, averaged once over the one-ring, unit length (zero where undefined).
Points vertex_normals(const Mesh& mesh, const OneRing& ring) {
    const Eigen::Index V = mesh.vertices.rows();
    Points n = Points::Zero(V, 3);
    for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
        const Eigen::RowVector3d a = mesh.vertices.row(mesh.faces(f, 0)), b = mesh.vertices.row(mesh.faces(f, 1)),
                                 c = mesh.vertices.row(mesh.faces(f, 2));
        const Eigen::RowVector3d fn = (b - a).cross(c - a);  // twice the area times the unit normal
        for (int k = 0; k < 3; ++k) n.row(mesh.faces(f, k)) += fn;
    }
    Points s = n;
#pragma omp parallel for schedule(static)
    for (Eigen::Index v = 0; v < V; ++v)
        for (std::int64_t e = ring.start[static_cast<std::size_t>(v)]; e < ring.start[static_cast<std::size_t>(v) + 1]; ++e)
            s.row(v) += n.row(ring.ids[static_cast<std::size_t>(e)]);
    for (Eigen::Index v = 0; v < V; ++v) {
        const double len = s.row(v).norm();
        s.row(v) = len > 0 ? Eigen::RowVector3d(s.row(v) / len) : Eigen::RowVector3d::Zero();
    }
    return s;
}

/// For each point, the mesh vertex nearest to it (the recentring's assignment, and the fit's for
/// the far-side cut).
IndexVector nearest_vertex(const Mesh& mesh, const PointsF& points) {
    return KdTree(mesh.vertices.cast<float>()).nearest(points);
}

}  // namespace

Mesh offset_along_normals(const Mesh& mesh, double distance) {
    PCP_CHECK(std::isfinite(distance), "offset along normals: the distance must be finite");
    if (distance == 0.0) return mesh;
    return offset_along_normals(mesh, Eigen::VectorXd::Constant(mesh.vertices.rows(), distance));
}

Mesh offset_along_normals(const Mesh& mesh, const Eigen::VectorXd& distances) {
    PCP_CHECK(distances.size() == mesh.vertices.rows(), "offset along normals: " << distances.size()
                                                        << " distances for " << mesh.vertices.rows() << " vertices");
    PCP_CHECK(distances.allFinite(), "offset along normals: the distances must be finite");
    Mesh out = mesh;
    if (mesh.faces.rows() == 0) return out;
    for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f)
        for (int k = 0; k < 3; ++k)
            PCP_CHECK(mesh.faces(f, k) >= 0 && mesh.faces(f, k) < mesh.vertices.rows(),
                      "offset along normals: face " << f << " indexes vertex " << mesh.faces(f, k) << " of "
                                                    << mesh.vertices.rows());
    const OneRing ring(mesh);
    out.vertices.array() += vertex_normals(mesh, ring).array().colwise() * distances.array();
    return out;
}

Mesh fit_surface_to_points(const Mesh& unit_mesh, const KdTree& cloud, const SurfaceFitOptions& options,
                           SurfaceFitStats* stats) {
    PCP_CHECK(options.support_k > 0 && options.move_k > 0, "surface fit: support_k and move_k must be > 0");
    PCP_CHECK(options.min_supported >= 0 && options.min_supported <= 1, "surface fit: min_supported must be in [0, 1]");
    PCP_CHECK(options.min_extent_k >= 0 && options.blister_k >= 0, "surface fit: min_extent_k and blister_k must be >= 0");
    PCP_CHECK(options.iterations >= 0 && options.iterations <= 100, "surface fit: iterations must be in [0, 100]");
    PCP_CHECK(options.surface_rounds >= 0, "surface fit: surface_rounds must be >= 0");
    PCP_CHECK(options.neighbors >= 3, "surface fit: neighbors must be >= 3");
    PCP_CHECK(options.bandwidth > 0, "surface fit: bandwidth must be > 0");
    PCP_CHECK(options.relax >= 0 && options.relax <= 1, "surface fit: relax must be in [0, 1]");
    PCP_CHECK(options.noise_spread >= 0 && std::isfinite(options.noise_spread) && options.far_side_k >= 0 && std::isfinite(options.far_side_k),
              "surface fit: noise_spread and far_side_k must be finite and >= 0");
    PCP_CHECK(options.far_side_clean_cos >= -1 && options.far_side_clean_cos <= 0, "surface fit: far_side_clean_cos must be in [-1, 0], got " << options.far_side_clean_cos);
    PCP_CHECK(options.far_side_clean_gap_k >= 0 && std::isfinite(options.far_side_clean_gap_k), "surface fit: far_side_clean_gap_k must be finite and >= 0, got " << options.far_side_clean_gap_k);
    PCP_CHECK(cloud.size() >= 2, "surface fit: the cloud needs at least two points");
    const Eigen::Index V0 = unit_mesh.vertices.rows();
    if (unit_mesh.faces.rows() > 0)
        PCP_CHECK(unit_mesh.faces.minCoeff() >= 0 && unit_mesh.faces.maxCoeff() < V0, "surface fit: a face index is out of range");
    SurfaceFitStats st;
    if (!options.enabled || unit_mesh.faces.rows() == 0) {
        if (stats) *stats = st;
        return unit_mesh;
    }
    st.scale = sampling_scale(cloud);
    const double support = options.support_k * st.scale;
    const double reach = options.move_k * st.scale;

    // 1. Support filter over connected components (vertices joined by faces).
    Eigen::VectorXf to_data;
    cloud.nearest(unit_mesh.vertices.cast<float>(), &to_data);
    const Components comp(unit_mesh);
    const Eigen::Index largest = comp.largest;  // never removed for its size
    std::vector<std::int64_t> supported(static_cast<std::size_t>(V0), 0);  // per root
    for (Eigen::Index v = 0; v < V0; ++v)
        if (comp.root[static_cast<std::size_t>(v)] >= 0 && to_data(v) <= support) ++supported[static_cast<std::size_t>(comp.root[static_cast<std::size_t>(v)])];
    std::vector<char> keep_root(static_cast<std::size_t>(V0), 0);
    bool others = false;  // a component other than the largest is kept
    for (Eigen::Index v = 0; v < V0; ++v) {
        const auto vs = static_cast<std::size_t>(v);
        if (comp.count[vs] == 0) continue;
        ++st.components;
        bool keep = static_cast<double>(supported[vs]) >= options.min_supported * static_cast<double>(comp.count[vs]);
        if (keep && v != largest && comp.diagonal(v) < options.min_extent_k * st.scale) {
            keep = false;
            ++st.removed_small;
        }
        keep_root[vs] = keep;
        if (!keep) ++st.removed_components;
        others = others || (keep && v != largest);
    }
    // A kept component (not the largest) whose every vertex lies within blister_k x scale of the
    // largest one's vertices is a blister on it: a second sheet of surface the largest already
    // has where the data is.
    if (others && options.blister_k > 0) {
        std::vector<Eigen::Index> main_vertices;
        std::vector<bool> blister(static_cast<std::size_t>(V0), true);
        for (Eigen::Index v = 0; v < V0; ++v)
            if (comp.root[static_cast<std::size_t>(v)] == largest) main_vertices.push_back(v);
        PointsF main_points(static_cast<Eigen::Index>(main_vertices.size()), 3);
        for (std::size_t i = 0; i < main_vertices.size(); ++i)
            main_points.row(Eigen::Index(i)) = unit_mesh.vertices.row(main_vertices[i]).cast<float>();
        const KdTree main_tree(main_points);
        for (Eigen::Index v = 0; v < V0; ++v) {
            const std::int32_t ri = comp.root[static_cast<std::size_t>(v)];
            if (ri < 0) continue;
            const auto r = static_cast<std::size_t>(ri);
            if (Eigen::Index(r) == largest || !keep_root[r] || !blister[r]) continue;
            float d = 0;
            main_tree.nearest_point(unit_mesh.vertices.row(v).transpose().cast<float>(), &d);
            if (double(d) > options.blister_k * st.scale) blister[r] = false;
        }
        for (Eigen::Index v = 0; v < V0; ++v)
            if (comp.count[static_cast<std::size_t>(v)] > 0 && v != largest && keep_root[static_cast<std::size_t>(v)] && blister[static_cast<std::size_t>(v)]) {
                keep_root[static_cast<std::size_t>(v)] = 0;
                ++st.removed_components;
                ++st.removed_blisters;
            }
    }
    Mesh mesh = keep_components(unit_mesh, comp, keep_root, &st.removed_faces);
    if (mesh.faces.rows() == 0) {
        if (stats) *stats = st;
        return mesh;
    }

    // 2-3. Normal mean-shift onto the data, then tangential relaxation.
    const OneRing ring(mesh);
    const Eigen::Index V = mesh.vertices.rows();
    const int K = static_cast<int>(std::min<Eigen::Index>(options.neighbors, cloud.size()));
    const PointsF& pts = cloud.points();
    NeighborIndices idx;
    NeighborDistances dist;
    // The far-side cut (SurfaceFitOptions::noise_spread, far_side_clean): on noisy data any vertex
    // facing the other way, far_side_k spreads behind; on clean data one facing nearly opposite,
    // far_side_clean_gap_k sampling scales behind.
    const bool noisy = options.noise_spread > 0;
    const bool cut_far_side = noisy || options.far_side_clean;
    const double far_gap = noisy ? options.far_side_k * options.noise_spread : options.far_side_clean_gap_k * st.scale;
    const double far_cos = noisy ? 0.0 : options.far_side_clean_cos;
    std::vector<double> to_surface;  // per input point: its signed distance to the mesh (negative behind its nearest face)
    for (int it = 0; it < options.iterations; ++it) {
        const bool surface_offsets = it >= options.iterations - options.surface_rounds;
        const Points normals = vertex_normals(mesh, ring);
        cloud.knn(mesh.vertices.cast<float>(), K, idx, dist);
        const IndexVector owner = cut_far_side ? nearest_vertex(mesh, pts) : IndexVector();
        if (surface_offsets) {  // each point's signed distance to its nearest face (exact, CGAL's AABB tree)
            const Points p = pts.cast<double>();
            Points closest;
            const Eigen::VectorXi face = detail::TriangleDistance(mesh).nearest_faces(p, closest);
            to_surface.resize(static_cast<std::size_t>(pts.rows()));
#pragma omp parallel for schedule(static)
            for (Eigen::Index i = 0; i < pts.rows(); ++i) {
                const Eigen::RowVector3d d = p.row(i) - closest.row(i);
                double side = 1;
                if (face(i) >= 0) {
                    const Eigen::RowVector3d a = mesh.vertices.row(mesh.faces(face(i), 0)), b = mesh.vertices.row(mesh.faces(face(i), 1)),
                                             c = mesh.vertices.row(mesh.faces(face(i), 2));
                    side = d.dot((b - a).cross(c - a)) < 0 ? -1 : 1;
                }
                to_surface[static_cast<std::size_t>(i)] = side * d.norm();
            }
        }
        Points moved = mesh.vertices;
        double shift_sum = 0;
        std::int64_t count = 0;
#pragma omp parallel reduction(+ : shift_sum, count)
        {
            // Per neighbour kept: its offset along the normal and its distance over h, which the
            // kernel's rounds reuse.
            std::vector<double> offsets(static_cast<std::size_t>(K)), scaled(static_cast<std::size_t>(K));
#pragma omp for schedule(static)
            for (Eigen::Index v = 0; v < V; ++v) {
                const Eigen::RowVector3d n = normals.row(v);
                if (dist(v, 0) > reach || n.squaredNorm() == 0) continue;
                const double h = std::max<double>(dist(v, K - 1), 1e-12);
                // The offset kernel's width follows the local sampling (10th neighbour), not the
                // neighbourhood: a wider neighbourhood averages more noise without reaching across
                // a thin part.
                const double b = options.bandwidth * std::max<double>(dist(v, std::min(K, 10) - 1), 1e-12);
                std::size_t kept = 0;
                for (int j = 0; j < K; ++j) {
                    if (cut_far_side) {  // a point of the far side of a thin part
                        const Eigen::Index u = owner(idx(v, j));
                        if (normals.row(u).dot(n) < far_cos && (mesh.vertices.row(v) - mesh.vertices.row(u)).dot(n) > far_gap) continue;
                    }
                    const Eigen::RowVector3d p = pts.row(idx(v, j)).cast<double>();
                    offsets[kept] = surface_offsets ? to_surface[static_cast<std::size_t>(idx(v, j))] : (p - mesh.vertices.row(v)).dot(n);
                    scaled[kept] = dist(v, j) / h;
                    ++kept;
                }
                double m = 0, se2 = 0;
                for (int round = 0; round < 8; ++round) {
                    double sw = 0, so = 0, soo = 0, sww = 0;
                    for (std::size_t j = 0; j < kept; ++j) {
                        const double o = offsets[j];
                        const double dj = scaled[j], oj = (o - m) / b;
                        const double w = std::exp(-dj * dj - oj * oj);
                        sw += w;
                        sww += w * w;
                        so += w * o;
                        soo += w * o * o;
                    }
                    if (!(sw > 1e-300)) break;
                    const double next = so / sw;
                    // Squared standard error of the weighted mean: variance / effective count.
                    se2 = std::max(0.0, soo / sw - next * next) * sww / (sw * sw);
                    const bool done = std::abs(next - m) < 1e-4 * h;
                    m = next;
                    if (done) break;
                }
                // Shrink a move the data cannot tell from its own noise (none on clean data).
                if (options.shrink && m != 0) m *= std::max(0.0, 1.0 - se2 / (m * m));
                m = std::clamp(m, -h, h);
                moved.row(v) += m * n;
                shift_sum += std::abs(m);
                ++count;
            }
        }  // omp parallel
        st.mean_shift = count ? shift_sum / static_cast<double>(count) : 0.0;
        st.supported_vertices = count;
        mesh.vertices = moved;
        if (options.relax > 0) {
            const Points n2 = vertex_normals(mesh, ring);
#pragma omp parallel for schedule(static)
            for (Eigen::Index v = 0; v < V; ++v) {
                const std::int64_t b0 = ring.start[static_cast<std::size_t>(v)], b1 = ring.start[static_cast<std::size_t>(v) + 1];
                if (b1 == b0) continue;
                Eigen::RowVector3d c = Eigen::RowVector3d::Zero();
                for (std::int64_t e = b0; e < b1; ++e) c += mesh.vertices.row(ring.ids[static_cast<std::size_t>(e)]);
                Eigen::RowVector3d l = c / static_cast<double>(b1 - b0) - mesh.vertices.row(v);
                const Eigen::RowVector3d n = n2.row(v);
                l -= l.dot(n) * n;
                moved.row(v) = mesh.vertices.row(v) + options.relax * l;
            }
            mesh.vertices = moved;
        }
    }
    if (stats) *stats = st;
    return mesh;
}

Mesh recentre_on_points(const Mesh& unit_mesh, const KdTree& cloud, const RecentreOptions& options, RecentreStats* stats) {
    PCP_CHECK(options.window_k > 0 && std::isfinite(options.window_k), "recentre: window_k must be > 0, got " << options.window_k);
    PCP_CHECK(options.passes >= 1 && options.passes <= 20, "recentre: passes must be in [1, 20], got " << options.passes);
    PCP_CHECK(options.clip_k > 0 && std::isfinite(options.clip_k), "recentre: clip_k must be > 0, got " << options.clip_k);
    PCP_CHECK(options.max_move_k > 0 && std::isfinite(options.max_move_k), "recentre: max_move_k must be > 0, got " << options.max_move_k);
    const Eigen::Index V = unit_mesh.vertices.rows();
    if (unit_mesh.faces.rows() > 0)
        PCP_CHECK(unit_mesh.faces.minCoeff() >= 0 && unit_mesh.faces.maxCoeff() < V, "recentre: a face index is out of range");
    RecentreStats st;
    Mesh mesh = unit_mesh;
    if (mesh.faces.rows() == 0 || cloud.size() < 2) {
        if (stats) *stats = st;
        return mesh;
    }
    const OneRing ring(mesh);
    double edge = 0;
    for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f)
        for (int k = 0; k < 3; ++k) edge += (mesh.vertices.row(mesh.faces(f, k)) - mesh.vertices.row(mesh.faces(f, (k + 1) % 3))).norm();
    edge /= 3.0 * static_cast<double>(mesh.faces.rows());
    // A walk of r one-ring averaging rounds spreads over about edge x sqrt(r / 2).
    const double width = options.window_k * sampling_scale(cloud) / std::max(edge, 1e-12);
    st.rounds = static_cast<int>(std::clamp(std::ceil(2.0 * width * width), 1.0, 400.0));
    const PointsF& pts = cloud.points();
    const Eigen::Index N = pts.rows();
    const auto Vs = static_cast<std::size_t>(V);
    std::vector<double> offset(static_cast<std::size_t>(N)), magnitude(static_cast<std::size_t>(N));
    std::vector<double> sum(Vs), count(Vs), sum_next(Vs), count_next(Vs);
    for (int pass = 0; pass < options.passes; ++pass) {
        const Points normals = vertex_normals(mesh, ring);
        const IndexVector nearest = nearest_vertex(mesh, pts);
#pragma omp parallel for schedule(static)
        for (Eigen::Index i = 0; i < N; ++i) {
            const Eigen::Index v = nearest(i);
            offset[static_cast<std::size_t>(i)] = (pts.row(i).cast<double>() - mesh.vertices.row(v)).dot(normals.row(v));
        }
        // The noise's spread: 1.4826 x the median absolute deviation from the median offset (a
        // common bias does not widen it).
        const auto mid = magnitude.begin() + static_cast<std::ptrdiff_t>(magnitude.size() / 2);
        std::copy(offset.begin(), offset.end(), magnitude.begin());
        std::nth_element(magnitude.begin(), mid, magnitude.end());
        const double median = *mid;
        for (std::size_t i = 0; i < offset.size(); ++i) magnitude[i] = std::abs(offset[i] - median);
        std::nth_element(magnitude.begin(), mid, magnitude.end());
        st.spread = 1.4826 * *mid;
        const double clip = options.clip_k * st.spread;
        std::fill(sum.begin(), sum.end(), 0.0);
        std::fill(count.begin(), count.end(), 0.0);
        for (Eigen::Index i = 0; i < N; ++i) {
            const double o = offset[static_cast<std::size_t>(i)];
            if (!(std::abs(o) <= clip)) continue;
            const auto v = static_cast<std::size_t>(nearest(i));
            sum[v] += o;
            count[v] += 1.0;
        }
        for (int round = 0; round < st.rounds; ++round) {
#pragma omp parallel for schedule(static)
            for (Eigen::Index v = 0; v < V; ++v) {
                const auto vs = static_cast<std::size_t>(v);
                const std::int64_t b0 = ring.start[vs], b1 = ring.start[vs + 1];
                double s = sum[vs], c = count[vs];
                for (std::int64_t e = b0; e < b1; ++e) {
                    const auto u = static_cast<std::size_t>(ring.ids[static_cast<std::size_t>(e)]);
                    s += sum[u];
                    c += count[u];
                }
                const double k = 1.0 + static_cast<double>(b1 - b0);
                sum_next[vs] = s / k;
                count_next[vs] = c / k;
            }
            sum.swap(sum_next);
            count.swap(count_next);
        }
        // A window's mean offset is a bias of the surface when it is a fraction of the noise; one
        // beyond the noise is a sheet away from the data (an inner sheet, a membrane across a
        // bore), which moving would crumple: such moves fade out.
        const double fade = options.max_move_k * st.spread;
        Eigen::VectorXd move = Eigen::VectorXd::Zero(V);
        for (Eigen::Index v = 0; v < V; ++v) {
            const auto vs = static_cast<std::size_t>(v);
            if (!(count[vs] > 1e-12) || normals.row(v).squaredNorm() == 0) continue;
            const double m = sum[vs] / count[vs];
            move(v) = m * std::clamp(2.0 - std::abs(m) / std::max(fade, 1e-300), 0.0, 1.0);
        }
        mesh.vertices += move.asDiagonal() * normals;
        double moved = 0;
        std::int64_t n_moved = 0;
        for (Eigen::Index v = 0; v < V; ++v)
            if (move(v) != 0) {
                moved += move(v);
                ++n_moved;
            }
        st.mean_move += n_moved ? moved / static_cast<double>(n_moved) : 0.0;
    }
    if (stats) *stats = st;
    return mesh;
}

Points mesh_vertex_normals(const Mesh& mesh) { return vertex_normals(mesh, OneRing(mesh)); }

Mesh trim_unsupported_faces(const Mesh& unit_mesh, const KdTree& cloud, double radius, std::int64_t* removed) {
    PCP_CHECK(radius > 0 && std::isfinite(radius), "trim_unsupported_faces: radius must be > 0, got " << radius);
    const Eigen::Index F = unit_mesh.faces.rows(), V = unit_mesh.vertices.rows();
    PCP_CHECK(F == 0 || (unit_mesh.faces.minCoeff() >= 0 && unit_mesh.faces.maxCoeff() < V),
              "trim_unsupported_faces: a face index is out of range");
    PointsF centroids(F, 3);
    for (Eigen::Index f = 0; f < F; ++f)
        centroids.row(f) = ((unit_mesh.vertices.row(unit_mesh.faces(f, 0)) + unit_mesh.vertices.row(unit_mesh.faces(f, 1)) +
                             unit_mesh.vertices.row(unit_mesh.faces(f, 2))) /
                            3.0)
                               .cast<float>();
    Eigen::VectorXf distance(F);
    if (F > 0) cloud.nearest(centroids, &distance);
    std::vector<int> new_index(static_cast<std::size_t>(V), -1);
    std::vector<Eigen::Index> kept_faces;
    for (Eigen::Index f = 0; f < F; ++f)
        if (static_cast<double>(distance(f)) <= radius) kept_faces.push_back(f);
    Mesh out;
    int next = 0;
    for (Eigen::Index f : kept_faces)
        for (int c = 0; c < 3; ++c) {
            int& id = new_index[static_cast<std::size_t>(unit_mesh.faces(f, c))];
            if (id < 0) id = next++;
        }
    out.vertices.resize(next, 3);
    for (Eigen::Index v = 0; v < V; ++v)
        if (new_index[static_cast<std::size_t>(v)] >= 0) out.vertices.row(new_index[static_cast<std::size_t>(v)]) = unit_mesh.vertices.row(v);
    out.faces.resize(static_cast<Eigen::Index>(kept_faces.size()), 3);
    for (std::size_t k = 0; k < kept_faces.size(); ++k)
        for (int c = 0; c < 3; ++c)
            out.faces(static_cast<Eigen::Index>(k), c) = new_index[static_cast<std::size_t>(unit_mesh.faces(kept_faces[k], c))];
    if (removed) *removed = F - static_cast<std::int64_t>(kept_faces.size());
    return out;
}

Mesh remove_small_components(const Mesh& mesh, double min_diagonal, std::int64_t* removed) {
    PCP_CHECK(min_diagonal >= 0 && std::isfinite(min_diagonal), "remove_small_components: min_diagonal must be finite and >= 0, got " << min_diagonal);
    const Eigen::Index V = mesh.vertices.rows(), F = mesh.faces.rows();
    PCP_CHECK(F == 0 || (mesh.faces.minCoeff() >= 0 && mesh.faces.maxCoeff() < V), "remove_small_components: a face index is out of range");
    const Components comp(mesh);
    std::vector<char> keep_root(static_cast<std::size_t>(V), 1);
    std::int64_t n_removed = 0;
    for (Eigen::Index v = 0; v < V; ++v)
        if (comp.count[static_cast<std::size_t>(v)] > 0 && v != comp.largest && comp.diagonal(v) < min_diagonal) {
            keep_root[static_cast<std::size_t>(v)] = 0;
            ++n_removed;
        }
    if (removed) *removed = n_removed;
    return n_removed == 0 ? mesh : keep_components(mesh, comp, keep_root);
}

Mesh fair_unsupported(const Mesh& unit_mesh, const KdTree& cloud, const FairOptions& options, FairStats* stats) {
    PCP_CHECK(options.support_k > 0 && std::isfinite(options.support_k), "fairing: support_k must be > 0, got " << options.support_k);
    PCP_CHECK(options.guard >= 0 && std::isfinite(options.guard), "fairing: guard must be >= 0, got " << options.guard);
    PCP_CHECK(options.support_count >= 1, "fairing: support_count must be >= 1, got " << options.support_count);
    const Eigen::Index V = unit_mesh.vertices.rows();
    PCP_CHECK(unit_mesh.faces.rows() == 0 || (unit_mesh.faces.minCoeff() >= 0 && unit_mesh.faces.maxCoeff() < V),
              "fairing: a face index is out of range");
    PCP_CHECK(unit_mesh.vertices.allFinite(), "fairing: a vertex coordinate is not finite");
    FairStats st;
    Mesh mesh = unit_mesh;
    if (!options.enabled || V == 0 || unit_mesh.faces.rows() == 0) {
        if (stats) *stats = st;
        return mesh;
    }
    const OneRing ring(mesh);
    const auto degree = [&](std::size_t v) { return static_cast<double>(ring.start[v + 1] - ring.start[v]); };
    // Free: fewer than support_count input points within the support radius (and on some face).
    const double radius = options.support_k * sampling_scale(cloud);
    const int count = static_cast<int>(std::min<Eigen::Index>(options.support_count, cloud.size()));
    const Eigen::VectorXf kth = cloud.kth_distance(mesh.vertices.cast<float>(), count);
    std::vector<char> loose(static_cast<std::size_t>(V), 0);
    for (Eigen::Index v = 0; v < V; ++v)
        loose[static_cast<std::size_t>(v)] = static_cast<double>(kth(v)) > radius && degree(static_cast<std::size_t>(v)) > 0;
    // Patches of free vertices joined along edges; those that touch no supported vertex stay put.
    std::vector<std::int32_t> parent(static_cast<std::size_t>(V));
    std::iota(parent.begin(), parent.end(), 0);
    for (Eigen::Index v = 0; v < V; ++v) {
        const auto vs = static_cast<std::size_t>(v);
        if (!loose[vs]) continue;
        for (std::int64_t e = ring.start[vs]; e < ring.start[vs + 1]; ++e) {
            const std::int32_t u = ring.ids[static_cast<std::size_t>(e)];
            if (loose[static_cast<std::size_t>(u)]) parent[static_cast<std::size_t>(find_root(parent, u))] = find_root(parent, static_cast<std::int32_t>(v));
        }
    }
    std::vector<std::int32_t> patch(static_cast<std::size_t>(V), -1);  // each loose vertex's patch (its root)
    for (Eigen::Index v = 0; v < V; ++v)
        if (loose[static_cast<std::size_t>(v)]) patch[static_cast<std::size_t>(v)] = find_root(parent, static_cast<std::int32_t>(v));
    std::vector<char> anchored(static_cast<std::size_t>(V), 0);
    for (Eigen::Index v = 0; v < V; ++v) {
        const auto vs = static_cast<std::size_t>(v);
        if (!loose[vs]) continue;
        const std::int32_t r = patch[vs];
        for (std::int64_t e = ring.start[vs]; e < ring.start[vs + 1]; ++e)
            if (!loose[static_cast<std::size_t>(ring.ids[static_cast<std::size_t>(e)])]) anchored[static_cast<std::size_t>(r)] = 1;
    }
    std::vector<std::int32_t> var(static_cast<std::size_t>(V), -1);
    std::int32_t n_free = 0;
    for (Eigen::Index v = 0; v < V; ++v) {
        const auto vs = static_cast<std::size_t>(v);
        if (!loose[vs]) continue;
        if (anchored[static_cast<std::size_t>(patch[vs])]) var[vs] = n_free++;
        else ++st.unanchored;
    }
    for (Eigen::Index v = 0; v < V; ++v)  // a patch's root is the loose vertex that is its own parent
        if (loose[static_cast<std::size_t>(v)] && parent[static_cast<std::size_t>(v)] == v && anchored[static_cast<std::size_t>(v)]) ++st.patches;
    st.free_vertices = n_free;
    if (n_free == 0) {
        if (stats) *stats = st;
        return mesh;
    }
    // The cotangent Laplacian L (L_ij = (cot a + cot b) / 2 along an edge, the angles facing it,
    // clipped to [0.1, 10] x their mean so that slivers of the marching cubes neither cut nor
    // dominate; L_ii = -sum_j L_ij) and the vertex areas A (a third of the faces'): the bi-Laplacian
    // L A^-1 L is the mesh's thin-plate energy whatever its triangles' shapes (the graph Laplacian
    // of a raw marching-cubes sphere flattened an unsupported cap twice as much). With the clip at
    // [0.01, 1000] x the mean, abc_00016513's mesh at 256 cells grew needles up to 1.7 long: a
    // vertex tied by a clipped small weight to a row that a large one dominates is pushed far to
    // zero that row (docs/BENCHMARKS.md, "Needles in the fairing at 256 cells").
    std::vector<double> weight(ring.ids.size(), 0.0);
    Eigen::VectorXd area = Eigen::VectorXd::Zero(V);
    const auto slot = [&](std::int32_t a, std::int32_t b) {  // position of b in a's sorted one-ring
        const auto first = ring.ids.begin() + ring.start[static_cast<std::size_t>(a)];
        const auto last = ring.ids.begin() + ring.start[static_cast<std::size_t>(a) + 1];
        return static_cast<std::size_t>(std::lower_bound(first, last, b) - ring.ids.begin());
    };
    for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
        const Eigen::RowVector3d p0 = mesh.vertices.row(mesh.faces(f, 0)), p1 = mesh.vertices.row(mesh.faces(f, 1)),
                                 p2 = mesh.vertices.row(mesh.faces(f, 2));
        const double twice_area = (p1 - p0).cross(p2 - p0).norm();
        for (int k = 0; k < 3; ++k) {
            const std::int32_t a = mesh.faces(f, k), b = mesh.faces(f, (k + 1) % 3), c = mesh.faces(f, (k + 2) % 3);
            area(a) += twice_area / 6;
            if (b == c) continue;
            const Eigen::RowVector3d u = mesh.vertices.row(b) - mesh.vertices.row(a), w = mesh.vertices.row(c) - mesh.vertices.row(a);
            const double half_cot = 0.5 * u.dot(w) / std::max(u.cross(w).norm(), 1e-300);
            weight[slot(b, c)] += half_cot;
            weight[slot(c, b)] += half_cot;
        }
    }
    double mean_weight = 0;
    for (double w : weight) mean_weight += std::abs(w);
    mean_weight = std::max(mean_weight / static_cast<double>(std::max<std::size_t>(weight.size(), 1)), 1e-300);
    for (double& w : weight) w = std::clamp(w, 0.1 * mean_weight, 10 * mean_weight);
    area = area.cwiseMax(1e-6 * std::max(area.mean(), 1e-300));  // no division by a sliver's zero area
    Eigen::VectorXd diagonal = Eigen::VectorXd::Zero(V);  // L_ii
    for (Eigen::Index v = 0; v < V; ++v)
        for (std::int64_t e = ring.start[static_cast<std::size_t>(v)]; e < ring.start[static_cast<std::size_t>(v) + 1]; ++e)
            diagonal(v) -= weight[static_cast<std::size_t>(e)];
    // The rows of L A^-1 L of the free vertices: sum over k = i and the one-ring of i of L_ik L_kj / A_k.
    // Free columns form the (symmetric, positive definite) system, fixed ones its right-hand side.
    std::vector<Eigen::Triplet<double>> triplets;
    Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(n_free, 3);
    const auto add = [&](std::int32_t row, std::int32_t col, double value) {
        const std::int32_t c = var[static_cast<std::size_t>(col)];
        if (c >= 0) triplets.emplace_back(row, c, value);
        else rhs.row(row) -= value * mesh.vertices.row(col);
    };
    const auto add_row_of_k = [&](std::int32_t row, std::int32_t k, double factor) {  // factor x row k of L
        add(row, k, factor * diagonal(k));
        for (std::int64_t e = ring.start[static_cast<std::size_t>(k)]; e < ring.start[static_cast<std::size_t>(k) + 1]; ++e)
            add(row, ring.ids[static_cast<std::size_t>(e)], factor * weight[static_cast<std::size_t>(e)]);
    };
    for (Eigen::Index v = 0; v < V; ++v) {
        const auto vs = static_cast<std::size_t>(v);
        const std::int32_t row = var[vs];
        if (row < 0) continue;
        add_row_of_k(row, static_cast<std::int32_t>(v), diagonal(v) / area(v));
        for (std::int64_t e = ring.start[vs]; e < ring.start[vs + 1]; ++e) {
            const std::int32_t k = ring.ids[static_cast<std::size_t>(e)];
            add_row_of_k(row, k, weight[static_cast<std::size_t>(e)] / area(k));
        }
    }
    Eigen::SparseMatrix<double> system(n_free, n_free);
    system.setFromTriplets(triplets.begin(), triplets.end());
    // Positive definite in exact arithmetic; should rounding still defeat the factorisation, the
    // mesh stays as the fit left it (the fairing is a refinement, never worth losing a run for).
    const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(system);
    Eigen::MatrixXd x;
    if (solver.info() == Eigen::Success) x = solver.solve(rhs);
    if (solver.info() != Eigen::Success || !x.allFinite()) {
        st.failed = true;
        st.free_vertices = 0;
        if (stats) *stats = st;
        return mesh;
    }
    // A patch whose solution leaves the box of its vertices and their one-rings, grown by
    // options.guard x that box's diagonal, is left as it was: a thin plate stays near its border and
    // its own guess, so a vertex beyond that is an ill-conditioned solve, not a smoother surface.
    const double inf = std::numeric_limits<double>::infinity();
    std::vector<Eigen::Vector3d> low(static_cast<std::size_t>(V), Eigen::Vector3d::Constant(inf)),
        high(static_cast<std::size_t>(V), Eigen::Vector3d::Constant(-inf));
    std::vector<char> reverted(static_cast<std::size_t>(V), 0);
    for (Eigen::Index v = 0; v < V; ++v) {
        if (var[static_cast<std::size_t>(v)] < 0) continue;
        const auto r = static_cast<std::size_t>(patch[static_cast<std::size_t>(v)]);
        const auto grow = [&](Eigen::Index u) {
            low[r] = low[r].cwiseMin(mesh.vertices.row(u).transpose());
            high[r] = high[r].cwiseMax(mesh.vertices.row(u).transpose());
        };
        grow(v);
        for (std::int64_t e = ring.start[static_cast<std::size_t>(v)]; e < ring.start[static_cast<std::size_t>(v) + 1]; ++e)
            grow(ring.ids[static_cast<std::size_t>(e)]);
    }
    for (Eigen::Index v = 0; v < V; ++v) {
        const std::int32_t i = var[static_cast<std::size_t>(v)];
        if (i < 0) continue;
        const auto r = static_cast<std::size_t>(patch[static_cast<std::size_t>(v)]);
        const double margin = options.guard * (high[r] - low[r]).norm();
        const Eigen::Vector3d p = x.row(i).transpose();
        if (((p - low[r]).array() < -margin).any() || ((p - high[r]).array() > margin).any()) reverted[r] = 1;
    }
    double moved = 0;
    for (Eigen::Index v = 0; v < V; ++v) {
        const std::int32_t i = var[static_cast<std::size_t>(v)];
        if (i < 0) continue;
        if (reverted[static_cast<std::size_t>(patch[static_cast<std::size_t>(v)])]) {
            --st.free_vertices;
            continue;
        }
        moved += (x.row(i) - mesh.vertices.row(v)).norm();
        mesh.vertices.row(v) = x.row(i);
    }
    st.reverted = std::count(reverted.begin(), reverted.end(), char{1});
    st.patches -= st.reverted;
    st.mean_move = st.free_vertices > 0 ? moved / static_cast<double>(st.free_vertices) : 0.0;
    if (stats) *stats = st;
    return mesh;
}

}  // namespace pcp
