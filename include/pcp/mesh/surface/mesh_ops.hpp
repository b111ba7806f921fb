// Operations on a mesh that the surface passes share: offsets along the vertex normals, the
// normals themselves, and trims of faces and components.
#pragma once

#include "pcp/cloud/kdtree.hpp"
#include "pcp/core/types.hpp"

#include <cstdint>

namespace pcp {

/// Every vertex moved by `distance` along its unit normal (area weighted, averaged over its
/// one-ring, as the fit's; positive: outward). Faces unchanged. pcp::reconstruct uses it to
/// bring a mesh extracted at the level F = d back by d (ReconstructOptions::thin_offset).
Mesh offset_along_normals(const Mesh& mesh, double distance);

/// The same with a distance per vertex (`distances`: one per vertex, finite).
Mesh offset_along_normals(const Mesh& mesh, const Eigen::VectorXd& distances);

/// The unit vertex normals those moves use (area weighted, averaged over the one-ring; zero where
/// undefined), V x 3.
Points mesh_vertex_normals(const Mesh& mesh);

/// Open boundaries where the data ends (the scene mode, ReconstructOptions::scene): keeps the faces
/// whose centroid has an input point within `radius` (unit-box units, like `unit_mesh` and
/// `cloud`), drops the others and the vertices no kept face uses. A signed field closes every
/// surface; a room's walls are seen from one side and its data ends at doors and wall tops, so
/// the faces that close it there rest on no data. `removed` (if not null) gets the faces dropped.
Mesh trim_unsupported_faces(const Mesh& unit_mesh, const KdTree& cloud, double radius, std::int64_t* removed = nullptr);

/// The components (connected by faces), all but the one with the most vertices, whose bounding-box
/// diagonal is under `min_diagonal`, removed; unused vertices dropped. pcp::reconstruct runs it
/// last with SurfaceFitOptions::min_extent_k x the sampling scale: the fit's support filter
/// applies that rule to the extracted mesh, but the fit and the smoothing then shrink a marching
/// cubes octahedron around a lone inside sample beside the data to a point (an 8-face component
/// of area 2e-32 came out of a noisy scan). `removed` (optional) receives the number of
/// components removed. Throws pcp::Error for a negative or non-finite `min_diagonal` or a face
/// index out of range.
Mesh remove_small_components(const Mesh& mesh, double min_diagonal, std::int64_t* removed = nullptr);

}  // namespace pcp
