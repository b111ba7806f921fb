// Cavity fill on the dense fine grid (see include/pcp/mesh/cavity_fill.hpp).
#include "pcp/mesh/cavity_fill.hpp"

#include "pcp/core/error.hpp"

#include <cmath>
#include <vector>

namespace pcp {

namespace {

/// Calls fn(value&, lattice index) for every stored, non-NaN sample of every block (a sample shared
/// by several blocks once per block that stores it).
template <class Fn>
void for_each_sample(SdfGrid& grid, Fn&& fn) {
    const int R = grid.spec.resolution, n1 = R + 1, B = grid.block_cells, S = B + 1, nb = grid.blocks_per_axis;
    const std::int64_t per_block = std::int64_t(S) * S * S;
    for (int b = 0; b < grid.num_blocks(); ++b) {
        const std::int64_t key = grid.block_keys[static_cast<std::size_t>(b)];
        const int bx = int(key % nb), by = int((key / nb) % nb), bz = int(key / (std::int64_t(nb) * nb));
        for (int z = 0; z < S; ++z)
            for (int y = 0; y < S; ++y)
                for (int x = 0; x < S; ++x) {
                    const std::int64_t i = std::int64_t(bx) * B + x, j = std::int64_t(by) * B + y, k = std::int64_t(bz) * B + z;
                    if (i > R || j > R || k > R) continue;
                    float& v = grid.values[static_cast<std::size_t>(b * per_block + (std::int64_t(z) * S + y) * S + x)];
                    if (std::isnan(v)) continue;
                    fn(v, (k * n1 + j) * n1 + i);
                }
    }
}

enum Label : std::uint8_t { kNone = 0, kOutside = 1, kCavity = 2 };

}  // namespace

CavityFillStats fill_cavities(SdfGrid& grid, const CavityFillOptions& options) {
    PCP_CHECK(options.core_cells > 0 && std::isfinite(options.core_cells), "cavity fill: core_cells must be > 0");
    PCP_CHECK(options.max_open >= 0 && options.max_open <= 1, "cavity fill: max_open must be in [0, 1]");
    CavityFillStats st;
    if (!options.enabled) return st;
    const int R = grid.spec.resolution, n1 = R + 1;
    const std::int64_t total = std::int64_t(n1) * n1 * n1;
    const std::int64_t dense_blocks = std::int64_t(grid.blocks_per_axis) * grid.blocks_per_axis * grid.blocks_per_axis;
    if (total > options.max_samples || grid.num_blocks() != dense_blocks) {
        st.skipped = true;
        return st;
    }
    st.delta = options.core_cells * grid.spec.spacing().maxCoeff();
    const float delta = static_cast<float>(st.delta);
    std::vector<float> value(static_cast<std::size_t>(total), std::numeric_limits<float>::quiet_NaN());
    for_each_sample(grid, [&](const float& v, std::int64_t g) { value[static_cast<std::size_t>(g)] = v; });
    for (float v : value) PCP_CHECK(!std::isnan(v), "cavity fill: the dense grid misses a sample");

    std::vector<std::uint8_t> label(static_cast<std::size_t>(total), kNone);
    std::vector<std::int64_t> front, next;
    auto neighbours = [n1](std::int64_t g, std::int64_t out[6]) {
        const std::int64_t i = g % n1, j = (g / n1) % n1, k = g / (std::int64_t(n1) * n1);
        int n = 0;
        if (i > 0) out[n++] = g - 1;
        if (i + 1 < n1) out[n++] = g + 1;
        if (j > 0) out[n++] = g - n1;
        if (j + 1 < n1) out[n++] = g + n1;
        if (k > 0) out[n++] = g - std::int64_t(n1) * n1;
        if (k + 1 < n1) out[n++] = g + std::int64_t(n1) * n1;
        return n;
    };
    // 1. The outside: from the box's faces through samples with F > delta.
    for (std::int64_t g = 0; g < total; ++g) {
        const std::int64_t i = g % n1, j = (g / n1) % n1, k = g / (std::int64_t(n1) * n1);
        const bool face = i == 0 || j == 0 || k == 0 || i == R || j == R || k == R;
        if (face && value[static_cast<std::size_t>(g)] > delta) {
            label[static_cast<std::size_t>(g)] = kOutside;
            front.push_back(g);
        }
    }
    std::int64_t nb[6];
    while (!front.empty()) {
        next.clear();
        for (std::int64_t g : front) {
            const int n = neighbours(g, nb);
            for (int a = 0; a < n; ++a) {
                const auto h = static_cast<std::size_t>(nb[a]);
                if (label[h] == kNone && value[h] > delta) {
                    label[h] = kOutside;
                    next.push_back(nb[a]);
                }
            }
        }
        front.swap(next);
    }
    // 2. Cavity cores; 3. both grow one layer at a time through the remaining positive samples.
    front.clear();
    for (std::int64_t g = 0; g < total; ++g) {
        if (value[static_cast<std::size_t>(g)] > delta && label[static_cast<std::size_t>(g)] == kNone) label[static_cast<std::size_t>(g)] = kCavity;
        if (label[static_cast<std::size_t>(g)] != kNone) front.push_back(g);
    }
    while (!front.empty()) {
        next.clear();
        for (std::int64_t g : front) {
            const int n = neighbours(g, nb);
            for (int a = 0; a < n; ++a) {
                const auto h = static_cast<std::size_t>(nb[a]);
                if (label[h] == kNone && value[h] > 0.0f) {
                    label[h] = label[static_cast<std::size_t>(g)];
                    next.push_back(nb[a]);
                }
            }
        }
        front.swap(next);
    }
    // 4. Pockets: 6-connected components of the positive samples not labelled outside. A pocket is
    //    filled when little of its boundary is open to the outside (pairs with outside samples, at
    //    most max_open of its boundary pairs; the rest are pairs with negative samples): a cavity
    //    behind pinholes is, a bay of the outside that the core threshold cut off is not (filling
    //    it would put a sheet where the two fronts met, away from the data).
    std::vector<std::uint8_t> flip(static_cast<std::size_t>(total), 0);
    {
        std::vector<std::uint8_t> seen(static_cast<std::size_t>(total), 0);
        std::vector<std::int64_t> stack, members;
        for (std::int64_t g = 0; g < total; ++g) {
            const auto s0 = static_cast<std::size_t>(g);
            if (value[s0] <= 0.0f || label[s0] == kOutside || seen[s0]) continue;
            members.clear();
            stack.assign(1, g);
            seen[s0] = 1;
            std::int64_t open = 0, closed = 0;
            while (!stack.empty()) {
                const std::int64_t c = stack.back();
                stack.pop_back();
                members.push_back(c);
                const int n = neighbours(c, nb);
                for (int a = 0; a < n; ++a) {
                    const auto h = static_cast<std::size_t>(nb[a]);
                    if (value[h] <= 0.0f) {
                        ++closed;
                    } else if (label[h] == kOutside) {
                        ++open;
                    } else if (!seen[h]) {
                        seen[h] = 1;
                        stack.push_back(nb[a]);
                    }
                }
            }
            ++st.pockets;
            if (double(open) > options.max_open * double(open + closed)) continue;
            ++st.cavities;
            st.cavity_samples += static_cast<std::int64_t>(members.size());
            for (std::int64_t c : members) flip[static_cast<std::size_t>(c)] = 1;
        }
    }
    if (st.cavity_samples == 0) return st;
    for_each_sample(grid, [&](float& v, std::int64_t g) {
        if (flip[static_cast<std::size_t>(g)]) v = -v;
    });
    return st;
}

}  // namespace pcp
