// Surface fit: support filter, normal mean-shift onto the data, tangential relaxation (see
// include/pcp/mesh/surface/surface_fit.hpp).
#include "pcp/mesh/surface/surface_fit.hpp"

#include "pcp/core/error.hpp"
#include "mesh/surface/mesh_rings.hpp"
#include "core/triangle_distance.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <vector>

namespace pcp {

using detail::Components;
using detail::OneRing;
using detail::keep_components;
using detail::nearest_vertex;
using detail::vertex_normals;

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

}  // namespace pcp
