// Tests for pcp/mesh/surface/shell_centre.hpp: the outer wall of a hollow shell moves to where the data is
// (the shell's middle for a noise band about it; nowhere for data on the wall); a thin slab (real outside on both sides) and a slab with a small filled bubble do not move; bad
// arguments are refused.
#include "mc_test_util.hpp"
#include "pcp/cloud/kdtree.hpp"
#include "pcp/cloud/shapes.hpp"
#include "pcp/core/error.hpp"
#include "pcp/mesh/repair/cavity_fill.hpp"
#include "pcp/mesh/grid/marching_cubes.hpp"
#include "pcp/mesh/surface/shell_centre.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace pcp_test;

namespace {

double mean_radius(const pcp::Mesh& m) {
    double s = 0;
    for (Eigen::Index v = 0; v < m.vertices.rows(); ++v) s += m.vertices.row(v).norm();
    return s / static_cast<double>(m.vertices.rows());
}

// Points on the sphere of radius r about the origin, moved radially by offsets spread evenly over
// [-spread, spread] (a noise band symmetric about r).
pcp::KdTree sphere_cloud(double r, double spread) {
    const pcp::PointCloud c = pcp::sample_sphere(20000, r, Eigen::Vector3d::Zero(), 7);
    pcp::PointsF p = c.points.cast<float>();
    for (Eigen::Index i = 0; i < p.rows(); ++i) {
        const Eigen::RowVector3f d = p.row(i).normalized();
        p.row(i) = d * static_cast<float>(r + spread * (2.0 * std::fmod(0.6180339887 * double(i), 1.0) - 1.0));
    }
    return pcp::KdTree(p);
}

}  // namespace

TEST_CASE("shell centring: the outer wall of a hollow shell moves to the middle of the shell", "[shell_centre]") {
    // A noisy scan's field: negative in a band 0.05 thick around the sphere of radius 0.3, positive
    // inside it again (the hollow). The cavity fill closes the hollow; the mesh is the outer wall.
    const ScalarSdf shell = [](const Eigen::Vector3d& p) { return std::abs(p.norm() - 0.3) - 0.025; };
    const pcp::SdfGrid before = dense_grid(shell, 64);  // cell 0.01875
    pcp::SdfGrid after = before;
    const pcp::CavityFillStats fill = pcp::fill_cavities(after);
    REQUIRE(fill.cavities == 1);
    const pcp::Mesh outer = pcp::marching_cubes(after);
    REQUIRE(mean_radius(outer) == Approx(0.325).margin(0.003));

    // The data: a noise band about radius 0.3, the shell's middle.
    const pcp::KdTree band = sphere_cloud(0.3, 0.015);
    pcp::ShellCentreStats st;
    const pcp::Mesh centred = pcp::centre_in_shells(outer, before, after, band, 0.2, &st);
    CHECK(st.applied);
    CHECK(st.moved == outer.vertices.rows());
    CHECK(st.mean_move == Approx(0.025).margin(0.003));
    CHECK(centred.faces == outer.faces);
    CHECK(mean_radius(centred) == Approx(0.3).margin(0.003));
    for (Eigen::Index v = 0; v < centred.vertices.rows(); ++v) CHECK(std::abs(centred.vertices.row(v).norm() - 0.3) < 0.006);

    // The same shell over data that lies on its outer wall: the data decides, the wall stays.
    const pcp::KdTree on_wall = sphere_cloud(0.325, 0.005);
    CHECK(mean_radius(pcp::centre_in_shells(outer, before, after, on_wall, 0.2)) == Approx(0.325).margin(0.004));

    // A wall thicker than max_thickness is left where it is.
    CHECK(pcp::centre_in_shells(outer, before, after, band, 0.03).vertices == outer.vertices);
}

TEST_CASE("shell centring: thin parts and bubbles keep their surface", "[shell_centre]") {
    // A slab 0.08 thick: walking in from one face leaves through the other into real outside.
    const ScalarSdf slab = box_sdf(Eigen::Vector3d::Zero(), Eigen::Vector3d(0.4, 0.4, 0.04));
    pcp::SdfGrid grid = dense_grid(slab, 64);
    const pcp::SdfGrid same = grid;
    REQUIRE(pcp::fill_cavities(grid).cavities == 0);
    const pcp::Mesh plate = pcp::marching_cubes(grid);
    const pcp::KdTree cloud = sphere_cloud(0.3, 0.0);
    pcp::ShellCentreStats st;
    CHECK(pcp::centre_in_shells(plate, same, grid, cloud, 0.2, &st).vertices == plate.vertices);
    CHECK(st.moved == 0);

    // A slab 0.16 thick with a bubble of radius 0.02 in its middle, which the fill closes: the
    // walk in from a face meets the bubble's wall, but what lies behind it is no hollow.
    const ScalarSdf bubbly = [](const Eigen::Vector3d& p) {
        const double s = box_sdf(Eigen::Vector3d::Zero(), Eigen::Vector3d(0.4, 0.4, 0.08))(p);
        return std::max(s, 0.02 - p.norm());
    };
    const pcp::SdfGrid before = dense_grid(bubbly, 64);
    pcp::SdfGrid after = before;
    REQUIRE(pcp::fill_cavities(after).cavities == 1);
    const pcp::Mesh filled = pcp::marching_cubes(after);
    CHECK(pcp::centre_in_shells(filled, before, after, cloud, 0.2, &st).vertices == filled.vertices);
    CHECK(st.moved == 0);
}

TEST_CASE("shell centring: bad arguments are refused", "[shell_centre]") {
    const pcp::SdfGrid a = dense_grid(sphere_sdf(Eigen::Vector3d::Zero(), 0.3), 32);
    const pcp::SdfGrid b = dense_grid(sphere_sdf(Eigen::Vector3d::Zero(), 0.3), 16);
    const pcp::Mesh m = pcp::marching_cubes(a);
    const pcp::KdTree cloud = sphere_cloud(0.3, 0.0);
    CHECK_THROWS_AS(pcp::centre_in_shells(m, a, a, cloud, 0.0), pcp::Error);
    CHECK_THROWS_AS(pcp::centre_in_shells(m, a, a, cloud, std::nan("")), pcp::Error);
    CHECK_THROWS_AS(pcp::centre_in_shells(m, a, b, cloud, 0.1), pcp::Error);
}
