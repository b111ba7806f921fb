// The marching-cubes case table, derived in code rather than copied (STYLE.md §3). This private
// header owns the unit cube's numbering (corners, edges, faces), the generator that turns one
// cube configuration into oriented polygons and triangles, and the table of every configuration
// built once on first use. src/marching_cubes.cpp is its only user besides tests/test_marching_cubes.cpp.
//
// Numbering. Corner c (0..7) sits at (c & 1, (c >> 1) & 1, (c >> 2) & 1). Edge e = 4 * axis + k
// runs along `axis` from the corner whose other two coordinates are (k & 1, k >> 1) (lower axis
// first) to that corner + e_axis. Face f = 2 * axis + side is the face where coordinate `axis`
// equals `side`; its outward normal is (side ? +1 : -1) * e_axis.
//
// A configuration is 8 bits, bit c set when corner c is inside (value < iso). On a face whose
// diagonal corners share a sign and differ from the other diagonal (an ambiguous face) the
// generator needs one more bit: face bit f set means the two inside corners of face f are joined
// through the face (the bilinear saddle is inside), clear means they are separated. That choice
// depends only on the face's own four values, so the two cubes sharing a face always agree and the
// mesh stays watertight. One more bit (kInteriorBit) is about the cube's interior: a configuration
// whose only two inside corners are opposite ends of a body diagonal (the classic case 4, no
// ambiguous face) gives two corner triangles with the bit clear and a tube joining the two corners
// through the cube with it set. The table is indexed by config * kCaseBits + bits; bits that do not
// apply (faces not ambiguous, the interior bit outside case 4) are ignored: their entries equal the
// entry with those bits clear.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

namespace pcp::detail {

constexpr int kMaxCaseTriangles = 12;  // 12 crossed edges at most; a polygon of k edges gives <= k triangles
constexpr int kMaxCaseCentres = 4;     // polygons triangulated around an added centre vertex
constexpr int kCentreCode = 12;        // triangle vertex code 12 + c: centre vertex c of the case
constexpr int kInteriorBit = 64;       // bit 6: the body-diagonal pair of case 4 joined through the cube
constexpr int kCaseBits = 128;         // six face bits and the interior bit

std::array<int, 2> mc_edge_corners(int edge);
/// The two faces that contain edge e.
std::array<int, 2> mc_edge_faces(int edge);
/// Face f's corners in cyclic order: (u, v) = (0,0), (1,0), (1,1), (0,1) in the face's two other
/// axes, lower axis first. Corners 0 and 2 of this list are one diagonal, 1 and 3 the other.
std::array<int, 4> mc_face_corners(int face);
/// The faces of `config` whose four corners form the ambiguous (checkerboard) pattern, as a mask.
int mc_ambiguous_faces(int config);
/// Whether the only inside corners of `config` are the two ends of one body diagonal (case 4):
/// the one configuration whose inside corners no face joins, though they touch at the centre.
bool mc_body_diagonal_pair(int config);

/// The generator's first result: closed polygons (cycles of cube edge indices), each ordered so
/// that its normal (right-hand rule) points to the outside (value >= iso) side.
std::vector<std::vector<int>> mc_case_polygons(int config, int face_bits);

/// One entry of the table: triangles counter-clockwise seen from outside, each vertex a code:
/// 0..11 the crossing on that cube edge, kCentreCode + c the centre of polygon c below (the mean of
/// its crossings), used only for polygons that cannot be triangulated from their own crossings.
struct McCase {
    std::uint8_t num_triangles = 0;
    std::uint8_t num_centres = 0;
    std::array<std::int8_t, 3 * kMaxCaseTriangles> vertices{};
    std::array<std::uint16_t, kMaxCaseCentres> centre_edges{};  ///< bit e: edge e is in centre c's polygon
};

/// The polygons of mc_case_polygons triangulated without any chord between two edges of one cube
/// face: such a chord could also be chosen by the cube across that face, making an edge shared by
/// four triangles. Among the valid triangulations, the one with the shortest chords (edge midpoints
/// as positions). A polygon with no valid triangulation (a 9-gon winding around a corner whose
/// three faces are all ambiguous, for example) becomes a fan around an added centre vertex, which
/// keeps every edge inside the cube. `bits`: the face bits, plus kInteriorBit; for a body-diagonal
/// pair with that bit, the two corner triangles' sides are instead joined by a band of six
/// triangles (a tube around the diagonal; its chords join edges of opposite corners, never of one
/// face).
McCase mc_triangulate_case(int config, int bits);

/// The full table, 256 * kCaseBits entries, generated on first use (thread-safe static initialisation).
const std::vector<McCase>& mc_case_table();

}  // namespace pcp::detail
