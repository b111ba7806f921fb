// Recentring onto the middle of the points' noise (see include/pcp/mesh/surface/recentre.hpp).
#include "pcp/mesh/surface/recentre.hpp"

#include "pcp/core/error.hpp"
#include "mesh/surface/mesh_rings.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace pcp {

using detail::OneRing;
using detail::nearest_vertex;
using detail::vertex_normals;

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

}  // namespace pcp
