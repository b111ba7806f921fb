// Tests for pcp/marching_cubes.hpp and the generated case table (src/mc_cases.hpp): every
// configuration gives closed, consistently oriented polygons through exactly its sign-changing
// edges, neighbouring cubes agree on every face, and meshes of analytic SDFs (sphere, torus, box)
// and of random fields are closed, manifold, outward-facing and close to the true surface.
#include "mesh/grid/mc_cases.hpp"
#include "mc_test_util.hpp"
#include "pcp/core/error.hpp"
#include "pcp/mesh/grid/marching_cubes.hpp"
#include "pcp/mesh/repair/tunnel_fill.hpp"

#include <catch2/catch.hpp>

#include <map>
#include <random>
#include <set>

using namespace pcp_test;
namespace d = pcp::detail;

namespace {

Eigen::Vector3d corner(int c) { return Eigen::Vector3d(c & 1, (c >> 1) & 1, (c >> 2) & 1); }
Eigen::Vector3d midpoint(int e) {
    const auto c = d::mc_edge_corners(e);
    return 0.5 * (corner(c[0]) + corner(c[1]));
}
bool on_face(int e, int f) {
    const auto fs = d::mc_edge_faces(e);
    return fs[0] == f || fs[1] == f;
}
// All face-bit masks that matter for `config` (subsets of its ambiguous faces).
std::vector<int> face_bit_variants(int config) {
    const int amb = d::mc_ambiguous_faces(config);
    std::vector<int> out;
    for (int bits = 0; bits < 64; ++bits)
        if ((bits & ~amb) == 0) out.push_back(bits);
    return out;
}
// A dense grid (blocks of 4 cells, truncated at the edges unless R is a multiple of 4) holding
// `table`'s values, sample (i, j, k) at (i, j, k): table[(k (R + 1) + j) (R + 1) + i].
pcp::SdfGrid grid_of_table(const std::vector<float>& table, int R) {
    pcp::GridSpec spec;
    spec.resolution = R;
    spec.box.min = Eigen::Vector3d::Zero();
    spec.box.max = Eigen::Vector3d::Constant(R);
    const pcp::SdfBatchFn field = [&](const Eigen::Ref<const pcp::PointsF>& p, Eigen::Ref<Eigen::VectorXf> v) {
        for (Eigen::Index n = 0; n < p.rows(); ++n) {
            const int i = int(std::lround(p(n, 0))), j = int(std::lround(p(n, 1))), k = int(std::lround(p(n, 2)));
            v[n] = table[std::size_t((k * (R + 1) + j) * (R + 1) + i)];
        }
    };
    pcp::SdfGridOptions opts;
    opts.band = pcp::NarrowBand::Dense;
    opts.block_cells = 4;
    return pcp::evaluate_sdf_grid(field, spec, opts);
}
// The same, with the interior bit where it matters (case 4).
std::vector<int> case_bit_variants(int config) {
    std::vector<int> out = face_bit_variants(config);
    if (d::mc_body_diagonal_pair(config)) out.push_back(d::kInteriorBit);
    return out;
}

}  // namespace

TEST_CASE("marching cubes: cube numbering is consistent", "[mc]") {
    for (int e = 0; e < 12; ++e) {
        const auto c = d::mc_edge_corners(e);
        CHECK((c[0] ^ c[1]) == (1 << (e / 4)));
        for (int f : d::mc_edge_faces(e)) {
            // Both corners of the edge lie on the face.
            for (int q : c) CHECK(((q >> (f / 2)) & 1) == f % 2);
        }
    }
    for (int f = 0; f < 6; ++f) {
        const auto p = d::mc_face_corners(f);
        for (int i = 0; i < 4; ++i) CHECK(__builtin_popcount(unsigned(p[i] ^ p[(i + 1) % 4])) == 1);
    }
    // Corners 1 = (1,0,0) and 2 = (0,1,0) inside: only face z = 0 (f = 4) holds both, diagonally.
    CHECK(d::mc_ambiguous_faces(0b00000110) == 1 << 4);
    CHECK(d::mc_ambiguous_faces(0b01101001) == 0b111111);  // checkerboard: every face
}

