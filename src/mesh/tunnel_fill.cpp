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

namespace {

/// The lattice of one grid, as the two rules below see it: `set` is the side whose passages are
/// closed (the inside for the tunnel fill, the outside for the bridge cut).
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

/// The samples outside `set` that its closing by the 3 x 3 x 3 cube adds (dilation, then erosion;
/// outside the lattice counts as outside `set`), in connected pieces (26-neighbours), each with the
/// change of the Euler characteristic of the union of the closed cells of `set` when the piece
/// joins it: chi(A) - chi(A meets set), counted on the cells of the cubical complex.
struct Piece {
    std::vector<std::int64_t> members;
    int chi_change = 0;
};

/// Cell c of the cubical complex in doubled coordinates (see closing_pieces): (-1)^dim (its
/// dimension is its number of even coordinates), and in `*in` whether a sample of `set` has a
/// closed cube holding it (the samples (i, j, k) with |2i - c_x| <= 1, per axis).
int cell_sign(const Lattice& L, const std::vector<std::uint8_t>& set, const int c[3], bool* in) {
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

std::vector<Piece> closing_pieces(const Lattice& L, const std::vector<std::uint8_t>& set) {
    const int R = L.R, n1 = L.n1;
    const std::int64_t total = L.total, n1s = L.n1s;
    std::vector<std::uint8_t> dilated(static_cast<std::size_t>(total), 0), added(static_cast<std::size_t>(total), 0);
#pragma omp parallel for schedule(static)
    for (int k = 0; k <= R; ++k)
        for (int j = 0; j <= R; ++j)
            for (int i = 0; i <= R; ++i) {
                bool any = false;
                for (int dz = -1; dz <= 1 && !any; ++dz)
                    for (int dy = -1; dy <= 1 && !any; ++dy)
                        for (int dx = -1; dx <= 1 && !any; ++dx) any = L.at(set, i + dx, j + dy, k + dz);
                dilated[L.index(i, j, k)] = any;
            }
#pragma omp parallel for schedule(static)
    for (int k = 0; k <= R; ++k)
        for (int j = 0; j <= R; ++j)
            for (int i = 0; i <= R; ++i) {
                const std::size_t g = L.index(i, j, k);
                if (set[g] || !dilated[g]) continue;
                bool all = true;
                for (int dz = -1; dz <= 1 && all; ++dz)
                    for (int dy = -1; dy <= 1 && all; ++dy)
                        for (int dx = -1; dx <= 1 && all; ++dx) all = L.at(dilated, i + dx, j + dy, k + dz);
                added[g] = all;
            }
    // Cells of the cubical complex in doubled coordinates: sample (i, j, k) is the closed cube
    // around (2i, 2j, 2k), its cells are (2i + a, 2j + b, 2k + c) with a, b, c in {-1, 0, 1}; a
    // cell's dimension is its number of even coordinates.
    const std::int64_t M = 2 * std::int64_t(R) + 3;  // doubled coordinates -1 .. 2R + 1, stored + 1
    std::vector<std::uint8_t> seen(static_cast<std::size_t>(total), 0);
    std::unordered_set<std::int64_t> cells;
    std::vector<Piece> pieces;
    for (std::int64_t g0 = 0; g0 < total; ++g0) {
        if (!added[static_cast<std::size_t>(g0)] || seen[static_cast<std::size_t>(g0)]) continue;
        Piece piece;
        seen[static_cast<std::size_t>(g0)] = 1;
        flood_26(L, g0, seen, [&](std::size_t h) { return added[h] != 0; }, [&](std::int64_t g) { piece.members.push_back(g); });
        cells.clear();
        for (std::int64_t g : piece.members) {
            const std::int64_t i = g % n1, j = (g / n1) % n1, k = g / n1s;
            for (int dz = -1; dz <= 1; ++dz)
                for (int dy = -1; dy <= 1; ++dy)
                    for (int dx = -1; dx <= 1; ++dx)
                        cells.insert(((2 * k + dz + 1) * M + (2 * j + dy + 1)) * M + (2 * i + dx + 1));
        }
        int chi_a = 0, chi_contact = 0;
        for (std::int64_t key : cells) {
            const int c[3] = {int(key % M) - 1, int((key / M) % M) - 1, int(key / (M * M)) - 1};
            bool touches = false;
            const int sign = cell_sign(L, set, c, &touches);
            chi_a += sign;
            if (touches) chi_contact += sign;
        }
        piece.chi_change = chi_a - chi_contact;
        pieces.push_back(std::move(piece));
    }
    return pieces;
}

/// The dense lattice of `grid` and which samples are inside (F < 0); false when the grid is not
/// dense or is larger than max_samples.
bool dense_inside(const SdfGrid& grid, std::int64_t max_samples, Lattice& L, std::vector<std::uint8_t>& inside) {
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
        PCP_CHECK(!std::isnan(v), "tunnel fill: the dense grid misses a sample");
        inside[static_cast<std::size_t>(g)] = v < 0.0f;
    }
    return true;
}

/// Whether the inside samples next to `piece` stay connected (26-neighbours) through the inside
/// without it: a flood fill from one of them that must reach all the others.
bool inside_stays_connected(const Lattice& L, const std::vector<std::uint8_t>& inside, const std::vector<std::int64_t>& piece) {
    std::vector<std::uint8_t> blocked(static_cast<std::size_t>(L.total), 0);
    for (std::int64_t g : piece) blocked[static_cast<std::size_t>(g)] = 1;
    std::vector<std::int64_t> rim;
    for (std::int64_t g : piece) {
        const int i = int(g % L.n1), j = int((g / L.n1) % L.n1), k = int(g / L.n1s);
        for (int dz = -1; dz <= 1; ++dz)
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx)
                    if (L.at(inside, i + dx, j + dy, k + dz) && !blocked[L.index(i + dx, j + dy, k + dz)])
                        rim.push_back(static_cast<std::int64_t>(L.index(i + dx, j + dy, k + dz)));
    }
    if (rim.empty()) return true;
    std::vector<std::uint8_t> reached(static_cast<std::size_t>(L.total), 0);
    reached[static_cast<std::size_t>(rim.front())] = 1;
    flood_26(L, rim.front(), reached, [&](std::size_t h) { return inside[h] && !blocked[h]; }, [](std::int64_t) {});
    for (std::int64_t g : rim)
        if (!reached[static_cast<std::size_t>(g)]) return false;
    return true;
}

