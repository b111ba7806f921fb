// The generated room (pcp/cloud/room.hpp): the scan lies on the boxes' surfaces, is one-sided
// (nothing behind the walls, under the floor or in the doorway's plane), and the ground truth is
// the visible surfaces: the floor's free area, no wall across the door.
#include "pcp/cloud/room.hpp"
#include "pcp/core/error.hpp"

#include <catch2/catch.hpp>

#include <Eigen/Geometry>

#include <cmath>

namespace {

double box_distance(const pcp::Aabb& b, const Eigen::Vector3d& p) {
    const Eigen::Vector3d q = (p - b.center()).cwiseAbs() - 0.5 * b.extent();
    return std::abs(q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0));
}

}  // namespace

TEST_CASE("room: the scan lies on the room's surfaces, seen from inside only", "[room]") {
    pcp::RoomOptions o;
    o.points = 20000;
    o.noise = 0.002;
    const pcp::Room room = pcp::make_room(o);
    REQUIRE(room.cloud.points.rows() == 20000);
    REQUIRE(room.cloud.properties.count("scanner") == 1);
    CHECK(room.cloud.properties.at("scanner").maxCoeff() == 1.0);  // both scanners contributed
    Eigen::Index far = 0;
    for (Eigen::Index i = 0; i < room.cloud.points.rows(); ++i) {
        const Eigen::Vector3d p = room.cloud.points.row(i).transpose();
        double d = 1e9;
        for (const pcp::Aabb& b : room.boxes) d = std::min(d, box_distance(b, p));
        far += d > 5 * o.noise;
        // One-sided: nothing under the floor, behind the west/north/south walls or above the walls.
        CHECK(p.y() > -5 * o.noise);
        CHECK(p.x() > -5 * o.noise);
        CHECK(p.z() > -5 * o.noise);
        CHECK(p.z() < o.depth + 5 * o.noise);
        CHECK(p.y() < o.height + 5 * o.noise);
    }
    CHECK(far <= 2);  // Gaussian noise: beyond 5 sigma is rare
}

TEST_CASE("room: the ground truth is the visible surfaces (floor minus footprints, the door open)", "[room]") {
    const pcp::RoomOptions o;
    const pcp::Room room = pcp::make_room(o);
    const pcp::Mesh& gt = room.ground_truth;
    REQUIRE(gt.faces.rows() > 0);
    double floor_area = 0, door_area = 0;
    for (Eigen::Index f = 0; f < gt.faces.rows(); ++f) {
        const Eigen::Vector3d a = gt.vertices.row(gt.faces(f, 0)), b = gt.vertices.row(gt.faces(f, 1)), c = gt.vertices.row(gt.faces(f, 2));
        const Eigen::Vector3d n = (b - a).cross(c - a);
        const Eigen::Vector3d centre = (a + b + c) / 3.0;
        if (std::abs(centre.y()) < 1e-9 && n.y() > 0) floor_area += 0.5 * n.norm();
        // The east wall's inner plane across the door opening (z in the door, below 2 m).
        if (std::abs(centre.x() - o.width) < 1e-9 && std::abs(centre.z() - 0.5 * o.depth) < 0.45 && centre.y() < 1.95)
            door_area += 0.5 * n.norm();
    }
    // The floor inside the walls and in the doorway (1 m x the wall), less the cabinet (0.5 x 1.0),
    // the box (0.5 x 0.5) and four legs.
    CHECK(floor_area == Approx(o.width * o.depth + o.wall * 1.0 - 0.5 - 0.25 - 4 * 0.0025).epsilon(1e-6));
    CHECK(door_area == 0.0);
}

TEST_CASE("room: bad options are refused", "[room]") {
    pcp::RoomOptions o;
    o.scanners = {Eigen::Vector3d(-1.0, 1.5, 1.0)};  // behind the west wall
    CHECK_THROWS_WITH(pcp::make_room(o), Catch::Contains("scanner"));
    o = pcp::RoomOptions{};
    o.points = 10;
    CHECK_THROWS_AS(pcp::make_room(o), pcp::Error);
    o = pcp::RoomOptions{};
    o.height = 1.5;  // lower than the door
    CHECK_THROWS_AS(pcp::make_room(o), pcp::Error);
}