TEST_CASE("marching cubes: every generated case is closed polygons through exactly the crossed edges", "[mc]") {
    int cases = 0, polygons_seen = 0;
    for (int config = 0; config < 256; ++config) {
        auto inside = [config](int c) { return ((config >> c) & 1) != 0; };
        for (int bits : face_bit_variants(config)) {
            ++cases;
            const auto polys = d::mc_case_polygons(config, bits);
            std::multiset<int> edges_used;
            for (const auto& poly : polys) {
                ++polygons_seen;
                REQUIRE(poly.size() >= 3);
                for (std::size_t i = 0; i < poly.size(); ++i) {
                    const int e0 = poly[i], e1 = poly[(i + 1) % poly.size()];
                    edges_used.insert(e0);
                    // Consecutive edges are joined by a segment inside one common face f, and
                    // seen from outside the cube (normal n_f) the segment has the inside
                    // endpoints of its two edges on its right, the outside ones on its left.
                    int f = -1;
                    for (int fa : d::mc_edge_faces(e0))
                        if (on_face(e1, fa)) f = fa;
                    INFO("config " << config << " face bits " << bits << " segment " << e0 << " -> " << e1);
                    REQUIRE(f >= 0);
                    Eigen::Vector3d n = Eigen::Vector3d::Zero();
                    n[f / 2] = (f % 2) ? 1.0 : -1.0;
                    const Eigen::Vector3d a = midpoint(e0), b = midpoint(e1);
                    for (int e : {e0, e1})
                        for (int q : d::mc_edge_corners(e)) {
                            const double side = (b - a).cross(corner(q) - a).dot(n);
                            CHECK(side != 0.0);
                            CHECK((side < 0.0) == inside(q));
                        }
                }
            }
            for (int e = 0; e < 12; ++e) {
                const auto c = d::mc_edge_corners(e);
                const bool crossed = inside(c[0]) != inside(c[1]);
                INFO("config " << config << " face bits " << bits << " edge " << e);
                CHECK(edges_used.count(e) == (crossed ? 1u : 0u));
            }
        }
    }
    CHECK(cases > 256);
    CHECK(polygons_seen > 256);
}

