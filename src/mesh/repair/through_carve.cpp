// Through-line carve on the dense fine grid (see include/pcp/mesh/repair/through_carve.hpp).
#include "pcp/mesh/repair/through_carve.hpp"

#include "mesh/grid/cubical.hpp"
#include "pcp/cloud/visibility.hpp"
#include "pcp/core/error.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

namespace pcp {

namespace {

/// Calls fn(index) for each inside sample among the 26 neighbours of sample g (g itself too when
/// it is inside).
template <class Fn>
void for_each_inside_neighbour(const detail::Lattice& L, const std::vector<std::uint8_t>& inside, std::int64_t g, Fn&& fn) {
    const int i = int(g % L.n1), j = int((g / L.n1) % L.n1), k = int(g / L.n1s);
    for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx)
                if (L.at(inside, i + dx, j + dy, k + dz)) fn(L.index(i + dx, j + dy, k + dz));
}

}  // namespace

ThroughCarveStats carve_through_lines(SdfGrid& grid, const KdTree& cloud, const ThroughCarveOptions& o) {
    const auto t0 = std::chrono::steady_clock::now();
    PCP_CHECK(o.voxels_per_cell >= 1 && o.voxels_per_cell <= 8, "through carve: voxels_per_cell must be in 1..8, got " << o.voxels_per_cell);
    PCP_CHECK(o.directions >= 8 && o.directions <= 4096, "through carve: directions must be in 8..4096, got " << o.directions);
    PCP_CHECK(o.min_through_lines >= 1 && o.min_through_lines <= o.directions,
              "through carve: min_through_lines must be in 1..directions, got " << o.min_through_lines);
    PCP_CHECK(std::isfinite(o.dilation) && o.dilation > 0.0, "through carve: dilation must be > 0");
    PCP_CHECK(std::isfinite(o.max_distance) && o.max_distance > 0.0, "through carve: max_distance must be > 0");
    ThroughCarveStats st;
    if (!o.enabled) return st;
    detail::Lattice L;
    std::vector<std::uint8_t> inside;
    if (!detail::dense_inside(grid, o.max_samples, L, inside)) {
        st.skipped = true;
        return st;
    }

    // 1. The occupancy grid of the dilated cloud.
    const ThroughLines lines(cloud, grid.spec.box, std::min(1024, o.voxels_per_cell * L.R), o.dilation, o.directions, std::min(4, o.voxels_per_cell));
    // Free voxels within max_distance of the data: the chessboard clearance c of a voxel puts its
    // points at least r + (c - 1) h from every input point, so c - 1 <= (max - r) / h.
    const double reach = o.max_distance * sampling_scale(cloud) - lines.radius();
    if (reach <= 0) return st;
    const int max_clearance = std::min(255, 1 + static_cast<int>(std::floor(reach / lines.voxel())));
    const auto position = [&](std::int64_t g) { return grid.spec.sample_position(g % L.n1, (g / L.n1) % L.n1, g / L.n1s); };

    // 2. The inside samples near the data on enough lines that cross no wall, tried from the
    //    outside in: first those beside an outside sample, then those beside a sample found on
    //    such lines (the deep inside of a solid is never tried).
    std::vector<std::uint8_t> through(static_cast<std::size_t>(L.total), 0), tried(static_cast<std::size_t>(L.total), 0);
    std::vector<std::int64_t> front, found;
    const auto add_neighbours = [&](std::int64_t g, std::vector<std::int64_t>& out) {
        for_each_inside_neighbour(L, inside, g, [&](std::size_t h) {
            if (tried[h]) return;
            tried[h] = 1;
            out.push_back(static_cast<std::int64_t>(h));
        });
    };
    for (std::int64_t g = 0; g < L.total; ++g) {
        if (!inside[static_cast<std::size_t>(g)]) continue;
        const int i = int(g % L.n1), j = int((g / L.n1) % L.n1), k = int(g / L.n1s);
        bool beside_outside = false;
        for (int dz = -1; dz <= 1 && !beside_outside; ++dz)
            for (int dy = -1; dy <= 1 && !beside_outside; ++dy)
                for (int dx = -1; dx <= 1 && !beside_outside; ++dx) beside_outside = !L.at(inside, i + dx, j + dy, k + dz);
        if (beside_outside) {
            tried[static_cast<std::size_t>(g)] = 1;
            front.push_back(g);
        }
    }
    while (!front.empty()) {
        const auto n = static_cast<std::int64_t>(front.size());
        std::int64_t candidates = 0;
#pragma omp parallel for schedule(dynamic, 256) reduction(+ : candidates)
        for (std::int64_t s = 0; s < n; ++s) {
            const std::int64_t g = front[static_cast<std::size_t>(s)];
            const Eigen::Vector3d p = position(g);
            const int c = lines.clearance(p);
            if (c == 0 || c > max_clearance) continue;
            ++candidates;
            if (lines.count(p, o.min_through_lines) >= o.min_through_lines)
                through[static_cast<std::size_t>(g)] = 1;
        }
        st.candidates += candidates;
        found.clear();
        for (std::int64_t g : front)
            if (through[static_cast<std::size_t>(g)]) add_neighbours(g, found);
        front.swap(found);
    }

    // 3. Their connected pieces, made outside.
    std::vector<std::uint8_t> seen(inside.size(), 0), carve(inside.size(), 0);
    std::vector<std::int64_t> piece;
    for (std::int64_t g0 = 0; g0 < L.total; ++g0) {
        if (!through[static_cast<std::size_t>(g0)] || seen[static_cast<std::size_t>(g0)]) continue;
        piece.clear();
        seen[static_cast<std::size_t>(g0)] = 1;
        detail::flood_26(L, g0, seen, [&](std::size_t h) { return through[h] != 0; }, [&](std::int64_t g) { piece.push_back(g); });
        ++st.pieces;
        ++st.opened;
        st.carved += static_cast<std::int64_t>(piece.size());
        for (std::int64_t g : piece) carve[static_cast<std::size_t>(g)] = 1;
    }
    if (st.opened > 0) detail::move_to_side(grid, carve, false);
    st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return st;
}

}  // namespace pcp
