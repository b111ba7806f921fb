// Tunnel fill on the dense fine grid (see include/pcp/mesh/repair/tunnel_fill.hpp).
#include "pcp/mesh/repair/tunnel_fill.hpp"

#include "mesh/grid/cubical.hpp"
#include "pcp/core/error.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_set>
#include <vector>

namespace pcp {

namespace {

using detail::cell_sign;
using detail::dense_inside;
using detail::euler_change_joining;
using detail::flood_26;
using detail::Lattice;
using detail::move_to_side;

/// The samples outside `set` that its closing by the 3 x 3 x 3 cube adds (dilation, then erosion;
/// outside the lattice counts as outside `set`), in connected pieces (26-neighbours), each with the
/// change of the Euler characteristic of the union of the closed cells of `set` when the piece
/// joins it: chi(A) - chi(A meets set), counted on the cells of the cubical complex.
struct Piece {
    std::vector<std::int64_t> members;
    int chi_change = 0;
};

std::vector<Piece> closing_pieces(const Lattice& L, const std::vector<std::uint8_t>& set) {
    const int R = L.R;
    const std::int64_t total = L.total;
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
    std::vector<std::uint8_t> seen(static_cast<std::size_t>(total), 0);
    std::unordered_set<std::int64_t> cells;
    std::vector<Piece> pieces;
    for (std::int64_t g0 = 0; g0 < total; ++g0) {
        if (!added[static_cast<std::size_t>(g0)] || seen[static_cast<std::size_t>(g0)]) continue;
        Piece piece;
        seen[static_cast<std::size_t>(g0)] = 1;
        flood_26(L, g0, seen, [&](std::size_t h) { return added[h] != 0; }, [&](std::int64_t g) { piece.members.push_back(g); });
        piece.chi_change = euler_change_joining(L, set, piece.members, cells);
        pieces.push_back(std::move(piece));
    }
    return pieces;
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

}  // namespace pcp
