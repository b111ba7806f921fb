// The project's own renderer: meshes and point clouds drawn side by side into one RGB picture by a
// software rasteriser (no GPU, no window system), and that picture written as PNG. The frame is a
// grid: one column per item (input, PCP, Poisson, ground truth, ...), one row per fixed view. All
// items of a row share one orthographic camera fitted to the union of their bounding boxes, so the
// same point of space lands on the same pixel of every column. Faces are shaded flat by their
// normal against a headlight; a face whose normal points away from the camera (inverted
// orientation, or an open sheet seen from behind) gets its own colour. Points are z-buffered square
// splats coloured by depth. The world's "up" is +y: the front view looks along -z.
#pragma once

#include "pcp/core/types.hpp"

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace pcp {

/// One column of the picture: a mesh, a point cloud, or both (drawn into the same z-buffer).
struct RenderItem {
    Mesh mesh;            ///< V x 3 vertices, F x 3 faces (counter-clockwise seen from outside); may be empty
    Points points;        ///< N x 3 points; may be empty
    std::string label;    ///< written above the column (characters a-z 0-9 _ . - and space; others shown blank)
};

/// A camera direction: the camera sits at azimuth (degrees around +y, 0 = on the +z side) and
/// elevation (degrees above the x-z plane), looking at the centre of the scene.
struct View {
    double azimuth_deg = 0;
    double elevation_deg = 0;
};

/// front (0, 0), three-quarter from above (45, 30), side (90, 0).
std::vector<View> default_views();

struct RenderOptions {
    int view_size = 400;                          ///< pixels per panel side, in [16, 4096]
    std::vector<View> views = default_views();    ///< one row of panels each; at least one
    bool back_faces_distinct = true;              ///< back faces orange instead of the front colour
    int point_size = 2;                           ///< splat side in pixels, in [1, 16]
    bool labels = true;                           ///< draw each item's label in its first panel
    double margin = 0.04;                         ///< empty border as a fraction of the panel, in [0, 0.45]
    /// A section: when finite, faces (by centroid) and points nearer to the camera than the plane
    /// at this signed depth from the scene's centre (a fraction of the scene's half-diagonal, in
    /// [-1, 1]; 0 cuts through the centre) are not drawn, so the inside shows: inner sheets and
    /// the back faces of a cut closed surface (orange).
    double section = std::numeric_limits<double>::quiet_NaN();
};

/// An 8-bit RGB picture, rows top to bottom, 3 bytes per pixel.
struct Image {
    int width = 0;
    int height = 0;
    std::vector<std::uint8_t> rgb;  ///< width * height * 3 bytes

    const std::uint8_t* pixel(int x, int y) const { return rgb.data() + 3 * (static_cast<std::size_t>(y) * width + x); }
    std::uint8_t* pixel(int x, int y) { return rgb.data() + 3 * (static_cast<std::size_t>(y) * width + x); }
};

/// The colours the renderer uses (tests and callers may compare against them).
struct RenderPalette {
    static constexpr std::uint8_t background[3] = {246, 246, 246};
    static constexpr std::uint8_t separator[3] = {170, 170, 170};
    static constexpr std::uint8_t front[3] = {190, 205, 235};   ///< lit front face at full intensity
    static constexpr std::uint8_t back[3] = {245, 130, 40};     ///< lit back face at full intensity
    static constexpr std::uint8_t point_near[3] = {20, 60, 150};
    static constexpr std::uint8_t point_far[3] = {150, 175, 215};
    static constexpr std::uint8_t text[3] = {20, 20, 20};
};

/// Renders `items` side by side: width = items.size() * view_size, height = views.size() *
/// view_size. Empty items leave their panels blank; if every item is empty the camera frame is the
/// unit cube.
/// @throws pcp::Error for no items, an option out of range, a non-finite coordinate, or a face
///   index out of range (naming the item by its label or index).
Image render(const std::vector<RenderItem>& items, const RenderOptions& options = {});

/// Writes `text` into `image` with its top-left corner at pixel (x, y), in the renderer's 5 x 7
/// font at `scale` pixels per font pixel (characters a-z 0-9 _ . - and space; others blank),
/// clipped to the image. For pictures drawn by other code (the plane demonstration).
/// @throws pcp::Error for an empty or inconsistent image or a scale below 1.
void draw_text(Image& image, int x, int y, int scale, const std::string& text);

/// The PNG encoding (8-bit RGB, no interlace) of `image`, in memory.
/// @throws pcp::Error for an empty or inconsistent image, or an encoder failure.
std::vector<std::uint8_t> encode_png(const Image& image);

/// Writes `image` to `path` as PNG, atomically (temp file in the same directory, then rename).
/// @throws pcp::Error naming `path` when its directory is missing or not writable, or any write fails;
///   no output file is left behind.
void write_png(const std::string& path, const Image& image);

/// Reads a PNG file (any colour type and depth) into 8-bit RGB (alpha composited on black).
/// @throws pcp::Error naming `path` for a missing, unreadable or malformed file.
Image read_png(const std::string& path);

}  // namespace pcp
