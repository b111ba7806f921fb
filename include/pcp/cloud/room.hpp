// A generated room with exact ground truth, for the scene mode (issue 17; paper section "Surface
// Reconstruction for Scenes"): a floor, four walls with a door opening, no ceiling, a cabinet
// against a wall, a box and a table on four legs -- all axis-aligned boxes, in metres, y up.
// It is scanned as a terrestrial scanner would: rays from a few positions inside the room in
// directions uniform on the sphere, the first surface each ray hits, Gaussian noise along the ray;
// rays that leave through the door or the open top return nothing. So the walls are seen from one
// side only, the floor has no underside, and the data ends at the door and the walls' tops.
// The ground truth is every surface a person in the room could see (box faces facing the room's
// free space: the floor's top, the walls' inner faces, the door's jambs and lintel, the furniture
// except where it stands on the floor or against a wall), as a mesh of small quads.
#pragma once

#include "pcp/core/types.hpp"

#include <cstdint>
#include <vector>

namespace pcp {

struct RoomOptions {
    double width = 4.0;          ///< interior x extent (m)
    double depth = 3.0;          ///< interior z extent (m)
    double height = 2.5;         ///< wall height (m); there is no ceiling
    double wall = 0.1;           ///< wall and floor thickness (m)
    Eigen::Index points = 200000;  ///< scanned points in all (split evenly over the scanners)
    double noise = 0.003;        ///< standard deviation of the range noise along each ray (m)
    /// Scanner positions (inside the room); empty = two positions at 1.5 m height.
    std::vector<Eigen::Vector3d> scanners;
    double gt_cell = 0.05;       ///< edge of the ground truth's quads (m)
    std::uint64_t seed = 1;
};

struct Room {
    PointCloud cloud;            ///< the scan (metres; property "scanner" = index of the position)
    Mesh ground_truth;           ///< the visible surfaces (see above), quads split into triangles
    std::vector<Aabb> boxes;     ///< the solid boxes the room is made of
};

/// The room and its scan (deterministic for a seed). Throws pcp::Error for options out of range
/// (a scanner outside the room, non-positive sizes, too few points).
Room make_room(const RoomOptions& options = {});

}  // namespace pcp