TEST_CASE("marching cubes: triangulations cover each polygon with consistent orientation", "[mc]") {
    int cases = 0, centred = 0;
    for (int config = 0; config < 256; ++config) {
        for (int bits : case_bit_variants(config)) {
            INFO("config " << config << " bits " << bits);
            ++cases;
            const bool tube = (bits & d::kInteriorBit) != 0;
            const auto polys = d::mc_case_polygons(config, bits & ~d::kInteriorBit);
            const d::McCase& mc = d::mc_case_table()[std::size_t(config * d::kCaseBits + bits)];
            // Centre c's polygon is one of the generated polygons.
            std::set<std::uint16_t> polygon_masks;
            for (const auto& poly : polys) {
                std::uint16_t mask = 0;
                for (int e : poly) mask = std::uint16_t(mask | (1u << e));
                polygon_masks.insert(mask);
            }
            std::size_t expected = 0;
            std::map<std::pair<int, int>, int> polygon_sides;
            for (const auto& poly : polys) {
                expected += poly.size() - 2;
                for (std::size_t i = 0; i < poly.size(); ++i) polygon_sides[{poly[i], poly[(i + 1) % poly.size()]}] = 0;
            }
            if (tube) {
                // Case 4's tube: the two corner triangles' sides joined by six triangles.
                REQUIRE(polys.size() == 2);
                expected = 6;
            }
            if (mc.num_centres > 0) CHECK(d::mc_ambiguous_faces(config) != 0);
            if (bits == 0) CHECK(mc.num_centres == 0);  // SeparateInside: one vertex per crossed edge, always
            for (int c = 0; c < mc.num_centres; ++c) {
                CHECK(polygon_masks.count(mc.centre_edges[std::size_t(c)]) == 1);
                expected += 2;  // a fan around a centre has k triangles instead of k - 2
                ++centred;
            }
            REQUIRE(mc.num_triangles == expected);
            std::map<std::pair<int, int>, int> directed;
            for (int t = 0; t < mc.num_triangles; ++t)
                for (int v = 0; v < 3; ++v) ++directed[{mc.vertices[3 * t + v], mc.vertices[3 * t + (v + 1) % 3]}];
            for (const auto& [e, n] : directed) {
                CHECK(n == 1);
                const bool side = polygon_sides.count(e) > 0;
                const bool reverse = directed.count({e.second, e.first}) > 0;
                CHECK(side != reverse);  // a polygon side once, or an inner chord once each way
                if (!side && e.first < d::kCentreCode && e.second < d::kCentreCode) {
                    // A chord never joins two edges of one face (the neighbour could choose it too).
                    const auto fa = d::mc_edge_faces(e.first), fb = d::mc_edge_faces(e.second);
                    CHECK(fa[0] != fb[0]);
                    CHECK(fa[0] != fb[1]);
                    CHECK(fa[1] != fb[0]);
                    CHECK(fa[1] != fb[1]);
                }
            }
            for (const auto& [e, n] : polygon_sides) CHECK(directed.count(e) == 1);
        }
    }
    // Centre vertices occur only where ambiguous faces are (asserted above per case) and the
    // generator does need them (e.g. config 60 with one face joined: a tube through that face).
    CHECK(centred > 0);
    CHECK(cases == 656 + 4);  // the four body-diagonal pairs with their tube
    // The interior bit is ignored outside case 4.
    for (int config = 0; config < 256; ++config) {
        if (d::mc_body_diagonal_pair(config)) continue;
        for (int bits : face_bit_variants(config)) {
            const d::McCase& a = d::mc_case_table()[std::size_t(config * d::kCaseBits + bits)];
            const d::McCase& b = d::mc_case_table()[std::size_t(config * d::kCaseBits + (bits | d::kInteriorBit))];
            CHECK((a.num_triangles == b.num_triangles && a.vertices == b.vertices));
        }
    }
}

TEST_CASE("marching cubes: cubes sharing a face cut it the same way with opposite directions", "[mc]") {
    // Key: (axis, signs of the face's 4 corners in cyclic order, joined bit) -> directed segments
    // in face-local edge numbering (edge i joins cyclic corners i and i+1).
    std::map<std::tuple<int, int, int>, std::set<std::pair<int, int>>> seen[2];
    for (int config = 0; config < 256; ++config) {
        for (int bits : face_bit_variants(config)) {
            const auto polys = d::mc_case_polygons(config, bits);
            for (int f = 0; f < 6; ++f) {
                const auto p = d::mc_face_corners(f);
                int signs = 0;
                for (int i = 0; i < 4; ++i) signs |= ((config >> p[i]) & 1) << i;
                auto local = [&](int e) {
                    for (int i = 0; i < 4; ++i) {
                        const auto c = d::mc_edge_corners(e);
                        const int a = p[i], b = p[(i + 1) % 4];
                        if ((c[0] == a && c[1] == b) || (c[0] == b && c[1] == a)) return i;
                    }
                    return -1;
                };
                std::set<std::pair<int, int>> segments;
                for (const auto& poly : polys)
                    for (std::size_t i = 0; i < poly.size(); ++i) {
                        const int a = local(poly[i]), b = local(poly[(i + 1) % poly.size()]);
                        if (a >= 0 && b >= 0) segments.insert({a, b});
                    }
                const auto key = std::make_tuple(f / 2, signs, (bits >> f) & 1);
                auto [it, fresh] = seen[f % 2].emplace(key, segments);
                INFO("config " << config << " face " << f);
                CHECK(it->second == segments);  // depends on the face alone
            }
        }
    }
    REQUIRE(seen[0].size() == seen[1].size());
    for (const auto& [key, segments] : seen[0]) {
        std::set<std::pair<int, int>> reversed;
        for (const auto& [a, b] : segments) reversed.insert({b, a});
        CHECK(seen[1].at(key) == reversed);
    }
}

