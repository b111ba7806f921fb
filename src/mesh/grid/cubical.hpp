// Private helper of the mesh stages that reason on the topology of the dense fine grid's solid
// (tunnel_fill.cpp, through_carve.cpp): the lattice, 26-connected flood fills, and the Euler
// characteristic of the union of closed cubes around a set of samples (the cubical complex).
#pragma once

#include "mesh/grid/grid_samples.hpp"
#include "pcp/core/error.hpp"
#include "pcp/mesh/grid/sdf_grid.hpp"

#include <cmath>
#include <cstdint>
#include <unordered_set>
#include <vector>

namespace pcp::detail {

/// The dense lattice of one grid: sample (i, j, k) at index (k * n1 + j) * n1 + i, n1 = R + 1. A
/// `set` is a mask over it (the inside, the outside, or the side whose passages a rule closes).
struct Lattice {
    int R = 0, n1 = 0;
    std::int64_t n1s = 0, total = 0;
    std::size_t index(int i, int j, int k) const { return static_cast<std::size_t>((std::int64_t(k) * n1 + j) * n1 + i); }
    bool at(const std::vector<std::uint8_t>& set, int i, int j, int k) const {
        if (i < 0 || j < 0 || k < 0 || i > R || j > R || k > R) return false;
        return set[index(i, j, k)] != 0;
    }
};

/// Flood fill over 26-neighbours from `start` (marked in `seen` by the caller) through the samples
/// for which passable(index) holds and `seen` is clear: each reached sample is marked in `seen`
/// and passed to visit(index), `start` included.
template <class Passable, class Visit>
void flood_26(const Lattice& L, std::int64_t start, std::vector<std::uint8_t>& seen, Passable&& passable, Visit&& visit) {
    std::vector<std::int64_t> stack(1, start);
    while (!stack.empty()) {
        const std::int64_t g = stack.back();
        stack.pop_back();
        visit(g);
        const int i = int(g % L.n1), j = int((g / L.n1) % L.n1), k = int(g / L.n1s);
        for (int dz = -1; dz <= 1; ++dz)
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) {
                    const int a = i + dx, b = j + dy, c = k + dz;
                    if (a < 0 || b < 0 || c < 0 || a > L.R || b > L.R || c > L.R) continue;
                    const std::size_t h = L.index(a, b, c);
                    if (seen[h] || !passable(h)) continue;
                    seen[h] = 1;
                    stack.push_back(static_cast<std::int64_t>(h));
                }
    }
}

/// Cell c of the cubical complex in doubled coordinates (see euler_change_joining): (-1)^dim (its
/// dimension is its number of even coordinates), and in `*in` whether a sample of `set` has a
/// closed cube holding it (the samples (i, j, k) with |2i - c_x| <= 1, per axis).
inline int cell_sign(const Lattice& L, const std::vector<std::uint8_t>& set, const int c[3], bool* in) {
    int dim = 0;
    int lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
        if (c[a] % 2 == 0) {
            ++dim;
            lo[a] = hi[a] = c[a] / 2;
        } else {
            lo[a] = (c[a] - 1) / 2;
            hi[a] = (c[a] + 1) / 2;
        }
    }
    *in = false;
    for (int k = lo[2]; k <= hi[2] && !*in; ++k)
        for (int j = lo[1]; j <= hi[1] && !*in; ++j)
            for (int i = lo[0]; i <= hi[0] && !*in; ++i) *in = L.at(set, i, j, k);
    return dim % 2 == 0 ? 1 : -1;
}

/// The change of the Euler characteristic of the union of the closed cells of `set` when the
/// samples `members` (outside `set`) join it: chi(A) - chi(A meets set), counted on the cells of
/// the cubical complex (A: the closed cubes of the members). `contact` (optional): whether A
/// meets the set at all. `cells` is scratch space.
inline int euler_change_joining(const Lattice& L, const std::vector<std::uint8_t>& set, const std::vector<std::int64_t>& members,
                                std::unordered_set<std::int64_t>& cells, bool* contact = nullptr) {
    // Cells of the cubical complex in doubled coordinates: sample (i, j, k) is the closed cube
    // around (2i, 2j, 2k), its cells are (2i + a, 2j + b, 2k + c) with a, b, c in {-1, 0, 1}; a
    // cell's dimension is its number of even coordinates.
    const std::int64_t M = 2 * std::int64_t(L.R) + 3;  // doubled coordinates -1 .. 2R + 1, stored + 1
    cells.clear();
    for (std::int64_t g : members) {
        const std::int64_t i = g % L.n1, j = (g / L.n1) % L.n1, k = g / L.n1s;
        for (int dz = -1; dz <= 1; ++dz)
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx)
                    cells.insert(((2 * k + dz + 1) * M + (2 * j + dy + 1)) * M + (2 * i + dx + 1));
    }
    int chi_a = 0, chi_contact = 0;
    bool any = false;
    for (std::int64_t key : cells) {
        const int c[3] = {int(key % M) - 1, int((key / M) % M) - 1, int(key / (M * M)) - 1};
        bool touches = false;
        const int sign = cell_sign(L, set, c, &touches);
        chi_a += sign;
        if (touches) {
            chi_contact += sign;
            any = true;
        }
    }
    if (contact) *contact = any;
    return chi_a - chi_contact;
}

/// The dense lattice of `grid` and which samples are inside (F < 0); false when the grid is not
/// dense or is larger than max_samples.
inline bool dense_inside(const SdfGrid& grid, std::int64_t max_samples, Lattice& L, std::vector<std::uint8_t>& inside) {
    L.R = grid.spec.resolution;
    L.n1 = L.R + 1;
    L.n1s = std::int64_t(L.n1) * L.n1;
    L.total = L.n1s * L.n1;
    const std::int64_t dense_blocks = std::int64_t(grid.blocks_per_axis) * grid.blocks_per_axis * grid.blocks_per_axis;
    if (L.total > max_samples || grid.num_blocks() != dense_blocks) return false;
    const std::vector<float> value = detail::lattice_values(grid);
    inside.assign(static_cast<std::size_t>(L.total), 0);
    for (std::int64_t g = 0; g < L.total; ++g) {
        const float v = value[static_cast<std::size_t>(g)];
        PCP_CHECK(!std::isnan(v), "the dense grid misses a sample");
        inside[static_cast<std::size_t>(g)] = v < 0.0f;
    }
    return true;
}

/// Every stored copy of the samples in `mask` made inside (negative) or outside (positive), |F|
/// kept (a tiny value where F was 0).
inline void move_to_side(SdfGrid& grid, const std::vector<std::uint8_t>& mask, bool inside) {
    const float tiny = static_cast<float>(1e-6 * grid.spec.spacing().minCoeff());
    detail::for_each_stored_sample(grid, [&](float& v, std::int64_t g) {
        if (mask[static_cast<std::size_t>(g)]) v = inside ? -std::max(std::abs(v), tiny) : std::max(std::abs(v), tiny);
    });
}

}  // namespace pcp::detail
