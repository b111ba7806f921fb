// Point-cloud and mesh file I/O. Formats are chosen by the lower-case file extension:
//   point clouds  .ply (ascii, binary little/big endian; any PLY scalar type; extra vertex
//                 properties kept by name), .xyz/.txt/.pts (text columns), .npy (NumPy float32/
//                 float64, C or Fortran order);
//   meshes        .ply (vertex + face elements), .obj, .off.
// Coordinates are always read into double in the file's own frame. Every reader either returns
// the complete contents or throws pcp::Error with a one-line message "<path>: <problem>" (with
// "line N" for text formats); no reader allocates more than the file size justifies. Every
// writer goes through pcp::write_file_atomically, so a failed write leaves no output file.
// Geometry checks (too few points, degenerate extents) are not done here: see normalize.
#pragma once

#include "pcp/core/types.hpp"

#include <string>

namespace pcp {

/// Reads a point cloud from `path` (.ply, .xyz, .txt, .pts, .npy).
///
/// @return points: N x 3 (double, the file's frame); properties: every extra per-point scalar
///   by name, each a vector of N values:
///   - .ply: each non-list vertex property other than x, y, z under its own name ("nx", "red",
///     "sdf", ...), converted to double; list properties of the vertex element are skipped;
///   - .xyz/.txt/.pts with exactly 6 columns: "nx", "ny", "nz"; with 4, 5 or 7+ columns: "c3",
///     "c4", ... (zero-based column index);
///   - .npy of shape (N, 6): "nx", "ny", "nz"; (N, k) with k = 4, 5 or > 6: "c3", "c4", ...
/// Duplicate points are kept. N may be 0 (an empty vertex element); callers that need points
/// check the count themselves.
/// @throws pcp::Error naming the file and the problem: missing/unreadable/empty file, unknown
///   extension, malformed header, truncated body, non-numeric token (with line number),
///   non-finite coordinate (with point index or line).
PointCloud read_point_cloud(const std::string& path);

/// Writes `cloud` to `path` (.ply, .xyz, .npy), atomically.
///   - .ply: binary little endian (or ascii if `ascii`), x y z and every property as double,
///     so a round trip is bit-exact;
///   - .xyz: text, one point per line, shortest round-trip decimal form (exact); a leading
///     "# x y z ..." comment names the columns;
///   - .npy: float64, C order, shape (N, 3 + P).
/// For .xyz and .npy the columns after x y z are nx ny nz (if all three are present) and then
/// the other properties in name order; only the "nx ny nz" names survive reading them back.
/// `ascii` only affects .ply.
/// @throws pcp::Error for an unsupported extension, a property whose length is not N, or an
///   I/O failure (no output file is left behind).
void write_point_cloud(const std::string& path, const PointCloud& cloud, bool ascii = false);

/// Reads a triangle mesh from `path` (.ply, .obj, .off). Polygons with more than three
/// vertices are fan-triangulated (v0 v1 v2, v0 v2 v3, ...).
///   - .ply: the "vertex" element (x, y, z) and the "face" element's list property
///     "vertex_indices" (or "vertex_index", or else its only list property); other elements
///     and properties are skipped;
///   - .obj: "v x y z" and "f" lines (forms a, a/b, a//c, a/b/c; negative = relative to the
///     end); other lines (vt, vn, g, usemtl, ...) are ignored;
///   - .off: OFF / COFF / NOFF / CNOFF headers, extra per-vertex or per-face columns ignored.
/// @return vertices V x 3 (double), faces F x 3 (zero-based indices into vertices).
/// @throws pcp::Error naming the file and the problem, including faces with fewer than three
///   vertices and vertex indices out of range.
Mesh read_mesh(const std::string& path);

struct MeshWriteOptions {
    bool ascii = false;   ///< .ply only: ascii instead of binary little endian
    int precision = 17;   ///< significant digits in text formats (ascii .ply, .obj, .off); 17
                          ///< round-trips any double exactly
};

/// Writes `mesh` to `path` (.ply, .obj, .off), atomically. Binary .ply stores vertex
/// coordinates as double (bit-exact round trip) and faces as "list uchar int vertex_indices".
/// @throws pcp::Error for an unsupported extension, face indices out of range, or an I/O
///   failure (no output file is left behind).
void write_mesh(const std::string& path, const Mesh& mesh, const MeshWriteOptions& options = {});

}  // namespace pcp
