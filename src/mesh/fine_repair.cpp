// Fine sign repair on the stored samples of the fine grid (see include/pcp/mesh/fine_repair.hpp).
#include "pcp/mesh/fine_repair.hpp"

#include "pcp/core/error.hpp"
#include "mesh/grid_samples.hpp"

#include <Eigen/Core>

#include <cmath>
#include <limits>
#include <vector>

namespace pcp {

namespace {


}  // namespace

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

    // Near the data: distance from each stored lattice point to the cloud.
    std::vector<std::int8_t> near(static_cast<std::size_t>(total), 0);
    {
        PointsF pos(static_cast<Eigen::Index>(stored.size()), 3);
        for (std::size_t s = 0; s < stored.size(); ++s) {
            const std::int64_t g = stored[s];
            pos.row(static_cast<Eigen::Index>(s)) = grid.spec.sample_position(g % n1, (g / n1) % n1, g / (std::int64_t(n1) * n1)).cast<float>().transpose();
        }
        Eigen::VectorXf d;
        cloud.nearest(pos, &d);
        for (std::size_t s = 0; s < stored.size(); ++s)
            near[static_cast<std::size_t>(stored[s])] = d(static_cast<Eigen::Index>(s)) <= st.tau ? 1 : 0;
    }

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
