// Shell centring (see include/pcp/mesh/surface/shell_centre.hpp).
#include "pcp/mesh/surface/shell_centre.hpp"

#include "mesh/grid/grid_samples.hpp"
#include "pcp/core/error.hpp"
#include "pcp/mesh/surface/mesh_ops.hpp"
#include "pcp/cloud/kdtree.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace pcp {
Mesh centre_in_shells(const Mesh& mesh, const SdfGrid& before, const SdfGrid& after, const KdTree& cloud, double max_thickness,
                      ShellCentreStats* stats) {
    PCP_CHECK(max_thickness > 0 && std::isfinite(max_thickness), "shell centring: max_thickness must be > 0, got " << max_thickness);
    PCP_CHECK(before.spec.resolution == after.spec.resolution && before.spec.box.min == after.spec.box.min &&
                  before.spec.box.max == after.spec.box.max && before.block_keys == after.block_keys,
              "shell centring: the grids before and after the fills differ");
    ShellCentreStats st;
    st.applied = true;
    const std::vector<float> pre = detail::lattice_values(before), post = detail::lattice_values(after);
    const detail::TrilinearLattice field_before{before.spec, pre}, field_after{after.spec, post};
    const Points normals = mesh_vertex_normals(mesh);
    const double step = 0.25 * before.spec.spacing().minCoeff();
    const int steps = static_cast<int>(std::ceil(max_thickness / step));
    const Eigen::Index V = mesh.vertices.rows();
    Eigen::VectorXd wall_depth = Eigen::VectorXd::Zero(V);
#pragma omp parallel for schedule(dynamic, 256)
    for (Eigen::Index v = 0; v < V; ++v) {
        const Eigen::RowVector3d n = normals.row(v);
        if (n.squaredNorm() == 0) continue;
        const Eigen::RowVector3d x = mesh.vertices.row(v);
        float last = field_before.at(x);
        if (std::isnan(last)) continue;
        bool inside = last < 0;  // the walk starts on the wall (the thin offset may leave it just outside)
        for (int s = 1; s <= steps; ++s) {
            const double t = s * step;
            const Eigen::RowVector3d p = x - t * n;
            const float b = field_before.at(p);
            if (std::isnan(b)) break;
            if (b <= 0) inside = true;
            if (b > 0 && inside) {
                // The inner wall, between the last two samples (linear). It counts only when what
                // lies behind it is a hollow the fills closed (negative now), at least as deep again
                // as the wall is thick: real outside there is the other side of a thin part, a
                // shallower pocket a bubble in a solid part.
                const double t0 = t - step;
                const double wall = t0 + step * static_cast<double>(-last) / static_cast<double>(b - last);
                if (wall > max_thickness) break;
                bool hollow = true;
                for (double u = t; u <= t + wall && hollow; u += step) {
                    const Eigen::RowVector3d q = x - u * n;
                    hollow = field_before.at(q) > 0 && field_after.at(q) < 0;
                }
                if (!hollow) break;
                wall_depth(v) = wall;
                break;
            }
            last = b;
        }
    }
    // Where in the shell the data is: the median offset along n of the input points nearest to the
    // shell's middle, among those within the shell (and half a wall beyond either side), inward only.
    std::vector<Eigen::Index> shell;
    for (Eigen::Index v = 0; v < V; ++v)
        if (wall_depth(v) > 0) shell.push_back(v);
    Eigen::VectorXd move = Eigen::VectorXd::Zero(V);
    double moved_sum = 0;
    std::int64_t moved = 0;
    const int K = static_cast<int>(std::min<Eigen::Index>(32, cloud.size()));
    if (!shell.empty() && K >= 5) {
        // Three probes per vertex, at depths 0, t/2 and t, so that the points gathered cover the
        // shell evenly (one probe at either wall would favour the data on its side).
        const auto S = static_cast<Eigen::Index>(shell.size());
        PointsF probes(3 * S, 3);
        for (Eigen::Index i = 0; i < S; ++i)
            for (int k = 0; k < 3; ++k)
                probes.row(3 * i + k) = (mesh.vertices.row(shell[static_cast<std::size_t>(i)]) -
                                         0.5 * k * wall_depth(shell[static_cast<std::size_t>(i)]) * normals.row(shell[static_cast<std::size_t>(i)]))
                                            .cast<float>();
        NeighborIndices idx;
        NeighborDistances dist;
        cloud.knn(probes, K, idx, dist);
        const PointsF& pts = cloud.points();
#pragma omp parallel for schedule(static) reduction(+ : moved_sum, moved)
        for (std::size_t i = 0; i < shell.size(); ++i) {
            const Eigen::Index v = shell[i];
            const double t = wall_depth(v);
            const Eigen::RowVector3d x = mesh.vertices.row(v), n = normals.row(v);
            std::vector<std::int64_t> ids;
            ids.reserve(static_cast<std::size_t>(3 * K));
            for (int k = 0; k < 3; ++k)
                for (int j = 0; j < K; ++j) ids.push_back(idx(3 * static_cast<Eigen::Index>(i) + k, j));
            std::sort(ids.begin(), ids.end());
            ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
            std::vector<double> all, o;
            all.reserve(ids.size());
            for (std::int64_t id : ids) all.push_back((pts.row(static_cast<Eigen::Index>(id)).cast<double>() - x).dot(n));
            // The median of the offsets within t of the estimate, from the shell's middle until it
            // settles: a window centred on the estimate itself, so neither wall is favoured.
            double m = -0.5 * t;
            bool ok = true;
            for (int round = 0; round < 8 && ok; ++round) {
                o.clear();
                for (double a : all)
                    if (std::abs(a - m) <= t) o.push_back(a);
                if (o.size() < 5) {
                    ok = false;
                    break;
                }
                std::nth_element(o.begin(), o.begin() + static_cast<std::ptrdiff_t>(o.size() / 2), o.end());
                const double next = o[o.size() / 2];
                const bool settled = std::abs(next - m) < 0.01 * t;
                m = next;
                if (settled) break;
            }
            if (!ok) continue;
            m = std::clamp(m, -t, 0.0);
            move(v) = m;
            moved_sum += -m;
            ++moved;
        }
    }
    // Two rounds of one-ring averaging (unmoved vertices count as 0): no step where the moved part
    // of the surface meets the unmoved.
    if (moved > 0) {
        std::vector<std::vector<std::int32_t>> ring(static_cast<std::size_t>(V));
        for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f)
            for (int k = 0; k < 3; ++k) {
                const std::int32_t a = mesh.faces(f, k), c = mesh.faces(f, (k + 1) % 3);
                ring[static_cast<std::size_t>(a)].push_back(c);
                ring[static_cast<std::size_t>(c)].push_back(a);
            }
        for (int round = 0; round < 2; ++round) {
            Eigen::VectorXd next = move;
#pragma omp parallel for schedule(static)
            for (Eigen::Index v = 0; v < V; ++v) {
                const auto& r = ring[static_cast<std::size_t>(v)];
                if (r.empty()) continue;
                double sum = move(v);
                for (std::int32_t u : r) sum += move(u);
                next(v) = sum / static_cast<double>(r.size() + 1);
            }
            move = next;
        }
    }
    st.moved = moved;
    st.mean_move = moved ? moved_sum / static_cast<double>(moved) : 0.0;
    if (stats) *stats = st;
    if (moved == 0) return mesh;
    return offset_along_normals(mesh, move);
}

}  // namespace pcp
