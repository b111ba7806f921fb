// Tests for pcp/mesh/surface/mesh_ops.hpp: an offset along the normals keeps a thin plate whole; a
// component the stages after the fit shrank below the size rule is removed (the largest never);
// faces with no data near them are trimmed.
#include "surface_test_util.hpp"
#include "pcp/core/error.hpp"
#include "pcp/core/rng.hpp"
#include "pcp/mesh/grid/mesh_check.hpp"
#include "pcp/mesh/surface/mesh_ops.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <random>

using namespace pcp_test;

TEST_CASE("offset along normals: a plate thinner than a cell is kept whole by extracting above zero and moving back",
          "[surface_fit]") {
    // A plate of half-thickness h = 0.002 on a grid of 0.0148 cells whose samples nearest to it lie
    // 0.0074 away on either side: every sample is outside, and the zero level set has no face
    // (the thin part is lost, as a fitted field loses the parts thinner than its error). The level
    // d = 0.01 encloses it; moved back by d along the normals, its broad faces lie at |z| = h.
    const double h = 0.002, d = 0.01;
    const ScalarSdf plate = [&](const Eigen::Vector3d& p) {  // axis-aligned box, half sizes 0.3, 0.3, h
        const Eigen::Vector3d q = p.cwiseAbs() - Eigen::Vector3d(0.3, 0.3, h);
        return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
    };
    const ScalarSdf raised = [&](const Eigen::Vector3d& p) { return plate(p) - d; };
    pcp::SdfGridOptions opts;
    opts.band = pcp::NarrowBand::Dense;
    const pcp::GridSpec grid = cube_grid(81);
    CHECK(pcp::marching_cubes(pcp::evaluate_sdf_grid(batch(plate), grid, opts)).faces.rows() == 0);
    const pcp::Mesh lifted = pcp::marching_cubes(pcp::evaluate_sdf_grid(batch(raised), grid, opts));
    REQUIRE(lifted.faces.rows() > 0);
    const pcp::Mesh back = pcp::offset_along_normals(lifted, -d);
    CHECK(back.faces == lifted.faces);
    const MeshTopology topo = topology(back);
    CHECK(topo.closed_manifold_oriented());
    CHECK(topo.euler() == 2);  // one closed piece of genus 0
    double worst_lifted = 0, worst_back = 0;
    for (Eigen::Index v = 0; v < back.vertices.rows(); ++v) {
        const Eigen::RowVector3d p = back.vertices.row(v), q = lifted.vertices.row(v);
        if (std::abs(p.x()) > 0.25 || std::abs(p.y()) > 0.25) continue;  // the broad faces, away from the rim
        worst_lifted = std::max(worst_lifted, std::abs(std::abs(q.z()) - (h + d)));
        worst_back = std::max(worst_back, std::abs(std::abs(p.z()) - h));
    }
    INFO("broad faces: lifted |z| - (h + d) up to " << worst_lifted << ", moved back |z| - h up to " << worst_back);
    CHECK(worst_lifted < 1e-6);
    CHECK(worst_back < 1e-6);
    // Per vertex: the constant vector moves as the scalar; vertices given 0 stay where they are,
    // the others move by their own distance; a wrong count or a non-finite distance is refused.
    CHECK(pcp::offset_along_normals(lifted, Eigen::VectorXd::Constant(lifted.vertices.rows(), -d)).vertices
              .isApprox(back.vertices, 1e-12));
    Eigen::VectorXd some = Eigen::VectorXd::Zero(lifted.vertices.rows());
    for (Eigen::Index v = 0; v < some.size(); v += 2) some(v) = -d;
    const pcp::Mesh half = pcp::offset_along_normals(lifted, some);
    for (Eigen::Index v = 0; v < some.size(); ++v) {
        const pcp::Mesh& expected = (v % 2 == 0) ? back : lifted;
        CHECK((half.vertices.row(v) - expected.vertices.row(v)).norm() < 1e-12);
    }
    CHECK_THROWS_AS(pcp::offset_along_normals(lifted, Eigen::VectorXd::Zero(lifted.vertices.rows() + 1)), pcp::Error);
    some(1) = std::numeric_limits<double>::quiet_NaN();
    CHECK_THROWS_AS(pcp::offset_along_normals(lifted, some), pcp::Error);
    // A zero distance is the identity; a face index out of range is refused.
    CHECK(pcp::offset_along_normals(lifted, 0.0).vertices == lifted.vertices);
    pcp::Mesh broken = lifted;
    broken.faces(0, 0) = static_cast<std::int32_t>(broken.vertices.rows());
    CHECK_THROWS_AS(pcp::offset_along_normals(broken, -d), pcp::Error);
}