namespace {

struct AnalyticCase {
    const char* name;
    ScalarSdf sdf;
    double volume;
    int euler;
};

std::vector<AnalyticCase> analytic_cases() {
    const double pi = 3.14159265358979323846;
    return {
        {"sphere", sphere_sdf({0.031, -0.017, 0.009}, 0.41), 4.0 / 3.0 * pi * 0.41 * 0.41 * 0.41, 2},
        {"torus", torus_sdf({0.02, 0.01, -0.015}, 0.33, 0.13), 2.0 * pi * pi * 0.33 * 0.13 * 0.13, 0},
        {"box", box_sdf({0.01, -0.02, 0.015}, {0.3, 0.22, 0.17}), 8.0 * 0.3 * 0.22 * 0.17, 2},
    };
}

}  // namespace

TEST_CASE("marching cubes: analytic shapes give closed oriented meshes near the surface", "[mc][heavy]") {
    for (const AnalyticCase& shape : analytic_cases()) {
        for (int resolution : {16, 32, 64}) {
            for (auto rule : {pcp::McAmbiguity::AsymptoticDecider, pcp::McAmbiguity::SeparateInside}) {
                INFO(shape.name << " at resolution " << resolution << " rule " << int(rule));
                const pcp::GridSpec spec = cube_grid(resolution);
                pcp::SdfGridOptions opts;
                opts.band = pcp::NarrowBand::Dense;
                const pcp::SdfGrid grid = pcp::evaluate_sdf_grid(batch(shape.sdf), spec, opts);
                pcp::MarchingCubesOptions mc;
                mc.ambiguity = rule;
                const pcp::Mesh mesh = pcp::marching_cubes(grid, mc);
                REQUIRE(mesh.faces.rows() > 0);
                const MeshTopology t = topology(mesh);
                CHECK(t.closed_manifold_oriented());
                CHECK(t.euler() == shape.euler);

                // Vertices within half a voxel of the surface.
                const double h = spec.spacing().maxCoeff();
                double worst = 0.0;
                for (Eigen::Index v = 0; v < mesh.vertices.rows(); ++v)
                    worst = std::max(worst, std::abs(shape.sdf(mesh.vertices.row(v).transpose())));
                CHECK(worst < 0.5 * h);

                // Outward normals: positive volume close to the analytic one, and face normals
                // agreeing with the SDF gradient.
                const double vol = signed_volume(mesh);
                CHECK(vol > 0.0);
                CHECK(std::abs(vol - shape.volume) / shape.volume < (resolution == 16 ? 0.12 : 0.05));
                int agree = 0;
                for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
                    const Eigen::Vector3d a = mesh.vertices.row(mesh.faces(f, 0)).transpose();
                    const Eigen::Vector3d b = mesh.vertices.row(mesh.faces(f, 1)).transpose();
                    const Eigen::Vector3d c = mesh.vertices.row(mesh.faces(f, 2)).transpose();
                    const Eigen::Vector3d n = (b - a).cross(c - a), m = (a + b + c) / 3.0;
                    const double eps = 1e-4;
                    Eigen::Vector3d g;
                    for (int k = 0; k < 3; ++k) {
                        Eigen::Vector3d dk = Eigen::Vector3d::Zero();
                        dk[k] = eps;
                        g[k] = shape.sdf(m + dk) - shape.sdf(m - dk);
                    }
                    if (n.dot(g) > 0.0) ++agree;
                }
                CHECK(agree >= 0.98 * double(mesh.faces.rows()));
            }
        }
    }
}

