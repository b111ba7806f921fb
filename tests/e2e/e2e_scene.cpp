// The scene mode (issue 17, paper "Surface Reconstruction for Scenes"): a generated room
// (pcp/cloud/room.hpp), scanned from inside, reconstructed with the scene settings on a reduced
// schedule. The mesh must stay open where the data ends -- no sheet across the doorway, no lid
// over the open top, nothing behind the walls -- face the scanner's side, and lie close to the
// room's visible surfaces (the scene protocol's metrics against the exact ground truth).
#include "pcp/cloud/room.hpp"
#include "pcp/eval/eval.hpp"
#include "pcp/reconstruct.hpp"
#include "reduced_preset.hpp"

#include <catch2/catch.hpp>

#include <Eigen/Geometry>

TEST_CASE("scene mode: a generated room stays open at the door and the top, faces the room, lies on its surfaces", "[e2e][scene]") {
    pcp::RoomOptions ro;
    ro.points = 40000;
    const pcp::Room room = pcp::make_room(ro);
    pcp::ReconstructOptions o = pcp::test::reduced_preset();
    const pcp::ReconstructOptions scene = pcp::ReconstructOptions::preset("scene");
    o.scene = scene.scene;
    o.sign_repair = scene.sign_repair;
    o.cavity_fill = scene.cavity_fill;
    o.fine_repair = scene.fine_repair;
    o.thin_offset = scene.thin_offset;
    o.resolution = 128;
    REQUIRE(o.scene.enabled);
    REQUIRE(o.winding_sign.enabled);  // the reduced (fast) preset's: the scene mode must not run it
    pcp::ReconstructReport report;
    const pcp::Mesh mesh = pcp::reconstruct(room.cloud.points, nullptr, o, &report);
    REQUIRE(mesh.faces.rows() > 0);
    CHECK(report.scene_trimmed > 0);
    CHECK(report.winding_sign.points == 0);  // an open room has no inside for a winding number

    const double W = ro.width, D = ro.depth, H = ro.height, t = ro.wall;
    Eigen::Index in_doorway = 0, above = 0, behind = 0, floor_up = 0, floor_down = 0;
    for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
        const Eigen::Vector3d a = mesh.vertices.row(mesh.faces(f, 0)), b = mesh.vertices.row(mesh.faces(f, 1)),
                              c = mesh.vertices.row(mesh.faces(f, 2));
        const Eigen::Vector3d m = (a + b + c) / 3.0, n = (b - a).cross(c - a);
        // The doorway (1 m x 2 m in the east wall), away from its jambs, lintel and floor.
        if (m.x() > W - 0.05 && m.x() < W + t + 0.05 && std::abs(m.z() - 0.5 * D) < 0.3 && m.y() > 0.2 && m.y() < 1.8) ++in_doorway;
        if (m.y() > H + 0.15) ++above;  // a lid over the open top
        if (m.x() < -t - 0.15 || m.z() < -t - 0.15 || m.z() > D + t + 0.15 || m.y() < -t - 0.15) ++behind;
        // The open floor (away from furniture and walls): faces should look up, into the room.
        if (std::abs(m.y()) < 0.05 && m.x() > 1.0 && m.x() < 1.3 && m.z() > 0.3 && m.z() < 2.7) (n.y() > 0 ? floor_up : floor_down) += 1;
    }
    INFO("faces: " << mesh.faces.rows() << ", in the doorway " << in_doorway << ", above the walls " << above << ", behind the walls "
                   << behind << ", open floor up / down " << floor_up << " / " << floor_down << ", trimmed " << report.scene_trimmed);
    CHECK(in_doorway == 0);
    CHECK(above == 0);
    CHECK(behind == 0);
    CHECK(floor_up > 10 * std::max<Eigen::Index>(floor_down, 1));

    // Close to the visible surfaces (metres, the scene protocol against the exact ground truth).
    pcp::EvalOptions eo;
    eo.protocol = pcp::EvalProtocol::Scene;
    eo.samples = 20000;
    const pcp::EvalResult r = pcp::evaluate(mesh, room.ground_truth, eo);
    WARN("room (reduced schedule, 40k points): L1-CD " << r.metrics.chamfer_l1 << " m, NC " << r.metrics.normal_consistency
                                                    << ", F-score@0.025 " << r.metrics.fscores.front().fscore);
    CHECK(r.metrics.chamfer_l1 < 0.05);
}