TEST_CASE("remove small components: a component shrunk to a point goes, one above the limit stays, the largest always",
          "[surface_fit]") {
    const pcp::Mesh sphere = mesh_of(sphere_sdf({0, 0, 0}, 0.3), 32);
    const Eigen::Index V = sphere.vertices.rows(), F = sphere.faces.rows();
    // Two octahedra beside the sphere: one collapsed to (almost) a point, as the fit leaves a lone
    // sample's octahedron, one of bounding-box diagonal 0.035.
    const auto with_octahedra = [&](double r_small, double r_large) {
        pcp::Mesh m = sphere;
        m.vertices.conservativeResize(V + 12, 3);
        m.faces.conservativeResize(F + 16, 3);
        const double offsets[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
        const int tris[8][3] = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
        const Eigen::RowVector3d centres[2] = {{0.31, 0, 0}, {0, 0.33, 0}};
        const double radii[2] = {r_small, r_large};
        for (int o = 0; o < 2; ++o) {
            for (int k = 0; k < 6; ++k)
                m.vertices.row(V + 6 * o + k) = centres[o] + radii[o] * Eigen::RowVector3d(offsets[k][0], offsets[k][1], offsets[k][2]);
            for (int k = 0; k < 8; ++k)
                for (int j = 0; j < 3; ++j) m.faces(F + 8 * o + k, j) = static_cast<int>(V + 6 * o) + tris[k][j];
        }
        return m;
    };
    const pcp::Mesh m = with_octahedra(1e-17, 0.01);
    std::int64_t removed = -1;
    const pcp::Mesh out = pcp::remove_small_components(m, 0.01, &removed);
    CHECK(removed == 1);
    CHECK(out.faces.rows() == F + 8);
    CHECK(out.vertices.rows() == V + 6);
    CHECK(pcp::mesh_topology(out).unused_vertices == 0);
    CHECK(pcp::is_closed_and_oriented(out));
    CHECK(out.vertices.row(V).isApprox(Eigen::RowVector3d(0.01, 0.33, 0)));  // the larger octahedron kept, in order
    // A limit above both removes both; zero removes none; the largest stays whatever the limit.
    CHECK(pcp::remove_small_components(m, 0.04, &removed).faces.rows() == F);
    CHECK(removed == 2);
    CHECK(pcp::remove_small_components(m, 0.0, &removed).faces.rows() == F + 16);
    CHECK(removed == 0);
    CHECK(pcp::remove_small_components(m, 100.0, &removed).faces.rows() == F);
    CHECK_THROWS_WITH(pcp::remove_small_components(m, -1.0), Catch::Contains("min_diagonal"));
    pcp::Mesh bad = m;
    bad.faces(0, 0) = static_cast<int>(m.vertices.rows());
    CHECK_THROWS_WITH(pcp::remove_small_components(bad, 0.01), Catch::Contains("out of range"));
}

TEST_CASE("trim unsupported faces: faces with no input point near their centroid go, the rest stays, vertices compacted",
          "[surface_fit]") {
    // Two unit squares (two triangles each) side by side in z = 0; points only over the first.
    pcp::Mesh m;
    m.vertices.resize(6, 3);
    m.vertices << 0, 0, 0, 1, 0, 0, 2, 0, 0, 0, 1, 0, 1, 1, 0, 2, 1, 0;
    m.faces.resize(4, 3);
    m.faces << 0, 1, 4, 0, 4, 3, 1, 2, 5, 1, 5, 4;
    pcp::PointsF pts(9, 3);
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) pts.row(3 * i + j) << 0.25f + 0.25f * i, 0.25f + 0.25f * j, 0.0f;
    const pcp::KdTree tree(pts);
    std::int64_t removed = -1;
    const pcp::Mesh t = pcp::trim_unsupported_faces(m, tree, 0.3, &removed);
    CHECK(removed == 2);
    REQUIRE(t.faces.rows() == 2);
    CHECK(t.vertices.rows() == 4);  // the first square's corners only
    CHECK(t.faces.maxCoeff() == 3);
    CHECK(t.vertices.col(0).maxCoeff() == 1.0);
    // A large radius keeps everything; bad radius throws.
    CHECK(pcp::trim_unsupported_faces(m, tree, 10.0).faces.rows() == 4);
    CHECK_THROWS_AS(pcp::trim_unsupported_faces(m, tree, 0.0), pcp::Error);
}
