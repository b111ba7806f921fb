// Fine sign repair on the stored samples of the fine grid (see include/pcp/mesh/repair/fine_repair.hpp).
#include "pcp/mesh/repair/fine_repair.hpp"

#include "pcp/core/error.hpp"
#include "mesh/grid/grid_samples.hpp"

#include <Eigen/Core>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace pcp {

namespace {

// Stamping (lattice_near_data): each point's ball on the lattice, threads owning slabs of k. Empty
// when it would test more than `budget` lattice points.
std::vector<std::int8_t> stamp_near(const GridSpec& spec, const PointsF& points, double tau, std::int64_t budget) {
    const int R = spec.resolution, n1 = R + 1;
    const Eigen::Vector3d h = spec.spacing(), lo = spec.box.min;
    // Lattice index range of a coordinate interval, one index wider on each side (the test decides).
    const auto range = [&](double a, double b, int c, int& first, int& last) {
        first = std::max(0, static_cast<int>(std::floor((a - lo(c)) / h(c))) - 1);
        last = std::min(R, static_cast<int>(std::ceil((b - lo(c)) / h(c))) + 1);
    };
    double per_point = 1;
    for (int c = 0; c < 3; ++c) per_point *= std::min(double(n1), 2.0 * tau / h(c) + 4.0);
    if (per_point * double(points.rows()) > double(budget)) return {};
    std::vector<std::int8_t> near(static_cast<std::size_t>(std::int64_t(n1) * n1 * n1), 0);
#pragma omp parallel
    {
        const int t = omp_get_thread_num(), T = omp_get_num_threads();
        const int k_first = int(std::int64_t(n1) * t / T), k_last = int(std::int64_t(n1) * (t + 1) / T) - 1;
        for (Eigen::Index p = 0; p < points.rows(); ++p) {
            const float px = points(p, 0), py = points(p, 1), pz = points(p, 2);
            int k0, k1, j0, j1, i0, i1;
            range(double(pz) - tau, double(pz) + tau, 2, k0, k1);
            k0 = std::max(k0, k_first);
            k1 = std::min(k1, k_last);
            if (k0 > k1) continue;
            range(double(py) - tau, double(py) + tau, 1, j0, j1);
            range(double(px) - tau, double(px) + tau, 0, i0, i1);
            for (int k = k0; k <= k1; ++k)
                for (int j = j0; j <= j1; ++j)
                    for (int i = i0; i <= i1; ++i) {
                        const std::int64_t g = (std::int64_t(k) * n1 + j) * n1 + i;
                        if (near[static_cast<std::size_t>(g)]) continue;
                        const Eigen::Vector3f q = spec.sample_position(i, j, k).cast<float>();
                        const float dx = q.x() - px, dy = q.y() - py, dz = q.z() - pz;
                        const float d = std::sqrt(dx * dx + dy * dy + dz * dz);
                        if (double(d) <= tau) near[static_cast<std::size_t>(g)] = 1;
                    }
        }
    }
    return near;
}

}  // namespace

namespace detail {

std::vector<std::int8_t> lattice_near_data(const GridSpec& spec, const std::vector<std::int64_t>& lattice_points,
                                           const KdTree& cloud, double tau, std::int64_t stamp_budget) {
    std::vector<std::int8_t> near = stamp_near(spec, cloud.points(), tau, stamp_budget);
    if (!near.empty()) return near;
    const std::int64_t n1 = spec.resolution + 1;
    near.assign(static_cast<std::size_t>(n1 * n1 * n1), 0);
    PointsF pos(static_cast<Eigen::Index>(lattice_points.size()), 3);
    for (std::size_t s = 0; s < lattice_points.size(); ++s) {
        const std::int64_t g = lattice_points[s];
        pos.row(static_cast<Eigen::Index>(s)) = spec.sample_position(g % n1, (g / n1) % n1, g / (n1 * n1)).cast<float>().transpose();
    }
    Eigen::VectorXf d;
    cloud.nearest(pos, &d);
    for (std::size_t s = 0; s < lattice_points.size(); ++s)
        near[static_cast<std::size_t>(lattice_points[s])] = d(static_cast<Eigen::Index>(s)) <= tau ? 1 : 0;
    return near;
}

}  // namespace detail

