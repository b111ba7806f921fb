// Generates the marching-cubes case table (see mc_cases.hpp for the numbering). For one cube
// configuration: every face contributes line segments joining its crossed edges (two crossings:
// one segment; four crossings: two segments, chosen by the face bit); each segment is directed so
// that, seen from outside the cube, the inside corners lie to its right; the segments then chain
// into closed cycles because every crossed edge lies on exactly two faces and the direction rule
// is the induced boundary orientation of the outside region on the cube's surface. Each cycle is
// triangulated by a small dynamic program that forbids diagonals between two edges of one face
// and otherwise minimises the total diagonal length (edge midpoints as vertex positions); the
// few polygons that admit no such triangulation get a fan around an added centre vertex. Case 4
// with the interior bit: a band of six triangles between its two corner triangles' sides.
#include "mesh/grid/mc_cases.hpp"

#include "pcp/core/error.hpp"

#include <Eigen/Geometry>  // cross products

#include <algorithm>
#include <cmath>
#include <limits>

namespace pcp::detail {
namespace {

Eigen::Vector3d corner_position(int c) {
    return Eigen::Vector3d(c & 1, (c >> 1) & 1, (c >> 2) & 1);
}

// The two axes other than `axis`, lower first.
std::array<int, 2> other_axes(int axis) {
    return axis == 0 ? std::array<int, 2>{1, 2} : axis == 1 ? std::array<int, 2>{0, 2} : std::array<int, 2>{0, 1};
}

// The edge joining two corners that differ in exactly one coordinate.
int edge_between(int c0, int c1) {
    const int diff = c0 ^ c1;
    const int axis = diff == 1 ? 0 : diff == 2 ? 1 : 2;
    const int start = c0 & c1;
    const auto oa = other_axes(axis);
    const int k = ((start >> oa[0]) & 1) | (((start >> oa[1]) & 1) << 1);
    return 4 * axis + k;
}

Eigen::Vector3d edge_midpoint(int e) {
    const auto c = mc_edge_corners(e);
    return 0.5 * (corner_position(c[0]) + corner_position(c[1]));
}

Eigen::Vector3d face_normal(int f) {
    Eigen::Vector3d n = Eigen::Vector3d::Zero();
    n[f / 2] = (f % 2) ? 1.0 : -1.0;
    return n;
}

bool share_face(int e0, int e1) {
    const auto f0 = mc_edge_faces(e0);
    const auto f1 = mc_edge_faces(e1);
    return f0[0] == f1[0] || f0[0] == f1[1] || f0[1] == f1[0] || f0[1] == f1[1];
}

}  // namespace

std::array<int, 2> mc_edge_corners(int edge) {
    const int axis = edge / 4;
    const int k = edge % 4;
    const auto oa = other_axes(axis);
    const int start = ((k & 1) << oa[0]) | ((k >> 1) << oa[1]);
    return {start, start | (1 << axis)};
}

std::array<int, 2> mc_edge_faces(int edge) {
    const int axis = edge / 4;
    const int k = edge % 4;
    const auto oa = other_axes(axis);
    return {2 * oa[0] + (k & 1), 2 * oa[1] + (k >> 1)};
}

std::array<int, 4> mc_face_corners(int face) {
    const int axis = face / 2;
    const int base = (face % 2) << axis;
    const auto oa = other_axes(axis);
    const int u = 1 << oa[0];
    const int v = 1 << oa[1];
    return {base, base | u, base | u | v, base | v};
}

int mc_ambiguous_faces(int config) {
    int mask = 0;
    for (int f = 0; f < 6; ++f) {
        const auto p = mc_face_corners(f);
        const bool in0 = (config >> p[0]) & 1, in1 = (config >> p[1]) & 1;
        const bool in2 = (config >> p[2]) & 1, in3 = (config >> p[3]) & 1;
        if (in0 == in2 && in1 == in3 && in0 != in1) mask |= 1 << f;
    }
    return mask;
}

bool mc_body_diagonal_pair(int config) {
    for (int c = 0; c < 4; ++c)
        if (config == ((1 << c) | (1 << (7 - c)))) return true;
    return false;
}

std::vector<std::vector<int>> mc_case_polygons(int config, int face_bits) {
    PCP_CHECK(config >= 0 && config < 256 && face_bits >= 0 && face_bits < 64,
              "marching cubes: case (" << config << ", " << face_bits << ") out of range");
    auto inside = [config](int c) { return ((config >> c) & 1) != 0; };

    // next[e] = the edge the directed segment leaving edge e goes to (-1: none yet).
    std::array<int, 12> next;
    next.fill(-1);
    auto add_segment = [&](int ea, int eb, int inside_corner, int face) {
        // Direct the segment so that the inside reference corner lies to its right seen from
        // outside the cube: ((b - a) x (p - a)) . n < 0.
        const Eigen::Vector3d a = edge_midpoint(ea), b = edge_midpoint(eb);
        const Eigen::Vector3d p = corner_position(inside_corner);
        if ((b - a).cross(p - a).dot(face_normal(face)) > 0.0) std::swap(ea, eb);
        PCP_CHECK(next[ea] == -1, "marching cubes: case " << config << ": edge " << ea
                                      << " has two outgoing segments (table generator bug)");
        next[ea] = eb;
    };

    for (int f = 0; f < 6; ++f) {
        const auto p = mc_face_corners(f);
        int crossed[4];
        int n_crossed = 0;
        for (int i = 0; i < 4; ++i) {
            if (inside(p[i]) != inside(p[(i + 1) % 4])) crossed[n_crossed++] = i;  // edge p[i]-p[i+1]
        }
        if (n_crossed == 2) {
            const int ea = edge_between(p[crossed[0]], p[(crossed[0] + 1) % 4]);
            const int eb = edge_between(p[crossed[1]], p[(crossed[1] + 1) % 4]);
            int ref = -1;
            for (int i = 0; i < 4 && ref < 0; ++i) {
                if (inside(p[i])) ref = p[i];
            }
            add_segment(ea, eb, ref, f);
        } else if (n_crossed == 4) {
            // Ambiguous face: cut off each inside corner (separated) or each outside corner (the
            // inside corners joined through the face).
            const bool joined = (face_bits >> f) & 1;
            for (int i = 0; i < 4; ++i) {
                if (inside(p[i]) == joined) continue;  // cut off corner i when it is on the minority side
                const int prev = (i + 3) % 4, nxt = (i + 1) % 4;
                const int ea = edge_between(p[prev], p[i]);
                const int eb = edge_between(p[i], p[nxt]);
                add_segment(ea, eb, joined ? p[nxt] : p[i], f);
            }
        }
    }

    std::vector<std::vector<int>> polygons;
    std::array<bool, 12> used{};
    for (int e = 0; e < 12; ++e) {
        if (next[e] < 0 || used[e]) continue;
        std::vector<int> cycle;
        int cur = e;
        while (!used[cur]) {
            used[cur] = true;
            cycle.push_back(cur);
            cur = next[cur];
            PCP_CHECK(cur >= 0, "marching cubes: case " << config << ": open polygon (table generator bug)");
        }
        PCP_CHECK(cur == e, "marching cubes: case " << config << ": polygons merge (table generator bug)");
        polygons.push_back(std::move(cycle));
    }
    return polygons;
}

McCase mc_triangulate_case(int config, int bits) {
    PCP_CHECK(bits >= 0 && bits < kCaseBits, "marching cubes: case bits " << bits << " out of range");
    McCase out;
    int t = 0;
    auto add_triangle = [&](int a, int b, int c) {
        PCP_CHECK(t < kMaxCaseTriangles, "marching cubes: case " << config << ": too many triangles");
        out.vertices[3 * t + 0] = static_cast<std::int8_t>(a);
        out.vertices[3 * t + 1] = static_cast<std::int8_t>(b);
        out.vertices[3 * t + 2] = static_cast<std::int8_t>(c);
        ++t;
    };
    if ((bits & kInteriorBit) && mc_body_diagonal_pair(config)) {
        // The tube: the six crossed edges (three at each inside corner) ordered by their angle
        // around the diagonal alternate between the two corners; each three consecutive ones make
        // a triangle, turned to face away from the diagonal (the outside). Its sides between two
        // edges of one corner are the corner triangles' sides, with their direction.
        int c0 = 0;
        while (!((config >> c0) & 1)) ++c0;
        const Eigen::Vector3d a = corner_position(c0), axis = (corner_position(7 - c0) - a).normalized();
        const Eigen::Vector3d u = (axis.unitOrthogonal()), v = axis.cross(u);
        std::vector<std::pair<double, int>> ring;
        for (int e = 0; e < 12; ++e) {
            const auto c = mc_edge_corners(e);
            if (((config >> c[0]) & 1) == ((config >> c[1]) & 1)) continue;
            const Eigen::Vector3d p = edge_midpoint(e) - a;
            ring.emplace_back(std::atan2(p.dot(v), p.dot(u)), e);
        }
        PCP_CHECK(ring.size() == 6, "marching cubes: case " << config << ": a tube needs six crossings");
        std::sort(ring.begin(), ring.end());
        for (int k = 0; k < 6; ++k) {
            int e0 = ring[std::size_t(k)].second, e1 = ring[std::size_t((k + 1) % 6)].second, e2 = ring[std::size_t((k + 2) % 6)].second;
            const Eigen::Vector3d p0 = edge_midpoint(e0), p1 = edge_midpoint(e1), p2 = edge_midpoint(e2);
            const Eigen::Vector3d m = (p0 + p1 + p2) / 3.0, radial = (m - a) - (m - a).dot(axis) * axis;
            if ((p1 - p0).cross(p2 - p0).dot(radial) < 0.0) std::swap(e1, e2);
            add_triangle(e0, e1, e2);
        }
        out.num_triangles = static_cast<std::uint8_t>(t);
        return out;
    }
    const int face_bits = bits & (kInteriorBit - 1);
    for (const auto& poly : mc_case_polygons(config, face_bits)) {
        const int k = static_cast<int>(poly.size());
        PCP_CHECK(k >= 3, "marching cubes: case " << config << ": polygon with " << k << " edges");
        // cost[i][j]: cheapest triangulation of the sub-polygon i..j closed by the chord (i, j);
        // split[i][j]: its apex. Chords between two edges of one face are forbidden.
        constexpr double inf = std::numeric_limits<double>::infinity();
        std::vector<std::vector<double>> cost(k, std::vector<double>(k, 0.0));
        std::vector<std::vector<int>> split(k, std::vector<int>(k, -1));
        auto chord = [&](int i, int j) {
            if (j - i == 1 || (i == 0 && j == k - 1)) return 0.0;  // a polygon side
            if (share_face(poly[i], poly[j])) return inf;
            return (edge_midpoint(poly[i]) - edge_midpoint(poly[j])).norm();
        };
        for (int len = 2; len < k; ++len) {
            for (int i = 0; i + len < k; ++i) {
                const int j = i + len;
                cost[i][j] = inf;
                for (int m = i + 1; m < j; ++m) {
                    const double c = cost[i][m] + cost[m][j] + chord(i, m) + chord(m, j);
                    if (c < cost[i][j]) {
                        cost[i][j] = c;
                        split[i][j] = m;
                    }
                }
            }
        }
        if (cost[0][k - 1] < inf) {
            std::vector<std::array<int, 2>> stack{{0, k - 1}};
            while (!stack.empty()) {
                const auto [i, j] = stack.back();
                stack.pop_back();
                if (j - i < 2) continue;
                const int m = split[i][j];
                add_triangle(poly[i], poly[m], poly[j]);
                stack.push_back({i, m});
                stack.push_back({m, j});
            }
        } else {
            PCP_CHECK(out.num_centres < kMaxCaseCentres, "marching cubes: case " << config << ": too many centres");
            const int c = out.num_centres++;
            for (int e : poly) out.centre_edges[c] = static_cast<std::uint16_t>(out.centre_edges[c] | (1u << e));
            for (int i = 0; i < k; ++i) add_triangle(kCentreCode + c, poly[i], poly[(i + 1) % k]);
        }
    }
    out.num_triangles = static_cast<std::uint8_t>(t);
    return out;
}

const std::vector<McCase>& mc_case_table() {
    static const std::vector<McCase> table = [] {
        std::vector<McCase> cases(256 * kCaseBits);
        for (int config = 0; config < 256; ++config) {
            const int used = mc_ambiguous_faces(config) | (mc_body_diagonal_pair(config) ? kInteriorBit : 0);
            for (int bits = 0; bits < kCaseBits; ++bits) {
                cases[config * kCaseBits + bits] =
                    (bits & ~used) ? cases[config * kCaseBits + (bits & used)] : mc_triangulate_case(config, bits);
            }
        }
        return cases;
    }();
    return table;
}

}  // namespace pcp::detail
