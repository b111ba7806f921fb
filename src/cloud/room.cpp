// The generated room (see pcp/cloud/room.hpp): boxes, a ray-cast scan, the visible faces as the
// ground truth.
#include "pcp/cloud/room.hpp"

#include "pcp/core/error.hpp"
#include "pcp/core/rng.hpp"

#include <cmath>
#include <limits>

namespace pcp {

namespace {

Aabb box(double x0, double y0, double z0, double x1, double y1, double z1) {
    Aabb b;
    b.min = Eigen::Vector3d(x0, y0, z0);
    b.max = Eigen::Vector3d(x1, y1, z1);
    return b;
}

/// Furniture positions on a 5 cm raster (the ground truth's quads then follow their outlines).
double snap(double x) { return std::round(x * 20.0) / 20.0; }

bool strictly_inside(const Aabb& b, const Eigen::Vector3d& p) {
    return (p.array() > b.min.array()).all() && (p.array() < b.max.array()).all();
}

/// Distance along the ray o + t d (|d| = 1) to box b's surface from outside, or +inf.
double ray_box(const Aabb& b, const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
    double t0 = 0, t1 = std::numeric_limits<double>::infinity();
    for (int a = 0; a < 3; ++a) {
        if (std::abs(d(a)) < 1e-15) {
            if (o(a) < b.min(a) || o(a) > b.max(a)) return std::numeric_limits<double>::infinity();
            continue;
        }
        double ta = (b.min(a) - o(a)) / d(a), tb = (b.max(a) - o(a)) / d(a);
        if (ta > tb) std::swap(ta, tb);
        t0 = std::max(t0, ta);
        t1 = std::min(t1, tb);
        if (t0 > t1) return std::numeric_limits<double>::infinity();
    }
    return t0 > 0 ? t0 : std::numeric_limits<double>::infinity();
}

}  // namespace

Room make_room(const RoomOptions& o) {
    PCP_CHECK(o.width > 1 && o.depth > 1 && o.height > 2.1 && o.wall > 0 && o.wall < 1,
              "room: width and depth must exceed 1 m, height 2.1 m (the door), wall in (0, 1) m");
    PCP_CHECK(o.points >= 1000 && o.noise >= 0 && o.noise < 0.1 && o.gt_cell > 0.001 && o.gt_cell <= 0.5,
              "room: at least 1000 points, noise in [0, 0.1) m, gt_cell in (0.001, 0.5] m");
    const double W = o.width, D = o.depth, H = o.height, t = o.wall;
    Room room;
    // The shell: floor slab, walls (west x < 0, east x > W with the door, north z < 0, south z > D).
    const double door_z0 = 0.5 * D - 0.5, door_z1 = 0.5 * D + 0.5, door_h = 2.0;
    room.boxes = {box(-t, -t, -t, W + t, 0, D + t),                    // floor
                  box(-t, 0, -t, 0, H, D + t),                         // west wall
                  box(W, 0, -t, W + t, H, door_z0),                    // east wall, north of the door
                  box(W, 0, door_z1, W + t, H, D + t),                 // east wall, south of the door
                  box(W, door_h, door_z0, W + t, H, door_z1),          // lintel
                  box(0, 0, -t, W, H, 0),                              // north wall
                  box(0, 0, D, W, H, D + t),                           // south wall
                  box(0, 0, 0.3, 0.5, 1.0, 1.3),                       // cabinet against the west wall
                  box(snap(0.65 * W), 0, snap(0.72 * D), snap(0.65 * W) + 0.5, 0.4, snap(0.72 * D) + 0.5),  // a box on the floor
                  box(snap(0.35 * W), 0.72, snap(0.3 * D), snap(0.35 * W) + 1.2, 0.76, snap(0.3 * D) + 0.8)};  // table top
    const Aabb top = room.boxes.back();  // a copy: the legs below grow the vector
    for (int i = 0; i < 4; ++i) {  // table legs, 5 cm square, 5 cm in from the corners
        const double x = i % 2 ? top.max.x() - 0.1 : top.min.x() + 0.05, z = i / 2 ? top.max.z() - 0.1 : top.min.z() + 0.05;
        room.boxes.push_back(box(x, 0, z, x + 0.05, 0.72, z + 0.05));
    }
    const Aabb interior = box(0, 0, 0, W, H, D);
    const Aabb doorway = box(W - 1e-9, 0, door_z0, W + t + 1e-9, door_h, door_z1);
    const auto free_space = [&](const Eigen::Vector3d& p) {
        if (!strictly_inside(interior, p) && !strictly_inside(doorway, p)) return false;
        for (const Aabb& b : room.boxes)
            if (strictly_inside(b, p)) return false;
        return true;
    };

    // The scan.
    std::vector<Eigen::Vector3d> scanners = o.scanners;
    if (scanners.empty()) scanners = {Eigen::Vector3d(0.3 * W, 1.5, 0.7 * D), Eigen::Vector3d(0.75 * W, 1.5, 0.35 * D)};
    for (const Eigen::Vector3d& s : scanners)
        PCP_CHECK(free_space(s), "room: scanner position (" << s.transpose() << ") is not in the room's free space");
    Rng rng(o.seed, 0x500);
    std::vector<Eigen::Vector3d> pts;
    std::vector<double> from;
    pts.reserve(static_cast<std::size_t>(o.points));
    const std::size_t per = static_cast<std::size_t>((o.points + static_cast<Eigen::Index>(scanners.size()) - 1) /
                                                     static_cast<Eigen::Index>(scanners.size()));
    for (std::size_t s = 0; s < scanners.size() && static_cast<Eigen::Index>(pts.size()) < o.points; ++s) {
        std::size_t got = 0, tries = 0;
        while (got < per && static_cast<Eigen::Index>(pts.size()) < o.points) {
            PCP_CHECK(++tries < 100 * per + 1000, "room: the scanners see too little (check the positions)");
            Eigen::Vector3d d(rng.normal(), rng.normal(), rng.normal());
            if (d.norm() < 1e-12) continue;
            d.normalize();
            double best = std::numeric_limits<double>::infinity();
            for (const Aabb& b : room.boxes) best = std::min(best, ray_box(b, scanners[s], d));
            if (!std::isfinite(best)) continue;  // out through the door or the open top
            pts.push_back(scanners[s] + (best + o.noise * rng.normal()) * d);
            from.push_back(static_cast<double>(s));
            ++got;
        }
    }
    room.cloud.points.resize(static_cast<Eigen::Index>(pts.size()), 3);
    Eigen::VectorXd scanner_id(static_cast<Eigen::Index>(pts.size()));
    for (std::size_t i = 0; i < pts.size(); ++i) {
        room.cloud.points.row(static_cast<Eigen::Index>(i)) = pts[i].transpose();
        scanner_id(static_cast<Eigen::Index>(i)) = from[i];
    }
    room.cloud.properties["scanner"] = scanner_id;

    // The ground truth: each box face cut into quads of about gt_cell; a quad is kept when the
    // point just in front of its centre is free space (in the room or the doorway, in no box).
    std::vector<Eigen::Vector3d> verts;
    std::vector<Eigen::Vector3i> faces;
    for (const Aabb& b : room.boxes)
        for (int axis = 0; axis < 3; ++axis)
            for (int side = 0; side < 2; ++side) {
                const int u = (axis + 1) % 3, v = (axis + 2) % 3;
                const double eu = b.max(u) - b.min(u), ev = b.max(v) - b.min(v);
                const int nu = std::max(1, static_cast<int>(std::ceil(eu / o.gt_cell - 1e-9)));
                const int nv = std::max(1, static_cast<int>(std::ceil(ev / o.gt_cell - 1e-9)));
                Eigen::Vector3d normal = Eigen::Vector3d::Zero();
                normal(axis) = side ? 1.0 : -1.0;
                for (int i = 0; i < nu; ++i)
                    for (int j = 0; j < nv; ++j) {
                        Eigen::Vector3d c[4];
                        for (int k = 0; k < 4; ++k) {
                            const int di = (k == 1 || k == 2) ? 1 : 0, dj = k >= 2 ? 1 : 0;
                            c[k](axis) = side ? b.max(axis) : b.min(axis);
                            c[k](u) = b.min(u) + eu * (i + di) / nu;
                            c[k](v) = b.min(v) + ev * (j + dj) / nv;
                        }
                        const Eigen::Vector3d centre = 0.25 * (c[0] + c[1] + c[2] + c[3]);
                        if (!free_space(centre + 1e-4 * normal)) continue;
                        const int base = static_cast<int>(verts.size());
                        for (const Eigen::Vector3d& p : c) verts.push_back(p);
                        // Counter-clockwise seen from the free side: (u, v, normal) is right-handed
                        // for side 1; for side 0 the order is reversed.
                        if (side) {
                            faces.emplace_back(base, base + 1, base + 2);
                            faces.emplace_back(base, base + 2, base + 3);
                        } else {
                            faces.emplace_back(base, base + 2, base + 1);
                            faces.emplace_back(base, base + 3, base + 2);
                        }
                    }
            }
    room.ground_truth.vertices.resize(static_cast<Eigen::Index>(verts.size()), 3);
    for (std::size_t i = 0; i < verts.size(); ++i) room.ground_truth.vertices.row(static_cast<Eigen::Index>(i)) = verts[i].transpose();
    room.ground_truth.faces.resize(static_cast<Eigen::Index>(faces.size()), 3);
    for (std::size_t i = 0; i < faces.size(); ++i) room.ground_truth.faces.row(static_cast<Eigen::Index>(i)) = faces[i].transpose();
    return room;
}

}  // namespace pcp