/// Every stored copy of the samples in `mask` made inside (negative) or outside (positive), |F|
/// kept (a tiny value where F was 0).
void move_to_side(SdfGrid& grid, const std::vector<std::uint8_t>& mask, bool inside) {
    const float tiny = static_cast<float>(1e-6 * grid.spec.spacing().minCoeff());
    detail::for_each_stored_sample(grid, [&](float& v, std::int64_t g) {
        if (mask[static_cast<std::size_t>(g)]) v = inside ? -std::max(std::abs(v), tiny) : std::max(std::abs(v), tiny);
    });
}

}  // namespace

TunnelFillStats fill_tunnels(SdfGrid& grid, const TunnelFillOptions& options) {
    TunnelFillStats st;
    if (!options.enabled) return st;
    Lattice L;
    std::vector<std::uint8_t> inside;
    if (!dense_inside(grid, options.max_samples, L, inside)) {
        st.skipped = true;
        return st;
    }
    // 1-2. The pieces the closing of the inside adds, scored.
    std::vector<std::uint8_t> plug(static_cast<std::size_t>(L.total), 0);
    for (const Piece& piece : closing_pieces(L, inside)) {
        ++st.candidates;
        if (piece.chi_change <= 0) continue;
        // 3. A plug: inside from now on.
        ++st.plugged;
        st.plugged_samples += static_cast<std::int64_t>(piece.members.size());
        for (std::int64_t g : piece.members) plug[static_cast<std::size_t>(g)] = 1;
    }
    if (st.plugged > 0) move_to_side(grid, plug, true);
    return st;
}

int solid_euler_characteristic(const SdfGrid& grid) {
    Lattice L;
    std::vector<std::uint8_t> inside;
    PCP_CHECK(dense_inside(grid, std::numeric_limits<std::int64_t>::max(), L, inside),
              "solid_euler_characteristic: the grid is not dense");
    // Cells in doubled coordinates as in closing_pieces: cell (x, y, z), -1 <= x, y, z <= 2R + 1,
    // belongs to the samples (i, j, k) with |2i - x| <= 1 (per axis); it is in the solid when one
    // of them is inside. Dimension: the number of even coordinates.
    const int hi = 2 * L.R + 1;
    std::int64_t chi = 0;
#pragma omp parallel for reduction(+ : chi) schedule(static)
    for (int z = -1; z <= hi; ++z)
        for (int y = -1; y <= hi; ++y)
            for (int x = -1; x <= hi; ++x) {
                const int c[3] = {x, y, z};
                bool in = false;
                const int sign = cell_sign(L, inside, c, &in);
                if (in) chi += sign;
            }
    return static_cast<int>(chi);
}

BridgeCutStats cut_bridges(SdfGrid& grid, const TunnelFillOptions& options) {
    BridgeCutStats st;
    if (!options.enabled || !options.cut_bridges) return st;
    Lattice L;
    std::vector<std::uint8_t> inside;
    if (!dense_inside(grid, options.max_samples, L, inside)) {
        st.skipped = true;
        return st;
    }
    std::vector<std::uint8_t> outside(inside.size());
    for (std::size_t g = 0; g < inside.size(); ++g) outside[g] = !inside[g];
    std::vector<std::uint8_t> cut(static_cast<std::size_t>(L.total), 0);
    for (const Piece& piece : closing_pieces(L, outside)) {
        ++st.candidates;
        // A bridge: the outside's Euler characteristic rises when the piece joins it, and the
        // solid around it stays in one piece (a thin neck between two parts of the solid scores
        // the same and is kept).
        if (piece.chi_change <= 0 || !inside_stays_connected(L, inside, piece.members)) continue;
        ++st.cut;
        st.cut_samples += static_cast<std::int64_t>(piece.members.size());
        for (std::int64_t g : piece.members) cut[static_cast<std::size_t>(g)] = 1;
    }
    if (st.cut > 0) move_to_side(grid, cut, false);
    return st;
}

}  // namespace pcp
