// Tests for pcp/mesh/surface/sheet_gap.hpp: the crossed sides of a thin slab are moved apart to the gap,
// symmetrically; a thin slab already wider than the gap, and two walls facing each other across a
// narrow gap (outside between them), are not touched; bad arguments are refused.
#include "pcp/core/error.hpp"
#include "pcp/mesh/surface/sheet_gap.hpp"
#include "test_meshes.hpp"

#include <catch2/catch.hpp>

#include <cmath>

namespace {

// A square sheet [-0.5, 0.5]^2 at height z, n x n vertices; faces counter-clockwise seen from +z
// (normal +z) when up, else from -z.
pcp::Mesh sheet(double z, bool up, int n = 21) {
    pcp::Mesh m;
    m.vertices.resize(n * n, 3);
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) m.vertices.row(i * n + j) << -0.5 + double(i) / (n - 1), -0.5 + double(j) / (n - 1), z;
    m.faces.resize(2 * (n - 1) * (n - 1), 3);
    int f = 0;
    for (int i = 0; i + 1 < n; ++i)
        for (int j = 0; j + 1 < n; ++j) {
            const int a = i * n + j, b = (i + 1) * n + j, c = (i + 1) * n + j + 1, d = i * n + j + 1;
            if (up) {
                m.faces.row(f++) << a, b, c;
                m.faces.row(f++) << a, c, d;
            } else {
                m.faces.row(f++) << a, c, b;
                m.faces.row(f++) << a, d, c;
            }
        }
    return m;
}

// Interior vertices only (away from the sheets' rims, where the one-ring normals tilt).
template <class Fn>
void for_interior(const pcp::Mesh& m, Eigen::Index first, Eigen::Index count, Fn&& fn) {
    for (Eigen::Index v = first; v < first + count; ++v)
        if (std::abs(m.vertices(v, 0)) < 0.4 && std::abs(m.vertices(v, 1)) < 0.4) fn(m.vertices(v, 2));
}

}  // namespace

TEST_CASE("sheet gap: the crossed sides of a thin slab move apart to the gap, about where they were", "[mesh][sheet_gap]") {
    // The slab |z| < 0.01 is the solid; its top side (normal +z) has crossed below its bottom side.
    const double e = 0.001, gap = 0.004;
    const pcp::Mesh m = pcp::test::concat(sheet(-e, true), sheet(+e, false));
    const pcp::SolidFn slab = [](const Eigen::Vector3d& p) { return static_cast<float>(std::abs(p.z()) - 0.01); };
    pcp::SheetGapOptions o;
    o.min_gap = gap;
    pcp::SheetGapStats st;
    const pcp::Mesh out = pcp::keep_sheets_apart(m, slab, o, &st);
    REQUIRE(out.faces == m.faces);
    const Eigen::Index half = m.vertices.rows() / 2;
    int top = 0, bottom = 0;
    for_interior(out, 0, half, [&](double z) {
        CHECK(z == Approx(gap / 2).margin(1e-9));
        ++top;
    });
    for_interior(out, half, half, [&](double z) {
        CHECK(z == Approx(-gap / 2).margin(1e-9));
        ++bottom;
    });
    CHECK(top > 200);
    CHECK(bottom > 200);
    CHECK(st.paired == m.vertices.rows());
    CHECK(st.crossed == m.vertices.rows());
    CHECK(st.moved == m.vertices.rows());
    CHECK(st.max_move == Approx(gap / 2 + e).margin(1e-9));
    // x and y stay.
    CHECK((out.vertices.leftCols(2) - m.vertices.leftCols(2)).cwiseAbs().maxCoeff() < 1e-12);
}

TEST_CASE("sheet gap: a slab wider than the gap, and a narrow gap between walls, stay as they are", "[mesh][sheet_gap]") {
    pcp::SheetGapOptions o;
    o.min_gap = 0.004;
    pcp::SheetGapStats st;
    SECTION("a thin slab already 0.006 thick") {
        const pcp::Mesh m = pcp::test::concat(sheet(0.003, true), sheet(-0.003, false));
        const pcp::SolidFn slab = [](const Eigen::Vector3d& p) { return static_cast<float>(std::abs(p.z()) - 0.003); };
        const pcp::Mesh out = pcp::keep_sheets_apart(m, slab, o, &st);
        CHECK(out.vertices == m.vertices);
        CHECK(st.paired == m.vertices.rows());
        CHECK(st.moved == 0);
    }
    SECTION("walls facing each other across a 0.002 gap: outside between them") {
        // The bottom wall's outside is up (+z), the top wall's down: the same local picture as the
        // crossed slab above; only the solid between them differs.
        const pcp::Mesh m = pcp::test::concat(sheet(-0.001, true), sheet(0.001, false));
        const pcp::SolidFn gap = [](const Eigen::Vector3d& p) { return static_cast<float>(0.001 - std::abs(p.z())); };
        const pcp::Mesh out = pcp::keep_sheets_apart(m, gap, o, &st);
        CHECK(out.vertices == m.vertices);
        CHECK(st.paired == m.vertices.rows());
        CHECK(st.crossed == 0);
        CHECK(st.moved == 0);
    }
    SECTION("off") {
        const pcp::Mesh m = pcp::test::concat(sheet(-0.001, true), sheet(0.001, false));
        o.enabled = false;
        const pcp::Mesh out = pcp::keep_sheets_apart(m, [](const Eigen::Vector3d&) { return -1.0f; }, o, &st);
        CHECK(out.vertices == m.vertices);
        CHECK(st.moved == 0);
    }
}

TEST_CASE("sheet gap: bad options and faces are refused", "[mesh][sheet_gap]") {
    const pcp::Mesh m = sheet(0, true, 3);
    const pcp::SolidFn solid = [](const Eigen::Vector3d&) { return -1.0f; };
    pcp::SheetGapOptions o;
    o.min_gap = 0;
    CHECK_THROWS_AS(pcp::keep_sheets_apart(m, solid, o), pcp::Error);
    o = {};
    o.passes = 0;
    CHECK_THROWS_AS(pcp::keep_sheets_apart(m, solid, o), pcp::Error);
    o = {};
    o.opposite_cos = 0.5;
    CHECK_THROWS_AS(pcp::keep_sheets_apart(m, solid, o), pcp::Error);
    o = {};
    CHECK_THROWS_AS(pcp::keep_sheets_apart(m, pcp::SolidFn(), o), pcp::Error);
    pcp::Mesh bad = m;
    bad.faces(0, 1) = 99;
    CHECK_THROWS_AS(pcp::keep_sheets_apart(bad, solid, o), pcp::Error);
}
