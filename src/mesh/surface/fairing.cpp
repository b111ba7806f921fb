// Fairing where there is no data (see include/pcp/mesh/surface/fairing.hpp).
#include "pcp/mesh/surface/fairing.hpp"

#include "pcp/core/error.hpp"
#include "mesh/surface/mesh_rings.hpp"

#include <Eigen/Geometry>
#include <Eigen/SparseCholesky>

#include <algorithm>
#include <cmath>
#include <vector>

namespace pcp {

using detail::OneRing;
using detail::find_root;

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
    // [0.01, 1000] x the mean, a noisy scan's mesh at 256 cells grew needles up to 1.7 long: a
    // vertex tied by a clipped small weight to a row that a large one dominates is pushed far to
    // zero that row (docs/NOTEBOOK.md, "Needles in the fairing at 256 cells").
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