TEST_CASE("marching cubes: random fields give closed manifold meshes with both ambiguity rules", "[mc]") {
    // Random sample values with a positive border: every level-set component is closed inside
    // the grid. Random signs hit every configuration, including ambiguous faces both ways.
    std::mt19937 rng(42);
    std::uniform_real_distribution<float> uniform(-1.0f, 1.0f);
    const int R = 11;  // not a multiple of the block size: truncated blocks too
    for (int trial = 0; trial < 20; ++trial) {
        std::vector<float> table(std::size_t((R + 1) * (R + 1) * (R + 1)));
        for (int k = 0; k <= R; ++k)
            for (int j = 0; j <= R; ++j)
                for (int i = 0; i <= R; ++i) {
                    const bool border = i == 0 || j == 0 || k == 0 || i == R || j == R || k == R;
                    table[std::size_t((k * (R + 1) + j) * (R + 1) + i)] = border ? 1.0f : uniform(rng) - 0.2f * (trial % 3);
                }
        const pcp::SdfGrid grid = grid_of_table(table, R);
        for (auto rule : {pcp::McAmbiguity::AsymptoticDecider, pcp::McAmbiguity::SeparateInside}) {
            INFO("trial " << trial << " rule " << int(rule));
            pcp::MarchingCubesOptions mc;
            mc.ambiguity = rule;
            const pcp::Mesh mesh = pcp::marching_cubes(grid, mc);
            REQUIRE(mesh.faces.rows() > 0);
            const MeshTopology t = topology(mesh);
            CHECK(t.closed_manifold_oriented());
            CHECK(t.edges_not_in_two_faces == 0);
            CHECK(signed_volume(mesh) > 0.0);
        }
    }
}

TEST_CASE("marching cubes: joining the inside meshes the boundary of the closed-cube solid the grid repairs see", "[mc]") {
    // Random fields (every configuration, ambiguous faces and case 4 included) and smoother ones
    // (sums of a few bumps: the handles of a bumpy fitted field): with JoinInside the mesh's Euler
    // characteristic is twice the solid's (the union of closed cubes around the inside samples),
    // so a handle the tunnel fill removed from that solid is not in the mesh. The asymptotic
    // decider separates some diagonal pairs the solid joins, and then differs on some fields.
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> uniform(-1.0f, 1.0f);
    const int R = 13;
    int decider_differs = 0, tubes = 0;
    for (int trial = 0; trial < 40; ++trial) {
        std::vector<float> table(std::size_t((R + 1) * (R + 1) * (R + 1)));
        std::vector<Eigen::Vector4f> bumps(8);
        for (auto& b : bumps) b = Eigen::Vector4f(uniform(rng), uniform(rng), uniform(rng), uniform(rng)) * float(R) * 0.5f + Eigen::Vector4f::Constant(float(R) * 0.5f);
        for (int k = 0; k <= R; ++k)
            for (int j = 0; j <= R; ++j)
                for (int i = 0; i <= R; ++i) {
                    const bool border = i == 0 || j == 0 || k == 0 || i == R || j == R || k == R;
                    float v = uniform(rng) - 0.1f * float(trial % 3);
                    if (trial % 2) {  // smooth: the nearest bump's distance minus its radius / 4, a little noise
                        v = 1e9f;
                        for (const auto& b : bumps)
                            v = std::min(v, (Eigen::Vector3f(float(i), float(j), float(k)) - b.head<3>()).norm() - 0.25f * b[3]);
                        v += 0.3f * uniform(rng);
                    }
                    table[std::size_t((k * (R + 1) + j) * (R + 1) + i)] = border ? 1.0f : v;
                }
        for (int k = 0; k < R; ++k)
            for (int j = 0; j < R; ++j)
                for (int i = 0; i < R; ++i) {
                    int config = 0;
                    for (int q = 0; q < 8; ++q)
                        config |= (table[std::size_t(((k + (q >> 2)) * (R + 1) + j + ((q >> 1) & 1)) * (R + 1) + i + (q & 1))] < 0.0f) << q;
                    tubes += d::mc_body_diagonal_pair(config);
                }
        const pcp::SdfGrid grid = grid_of_table(table, R);
        const int solid = pcp::solid_euler_characteristic(grid);
        INFO("trial " << trial << ": solid's Euler characteristic " << solid);
        pcp::MarchingCubesOptions mc;
        mc.ambiguity = pcp::McAmbiguity::JoinInside;
        const pcp::Mesh mesh = pcp::marching_cubes(grid, mc);
        REQUIRE(mesh.faces.rows() > 0);
        const MeshTopology t = topology(mesh);
        CHECK(t.closed_manifold_oriented());
        CHECK(signed_volume(mesh) > 0.0);
        CHECK(t.euler() == 2 * solid);
        mc.ambiguity = pcp::McAmbiguity::AsymptoticDecider;
        decider_differs += topology(pcp::marching_cubes(grid, mc)).euler() != 2 * solid;
    }
    CHECK(tubes > 0);            // case 4 occurred
    CHECK(decider_differs > 0);  // the rule matters
}

