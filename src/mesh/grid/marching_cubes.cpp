// Marching cubes over the stored blocks of an SdfGrid (include/pcp/marching_cubes.hpp). Each block
// is processed independently (OpenMP): it lists the crossed lattice edges of its closed box with
// their interpolated positions, and the triangles of its cubes as triples of global edge ids, taken
// from the generated case table (src/mc_cases.*) with the ambiguous faces resolved from their own
// four values (or all joined, McAmbiguity::JoinInside, case 4 by its tube). The blocks' results are
// then merged: vertices are the distinct edge ids in increasing order, so a vertex on a block
// boundary, computed by both blocks from the same values, appears once and the mesh is
// shared-vertex and watertight across blocks. The rare polygons that need a centre vertex
// (mc_cases.hpp) get one id per cell and polygon, after all edge ids.
//
// Letters as in sdf_grid.cpp: R = resolution, B = block_cells, S = B + 1, K = stored blocks.
// Global edge id of the edge from sample g along axis a: ((g.z * (R+1) + g.y) * (R+1) + g.x) * 3 + a;
// centre vertex q of cell c: 3 (R+1)^3 + ((c.z * R + c.y) * R + c.x) * kMaxCaseCentres + q.
#include "pcp/mesh/grid/marching_cubes.hpp"

#include "mesh/grid/mc_cases.hpp"
#include "pcp/core/error.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

