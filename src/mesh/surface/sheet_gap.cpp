// The two sides of a thin part kept apart (see include/pcp/mesh/surface/sheet_gap.hpp).
#include "pcp/mesh/surface/sheet_gap.hpp"

#include "pcp/cloud/kdtree.hpp"
#include "pcp/core/error.hpp"
#include "pcp/mesh/surface/mesh_ops.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <vector>

namespace pcp {

Mesh keep_sheets_apart(const Mesh& unit_mesh, const SolidFn& solid, const SheetGapOptions& options, SheetGapStats* stats) {
    const auto t0 = std::chrono::steady_clock::now();
    PCP_CHECK(std::isfinite(options.min_gap) && options.min_gap > 0, "sheet gap: min_gap must be > 0, got " << options.min_gap);
    PCP_CHECK(options.passes >= 1 && options.passes <= 100, "sheet gap: passes must be in [1, 100], got " << options.passes);
    PCP_CHECK(options.opposite_cos >= -1 && options.opposite_cos < 0,
              "sheet gap: opposite_cos must be in [-1, 0), got " << options.opposite_cos);
    PCP_CHECK(std::isfinite(options.lateral) && options.lateral > 0, "sheet gap: lateral must be > 0, got " << options.lateral);
    PCP_CHECK(std::isfinite(options.search) && options.search > 0, "sheet gap: search must be > 0, got " << options.search);
    PCP_CHECK(std::isfinite(options.max_move) && options.max_move > 0, "sheet gap: max_move must be > 0, got " << options.max_move);
    PCP_CHECK(static_cast<bool>(solid), "sheet gap: no solid given");
    const Eigen::Index V = unit_mesh.vertices.rows(), F = unit_mesh.faces.rows();
    for (Eigen::Index f = 0; f < F; ++f)
        for (int c = 0; c < 3; ++c)
            PCP_CHECK(unit_mesh.faces(f, c) >= 0 && unit_mesh.faces(f, c) < V,
                      "sheet gap: face " << f << " refers to vertex " << unit_mesh.faces(f, c) << " of " << V);
    SheetGapStats st;
    Mesh out = unit_mesh;
    if (!options.enabled || V < 2 || F == 0) {
        if (stats) *stats = st;
        return out;
    }
    double edge_sum = 0;
    for (Eigen::Index f = 0; f < F; ++f)
        for (int c = 0; c < 3; ++c)
            edge_sum += (unit_mesh.vertices.row(unit_mesh.faces(f, c)) - unit_mesh.vertices.row(unit_mesh.faces(f, (c + 1) % 3))).norm();
    const double edge = edge_sum / (3.0 * static_cast<double>(F));
    const double reach = options.search * options.min_gap + 2 * edge, off_line = options.lateral * edge;
    const int K = static_cast<int>(std::min<Eigen::Index>(32, V));
    Eigen::VectorXd total = Eigen::VectorXd::Zero(V);
    std::vector<std::uint8_t> ever(static_cast<std::size_t>(V), 0);
    // The first pass looks at every vertex; each later one at those the pass before moved (a vertex
    // that found no partner closer than the gap does not find one when the moved sides part).
    std::vector<Eigen::Index> active(static_cast<std::size_t>(V));
    for (Eigen::Index i = 0; i < V; ++i) active[static_cast<std::size_t>(i)] = i;
    for (int pass = 0; pass < options.passes && !active.empty(); ++pass) {
        const Points normals = mesh_vertex_normals(out);
        const PointsF positions = out.vertices.cast<float>();
        const KdTree tree(positions);
        const auto A = static_cast<Eigen::Index>(active.size());
        PointsF queries(A, 3);
        for (Eigen::Index a = 0; a < A; ++a) queries.row(a) = positions.row(active[static_cast<std::size_t>(a)]);
        NeighborIndices idx;
        NeighborDistances dist;
        tree.knn(queries, K, idx, dist);
        Eigen::VectorXd move = Eigen::VectorXd::Zero(V);
        std::int64_t paired = 0, crossed = 0;
#pragma omp parallel for schedule(dynamic, 512) reduction(+ : paired, crossed)
        for (Eigen::Index a = 0; a < A; ++a) {
            const Eigen::Index i = active[static_cast<std::size_t>(a)];
            const Eigen::RowVector3d n = normals.row(i);
            if (n.squaredNorm() == 0) continue;
            const Eigen::RowVector3d p = out.vertices.row(i);
            double best = std::numeric_limits<double>::infinity(), s = 0;
            Eigen::Index partner = -1;
            for (int k = 0; k < K; ++k) {
                if (static_cast<double>(dist(a, k)) > reach) break;
                const Eigen::Index j = idx(a, k);
                if (j == i || normals.row(j).dot(n) > options.opposite_cos) continue;
                const Eigen::RowVector3d d = p - out.vertices.row(j);
                const double along = d.dot(n), off = (d - along * n).norm();
                if (off > off_line || off >= best) continue;
                best = off;
                s = along;
                partner = j;
            }
            if (partner < 0) continue;
            ++paired;
            if (s >= options.min_gap) continue;
            const Eigen::Vector3d mid = 0.5 * (p + out.vertices.row(partner)).transpose();
            const float inside = solid(mid);
            if (!(inside < 0)) continue;  // a gap between walls (or unknown): left alone
            if (s < 0) ++crossed;
            // At most max_move in all (a crumpled pocket's walls never settle: they would walk).
            move(i) = std::min(0.5 * (options.min_gap - s), options.max_move * options.min_gap - total(i));
        }
        if (pass == 0) {
            st.paired = paired;
            st.crossed = crossed;
        }
        active.clear();
        for (Eigen::Index i = 0; i < V; ++i) {
            if (move(i) <= 0) continue;
            out.vertices.row(i) += move(i) * normals.row(i);
            total(i) += move(i);
            ever[static_cast<std::size_t>(i)] = 1;
            active.push_back(i);
        }
    }
    st.moved = std::count(ever.begin(), ever.end(), std::uint8_t(1));
    st.max_move = total.size() ? total.maxCoeff() : 0.0;
    st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (stats) *stats = st;
    return out;
}

}  // namespace pcp