TEST_CASE("marching cubes: the field minus a level selects that level set, vertices interpolate linearly", "[mc]") {
    // A linear field: every vertex lies exactly on the plane x + 2y - z = iso.
    auto plane = [](const Eigen::Vector3d& p) { return p.x() + 2.0 * p.y() - p.z(); };
    const pcp::GridSpec spec = cube_grid(10, 1.0);
    pcp::SdfGridOptions opts;
    opts.band = pcp::NarrowBand::Dense;
    opts.block_cells = 3;
    for (double iso : {0.0, 0.37}) {
        const pcp::SdfGrid grid =
            pcp::evaluate_sdf_grid(batch([&](const Eigen::Vector3d& p) { return plane(p) - iso; }), spec, opts);
        const pcp::Mesh mesh = pcp::marching_cubes(grid);
        REQUIRE(mesh.vertices.rows() > 0);
        double worst = 0.0;
        for (Eigen::Index v = 0; v < mesh.vertices.rows(); ++v)
            worst = std::max(worst, std::abs(plane(mesh.vertices.row(v).transpose()) - iso));
        CHECK(worst < 1e-5);  // float samples
        // An open sheet: its boundary edges are on the grid box, every other edge has two faces.
        const MeshTopology t = topology(mesh);
        CHECK(t.repeated_directed_edges == 0);
        CHECK(t.euler() == 1);  // a disk
        // Normals point towards increasing field (the outside).
        const Eigen::Vector3d grad(1.0, 2.0, -1.0);
        for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
            const Eigen::Vector3d a = mesh.vertices.row(mesh.faces(f, 0)).transpose();
            const Eigen::Vector3d b = mesh.vertices.row(mesh.faces(f, 1)).transpose();
            const Eigen::Vector3d c = mesh.vertices.row(mesh.faces(f, 2)).transpose();
            CHECK((b - a).cross(c - a).dot(grad) >= -1e-12);  // zero-area faces where the plane hits samples
        }
    }
}

TEST_CASE("marching cubes: an empty level set gives an empty mesh, a bad grid is an error", "[mc]") {
    pcp::SdfGridOptions opts;
    opts.band = pcp::NarrowBand::Dense;
    const pcp::SdfGrid grid =
        pcp::evaluate_sdf_grid(batch([](const Eigen::Vector3d& p) { return sphere_sdf({0, 0, 0}, 0.1)(p) + 5.0; }), cube_grid(8), opts);
    const pcp::Mesh mesh = pcp::marching_cubes(grid);
    CHECK(mesh.vertices.rows() == 0);
    CHECK(mesh.faces.rows() == 0);
    CHECK_THROWS_AS(pcp::marching_cubes(pcp::SdfGrid{}), pcp::Error);
    pcp::SdfGrid broken = grid;
    broken.values.pop_back();
    CHECK_THROWS_AS(pcp::marching_cubes(broken), pcp::Error);
}