namespace pcp {
namespace {

struct BlockMesh {
    std::vector<std::pair<std::int64_t, Eigen::Vector3d>> vertices;  // (edge id, position)
    std::vector<std::array<std::int64_t, 3>> triangles;            // edge ids
};

// Per-configuration data looked up in the inner loop.
struct CubeTables {
    std::array<int, 256> ambiguous{};                 // mask of ambiguous faces
    std::array<bool, 256> body_pair{};                // case 4: two inside corners on a body diagonal
    std::array<std::array<int, 4>, 6> face_corners{};  // cyclic corner order of each face
    std::array<int, 12> edge_axis{};
    std::array<Eigen::Vector3i, 12> edge_start{};      // start corner offset of each edge
};

CubeTables make_cube_tables() {
    CubeTables t;
    for (int c = 0; c < 256; ++c) {
        t.ambiguous[c] = detail::mc_ambiguous_faces(c);
        t.body_pair[c] = detail::mc_body_diagonal_pair(c);
    }
    for (int f = 0; f < 6; ++f) t.face_corners[f] = detail::mc_face_corners(f);
    for (int e = 0; e < 12; ++e) {
        const int s = detail::mc_edge_corners(e)[0];
        t.edge_axis[e] = e / 4;
        t.edge_start[e] = Eigen::Vector3i(s & 1, (s >> 1) & 1, (s >> 2) & 1);
    }
    return t;
}

}  // namespace

Mesh marching_cubes(const SdfGrid& grid, const MarchingCubesOptions& options) {
    const int R = grid.spec.resolution, B = grid.block_cells, S = B + 1, nb = grid.blocks_per_axis;
    PCP_CHECK(R >= 2 && B >= 2 && nb == (R + B - 1) / B,
              "marching_cubes: the grid is not initialised (resolution " << R << ", block_cells " << B
                  << ", blocks_per_axis " << nb << "); build it with evaluate_sdf_grid");
    const std::int64_t S3 = std::int64_t(S) * S * S;
    const std::int64_t K = grid.num_blocks();
    PCP_CHECK(std::int64_t(grid.values.size()) == K * S3,
              "marching_cubes: the grid holds " << grid.values.size() << " values for " << K
                                                << " blocks; expected " << K * S3);

    const std::vector<detail::McCase>& table = detail::mc_case_table();
    static const CubeTables cube = make_cube_tables();
    const bool decider = options.ambiguity == McAmbiguity::AsymptoticDecider;
    const bool join = options.ambiguity == McAmbiguity::JoinInside;
    const std::int64_t n1 = R + 1;
    auto edge_id = [n1](const Eigen::Vector3i& g, int axis) {
        return ((std::int64_t(g.z()) * n1 + g.y()) * n1 + g.x()) * 3 + axis;
    };
    // Centre vertices (rare, see mc_cases.hpp) are numbered after every edge: one range per cell.
    const std::int64_t centre_id0 = n1 * n1 * n1 * 3;

    std::vector<BlockMesh> blocks(static_cast<std::size_t>(K));
#pragma omp parallel for schedule(dynamic, 4)
    for (std::int64_t b = 0; b < K; ++b) {
        const std::int64_t key = grid.block_keys[std::size_t(b)];
        const Eigen::Vector3i X(int(key % nb), int((key / nb) % nb), int(key / (std::int64_t(nb) * nb)));
        const Eigen::Vector3i c = (Eigen::Vector3i::Constant(B).array().min(R - X.array() * B)).matrix();
        const float* block = grid.values.data() + b * S3;
        // w(l) = value at local sample l; inside when w < 0.
        auto w = [&](int i, int j, int k) {
            return double(block[(std::int64_t(k) * S + j) * S + i]);
        };
        BlockMesh& out = blocks[std::size_t(b)];

        // Crossed edges of the block's closed box, with linearly interpolated positions.
        for (int k = 0; k <= c.z(); ++k)
            for (int j = 0; j <= c.y(); ++j)
                for (int i = 0; i <= c.x(); ++i) {
                    const Eigen::Vector3i l(i, j, k);
                    const double w0 = w(i, j, k);
                    for (int a = 0; a < 3; ++a) {
                        if (l[a] == c[a]) continue;
                        Eigen::Vector3i l1 = l;
                        ++l1[a];
                        const double w1 = w(l1.x(), l1.y(), l1.z());
                        if ((w0 < 0.0) == (w1 < 0.0)) continue;
                        const Eigen::Vector3i g0 = X * B + l, g1 = X * B + l1;
                        const Eigen::Vector3d p0 = grid.spec.sample_position(g0.x(), g0.y(), g0.z());
                        const Eigen::Vector3d p1 = grid.spec.sample_position(g1.x(), g1.y(), g1.z());
                        const double t = w0 / (w0 - w1);
                        out.vertices.emplace_back(edge_id(g0, a), p0 + t * (p1 - p0));
                    }
                }

        // Triangles of the block's cubes.
        for (int k = 0; k < c.z(); ++k)
            for (int j = 0; j < c.y(); ++j)
                for (int i = 0; i < c.x(); ++i) {
                    std::array<double, 8> wc;
                    int config = 0;
                    for (int q = 0; q < 8; ++q) {
                        wc[q] = w(i + (q & 1), j + ((q >> 1) & 1), k + ((q >> 2) & 1));
                        if (wc[q] < 0.0) config |= 1 << q;
                    }
                    if (config == 0 || config == 255) continue;
                    int face_bits = 0;
                    const int amb = cube.ambiguous[config];
                    if (join) {
                        face_bits = amb | (cube.body_pair[config] ? detail::kInteriorBit : 0);
                    } else if (decider && amb) {
                        for (int f = 0; f < 6; ++f) {
                            if (!((amb >> f) & 1)) continue;
                            const auto& p = cube.face_corners[f];
                            // Bilinear saddle: the diagonal (p0, p2) is joined iff w0 w2 > w1 w3.
                            const double d02 = wc[p[0]] * wc[p[2]], d13 = wc[p[1]] * wc[p[3]];
                            const bool joined = wc[p[0]] < 0.0 ? d02 > d13 : d13 > d02;
                            if (joined) face_bits |= 1 << f;
                        }
                    }
                    const detail::McCase& mc = table[std::size_t(config * detail::kCaseBits + face_bits)];
                    const Eigen::Vector3i cell = X * B + Eigen::Vector3i(i, j, k);
                    const std::int64_t centre_base =
                        centre_id0 + ((std::int64_t(cell.z()) * R + cell.y()) * R + cell.x()) * detail::kMaxCaseCentres;
                    for (int q = 0; q < mc.num_centres; ++q) {
                        // The centre of a polygon without a valid triangulation: mean of its crossings.
                        Eigen::Vector3d sum = Eigen::Vector3d::Zero();
                        int n = 0;
                        for (int e = 0; e < 12; ++e) {
                            if (!((mc.centre_edges[std::size_t(q)] >> e) & 1)) continue;
                            const Eigen::Vector3i g0 = cell + cube.edge_start[std::size_t(e)];
                            Eigen::Vector3i g1 = g0;
                            ++g1[cube.edge_axis[std::size_t(e)]];
                            const Eigen::Vector3d p0 = grid.spec.sample_position(g0.x(), g0.y(), g0.z());
                            const Eigen::Vector3d p1 = grid.spec.sample_position(g1.x(), g1.y(), g1.z());
                            const Eigen::Vector3i l0 = g0 - X * B, l1 = g1 - X * B;
                            const double w0 = w(l0.x(), l0.y(), l0.z()), w1 = w(l1.x(), l1.y(), l1.z());
                            sum += p0 + (w0 / (w0 - w1)) * (p1 - p0);
                            ++n;
                        }
                        out.vertices.emplace_back(centre_base + q, sum / n);
                    }
                    for (int t = 0; t < mc.num_triangles; ++t) {
                        std::array<std::int64_t, 3> tri;
                        for (int v = 0; v < 3; ++v) {
                            const int code = mc.vertices[std::size_t(3 * t + v)];
                            tri[std::size_t(v)] =
                                code >= detail::kCentreCode
                                    ? centre_base + (code - detail::kCentreCode)
                                    : edge_id(cell + cube.edge_start[std::size_t(code)], cube.edge_axis[std::size_t(code)]);
                        }
                        out.triangles.push_back(tri);
                    }
                }
    }

    // Merge: distinct edge ids in increasing order are the vertices.
    std::size_t n_vertices = 0, n_triangles = 0;
    for (const BlockMesh& bm : blocks) {
        n_vertices += bm.vertices.size();
        n_triangles += bm.triangles.size();
    }
    std::vector<std::pair<std::int64_t, Eigen::Vector3d>> all;
    all.reserve(n_vertices);
    for (BlockMesh& bm : blocks) {
        all.insert(all.end(), bm.vertices.begin(), bm.vertices.end());
        std::vector<std::pair<std::int64_t, Eigen::Vector3d>>().swap(bm.vertices);
    }
    std::sort(all.begin(), all.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
    all.erase(std::unique(all.begin(), all.end(), [](const auto& x, const auto& y) { return x.first == y.first; }),
              all.end());
    PCP_CHECK(all.size() < std::size_t(std::numeric_limits<std::int32_t>::max()) &&
                  n_triangles < std::size_t(std::numeric_limits<std::int32_t>::max()),
              "marching_cubes: the mesh has too many vertices or faces for 32-bit indices; lower the resolution");

    Mesh mesh;
    mesh.vertices.resize(Eigen::Index(all.size()), 3);
    std::vector<std::int64_t> ids(all.size());
    for (std::size_t v = 0; v < all.size(); ++v) {
        ids[v] = all[v].first;
        mesh.vertices.row(Eigen::Index(v)) = all[v].second.transpose();
    }
    std::vector<std::pair<std::int64_t, Eigen::Vector3d>>().swap(all);

    std::vector<std::size_t> first_triangle(blocks.size() + 1, 0);
    for (std::size_t b = 0; b < blocks.size(); ++b) first_triangle[b + 1] = first_triangle[b] + blocks[b].triangles.size();
    mesh.faces.resize(Eigen::Index(n_triangles), 3);
#pragma omp parallel for schedule(dynamic, 16)
    for (std::int64_t b = 0; b < K; ++b) {
        const auto& tris = blocks[std::size_t(b)].triangles;
        for (std::size_t t = 0; t < tris.size(); ++t)
            for (int v = 0; v < 3; ++v) {
                const auto it = std::lower_bound(ids.begin(), ids.end(), tris[t][std::size_t(v)]);
                mesh.faces(Eigen::Index(first_triangle[std::size_t(b)] + t), v) = std::int32_t(it - ids.begin());
            }
    }
    return mesh;
}

}  // namespace pcp
