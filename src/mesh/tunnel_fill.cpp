// Tunnel fill on the dense fine grid (see include/pcp/mesh/tunnel_fill.hpp).
#include "pcp/mesh/tunnel_fill.hpp"

#include "mesh/grid_samples.hpp"
#include "pcp/core/error.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_set>
#include <vector>

namespace pcp {

TunnelFillStats fill_tunnels(SdfGrid& grid, const TunnelFillOptions& options) {
    TunnelFillStats st;
    if (!options.enabled) return st;
    const int R = grid.spec.resolution, n1 = R + 1;
    const std::int64_t n1s = std::int64_t(n1) * n1, total = n1s * n1;
    const std::int64_t dense_blocks = std::int64_t(grid.blocks_per_axis) * grid.blocks_per_axis * grid.blocks_per_axis;
    if (total > options.max_samples || grid.num_blocks() != dense_blocks) {
        st.skipped = true;
        return st;
    }
    const std::vector<float> value = detail::lattice_values(grid);
    std::vector<std::uint8_t> inside(static_cast<std::size_t>(total), 0);
    for (std::int64_t g = 0; g < total; ++g) {
        const float v = value[static_cast<std::size_t>(g)];
        PCP_CHECK(!std::isnan(v), "tunnel fill: the dense grid misses a sample");
        inside[static_cast<std::size_t>(g)] = v < 0.0f;
    }
    const auto at = [&](const std::vector<std::uint8_t>& set, int i, int j, int k) {
        if (i < 0 || j < 0 || k < 0 || i > R || j > R || k > R) return false;
        return set[static_cast<std::size_t>((std::int64_t(k) * n1 + j) * n1 + i)] != 0;
    };
    // 1. Closing by the 3 x 3 x 3 cube: dilation, then erosion (outside the lattice is outside).
    std::vector<std::uint8_t> dilated(static_cast<std::size_t>(total), 0), added(static_cast<std::size_t>(total), 0);
#pragma omp parallel for schedule(static)
    for (int k = 0; k <= R; ++k)
        for (int j = 0; j <= R; ++j)
            for (int i = 0; i <= R; ++i) {
                bool any = false;
                for (int dz = -1; dz <= 1 && !any; ++dz)
                    for (int dy = -1; dy <= 1 && !any; ++dy)
                        for (int dx = -1; dx <= 1 && !any; ++dx) any = at(inside, i + dx, j + dy, k + dz);
                dilated[static_cast<std::size_t>((std::int64_t(k) * n1 + j) * n1 + i)] = any;
            }
#pragma omp parallel for schedule(static)
    for (int k = 0; k <= R; ++k)
        for (int j = 0; j <= R; ++j)
            for (int i = 0; i <= R; ++i) {
                const auto g = static_cast<std::size_t>((std::int64_t(k) * n1 + j) * n1 + i);
                if (inside[g] || !dilated[g]) continue;
                bool all = true;
                for (int dz = -1; dz <= 1 && all; ++dz)
                    for (int dy = -1; dy <= 1 && all; ++dy)
                        for (int dx = -1; dx <= 1 && all; ++dx) all = at(dilated, i + dx, j + dy, k + dz);
                added[g] = all;
            }
    // 2. Components of the added samples (26-neighbours), each scored by the change of the solid's
    //    Euler characteristic. Cells of the cubical complex in doubled coordinates: sample (i, j, k)
    //    is the closed cube around (2i, 2j, 2k), its cells are (2i + a, 2j + b, 2k + c) with a, b,
    //    c in {-1, 0, 1}; a cell's dimension is its number of even coordinates.
    const std::int64_t M = 2 * std::int64_t(R) + 3;  // doubled coordinates -1 .. 2R + 1, stored + 1
    std::vector<std::uint8_t> plug(static_cast<std::size_t>(total), 0), seen(static_cast<std::size_t>(total), 0);
    std::vector<std::int64_t> stack, members;
    std::unordered_set<std::int64_t> cells;
    for (std::int64_t g0 = 0; g0 < total; ++g0) {
        if (!added[static_cast<std::size_t>(g0)] || seen[static_cast<std::size_t>(g0)]) continue;
        members.clear();
        stack.assign(1, g0);
        seen[static_cast<std::size_t>(g0)] = 1;
        while (!stack.empty()) {
            const std::int64_t g = stack.back();
            stack.pop_back();
            members.push_back(g);
            const int i = int(g % n1), j = int((g / n1) % n1), k = int(g / n1s);
            for (int dz = -1; dz <= 1; ++dz)
                for (int dy = -1; dy <= 1; ++dy)
                    for (int dx = -1; dx <= 1; ++dx) {
                        const int a = i + dx, b = j + dy, c = k + dz;
                        if (!at(added, a, b, c)) continue;
                        const auto h = static_cast<std::size_t>((std::int64_t(c) * n1 + b) * n1 + a);
                        if (!seen[h]) {
                            seen[h] = 1;
                            stack.push_back(static_cast<std::int64_t>(h));
                        }
                    }
        }
        ++st.candidates;
        cells.clear();
        for (std::int64_t g : members) {
            const std::int64_t i = g % n1, j = (g / n1) % n1, k = g / n1s;
            for (int dz = -1; dz <= 1; ++dz)
                for (int dy = -1; dy <= 1; ++dy)
                    for (int dx = -1; dx <= 1; ++dx)
                        cells.insert(((2 * k + dz + 1) * M + (2 * j + dy + 1)) * M + (2 * i + dx + 1));
        }
        int chi_a = 0, chi_contact = 0;
        for (std::int64_t key : cells) {
            const int c[3] = {int(key % M) - 1, int((key / M) % M) - 1, int(key / (M * M)) - 1};
            int dim = 0;
            int lo[3], hi[3];  // the samples whose closed cube holds the cell, per axis
            for (int a = 0; a < 3; ++a) {
                if (c[a] % 2 == 0) {
                    ++dim;
                    lo[a] = hi[a] = c[a] / 2;
                } else {
                    lo[a] = (c[a] - 1) / 2;
                    hi[a] = (c[a] + 1) / 2;
                }
            }
            const int sign = dim % 2 == 0 ? 1 : -1;
            chi_a += sign;
            bool touches = false;
            for (int z = lo[2]; z <= hi[2] && !touches; ++z)
                for (int y = lo[1]; y <= hi[1] && !touches; ++y)
                    for (int x = lo[0]; x <= hi[0] && !touches; ++x) touches = at(inside, x, y, z);
            if (touches) chi_contact += sign;
        }
        if (chi_a - chi_contact <= 0) continue;
        // 3. A plug: inside from now on.
        ++st.plugged;
        st.plugged_samples += static_cast<std::int64_t>(members.size());
        for (std::int64_t g : members) plug[static_cast<std::size_t>(g)] = 1;
    }
    if (st.plugged == 0) return st;
    const float tiny = static_cast<float>(1e-6 * grid.spec.spacing().minCoeff());
    detail::for_each_stored_sample(grid, [&](float& v, std::int64_t g) {
        if (plug[static_cast<std::size_t>(g)]) v = -std::max(v, tiny);
    });
    return st;
}

}  // namespace pcp