FineRepairStats repair_fine_grid(SdfGrid& grid, const KdTree& cloud, const FineRepairOptions& options) {
    PCP_CHECK(options.near_k > 0 && options.near_cells >= 0, "fine repair: near_k must be > 0 and near_cells >= 0");
    PCP_CHECK(options.max_unsupported >= 0 && options.max_unsupported < 1, "fine repair: max_unsupported must be in [0, 1)");
    PCP_CHECK(cloud.size() >= 2, "fine repair: the cloud needs at least two points");
    FineRepairStats st;
    if (!options.enabled || grid.num_blocks() == 0) return st;
    const int R = grid.spec.resolution, n1 = R + 1;
    const std::int64_t total = std::int64_t(n1) * n1 * n1;
    if (total > options.max_samples) {
        st.skipped = true;
        return st;
    }
    st.tau = std::max(options.near_k * sampling_scale(cloud), options.near_cells * grid.spec.spacing().norm());
    auto index = [n1](std::int64_t i, std::int64_t j, std::int64_t k) { return (k * n1 + j) * n1 + i; };

    // Signs of the stored lattice points (0: not stored), and their list.
    std::vector<std::int8_t> sign(static_cast<std::size_t>(total), 0);
    std::vector<std::int64_t> stored;
    detail::for_each_stored_sample(grid, [&](const float& v, std::int64_t g) {
        if (sign[static_cast<std::size_t>(g)] != 0) return;  // shared with a block seen before
        sign[static_cast<std::size_t>(g)] = v < 0 ? -1 : 1;
        stored.push_back(g);
    });

    // Near the data: within tau of an input point (stamped unless that costs more than 64 lattice
    // tests per stored sample).
    const std::vector<std::int8_t> near =
        detail::lattice_near_data(grid.spec, stored, cloud, st.tau, 64 * static_cast<std::int64_t>(stored.size()));

    // Components of one sign away from the data; anchored ones reach unstored space or the faces.
    std::vector<std::int32_t> comp(static_cast<std::size_t>(total), -1);
    std::vector<bool> flip;
    std::vector<std::int64_t> stack;
    const int di[6] = {1, -1, 0, 0, 0, 0}, dj[6] = {0, 0, 1, -1, 0, 0}, dk[6] = {0, 0, 0, 0, 1, -1};
    for (const std::int64_t seed : stored) {
        if (near[static_cast<std::size_t>(seed)] || comp[static_cast<std::size_t>(seed)] >= 0) continue;
        const std::int32_t c = static_cast<std::int32_t>(flip.size());
        const std::int8_t sg = sign[static_cast<std::size_t>(seed)];
        bool anchored = false;
        std::int64_t pairs_near = 0, pairs_away = 0;
        comp[static_cast<std::size_t>(seed)] = c;
        stack.assign(1, seed);
        while (!stack.empty()) {
            const std::int64_t g = stack.back();
            stack.pop_back();
            const int i = int(g % n1), j = int((g / n1) % n1), k = int(g / (std::int64_t(n1) * n1));
            for (int d = 0; d < 6; ++d) {
                const int a = i + di[d], b = j + dj[d], e = k + dk[d];
                if (a < 0 || b < 0 || e < 0 || a > R || b > R || e > R) {
                    anchored = true;
                    continue;
                }
                const std::int64_t m = index(a, b, e);
                const std::int8_t sm = sign[static_cast<std::size_t>(m)];
                if (sm == 0) {
                    anchored = true;
                } else if (near[static_cast<std::size_t>(m)]) {
                    ++pairs_near;
                } else if (sm != sg) {
                    ++pairs_away;
                } else if (comp[static_cast<std::size_t>(m)] < 0) {
                    comp[static_cast<std::size_t>(m)] = c;
                    stack.push_back(m);
                }
            }
        }
        const bool wrong = !anchored && pairs_away > 0 &&
                           double(pairs_away) > options.max_unsupported * double(pairs_away + pairs_near);
        flip.push_back(wrong);
        if (!anchored) ++st.components;
        if (wrong) ++st.flipped_components;
    }
    if (st.flipped_components == 0) return st;

    // Negate the flipped components' values in every block that stores them.
    detail::for_each_stored_sample(grid, [&](float& v, std::int64_t g) {
        const std::int32_t c = comp[static_cast<std::size_t>(g)];
        if (c >= 0 && flip[static_cast<std::size_t>(c)]) v = v == 0.0f ? -std::numeric_limits<float>::min() : -v;
    });
    for (const std::int64_t g : stored) {
        const std::int32_t c = comp[static_cast<std::size_t>(g)];
        if (c >= 0 && flip[static_cast<std::size_t>(c)]) ++st.flipped_samples;
    }
    return st;
}

}  // namespace pcp
