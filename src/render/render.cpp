// The software rasteriser behind pcp::render: one orthographic camera per view fitted to the union
// bounding box of all items, a float z-buffer per panel, flat shading of each face by its normal
// against a headlight (plus ambient), back faces in their own colour, points as square splats
// coloured by depth, panel separators and a 5 x 7 bitmap font (our own glyphs) for the labels.
// Panels (item x view) are independent and drawn in parallel; each writes only its own pixels.
#include "pcp/render/render.hpp"

#include "pcp/core/error.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>

namespace pcp {

std::vector<View> default_views() { return {View{0, 0}, View{45, 30}, View{90, 0}}; }

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kAmbient = 0.25;  // share of the colour that does not depend on the light

/// Orthographic camera: screen x = offset + scale * (p - c).right, screen y = offset - scale *
/// (p - c).up (rows grow downwards), depth = (p - c).toward (larger = nearer the camera).
struct Camera {
    Eigen::Vector3d center, right, up, toward;
    double scale = 1, offset = 0, radius = 1;

    Eigen::Vector3d project(const Eigen::Vector3d& p) const {
        const Eigen::Vector3d d = p - center;
        return {offset + scale * d.dot(right), offset - scale * d.dot(up), d.dot(toward)};
    }
};

Camera make_camera(const View& view, const Aabb& box, int size, double margin) {
    const double az = view.azimuth_deg * kPi / 180, el = view.elevation_deg * kPi / 180;
    Camera cam;
    cam.center = box.center();
    cam.toward = Eigen::Vector3d(std::cos(el) * std::sin(az), std::sin(el), std::cos(el) * std::cos(az));
    cam.right = Eigen::Vector3d(std::cos(az), 0, -std::sin(az));
    cam.up = cam.toward.cross(cam.right);
    // Half the diagonal: the box fits the panel from every direction, so the scale is the same in
    // every view and every column.
    cam.radius = 0.5 * box.extent().norm();
    if (!(cam.radius > 0)) cam.radius = 1;
    cam.offset = 0.5 * size;
    cam.scale = size * (0.5 - margin) / cam.radius;
    return cam;
}

/// A panel: its pixels in the shared image plus its own z-buffer.
struct Panel {
    Image* image;
    int x0, y0, size;
    std::vector<float> depth;

    Panel(Image* img, int x, int y, int s)
        : image(img), x0(x), y0(y), size(s), depth(static_cast<std::size_t>(s) * s, -std::numeric_limits<float>::infinity()) {}

    /// Writes `colour` at panel pixel (x, y) if `z` is nearer than what is there.
    void plot(int x, int y, float z, const std::uint8_t colour[3]) {
        float& d = depth[static_cast<std::size_t>(y) * size + x];
        if (z <= d) return;
        d = z;
        std::uint8_t* px = image->pixel(x0 + x, y0 + y);
        px[0] = colour[0];
        px[1] = colour[1];
        px[2] = colour[2];
    }
};

void shade(const std::uint8_t base[3], double intensity, std::uint8_t out[3]) {
    for (int k = 0; k < 3; ++k) out[k] = static_cast<std::uint8_t>(std::lround(std::clamp(base[k] * intensity, 0.0, 255.0)));
}

// Edge function of the directed edge a -> b at p: twice the signed area of (a, b, p). Evaluated
// from the edge's endpoints in one canonical order and negated for the other, so that the two
// faces sharing an edge get exactly opposite values at every pixel centre: a centre on the edge
// (value 0) is inside both, never in neither. The plain formula is not antisymmetric in rounding
// (another base point, and a fused multiply-add contracts one product but not the other), which
// left a crack of background pixels along shared edges under some compilers.
inline double edge(double ax, double ay, double bx, double by, double px, double py) {
    if (ax < bx || (ax == bx && ay < by)) return (bx - ax) * (py - ay) - (by - ay) * (px - ax);
    return -((ax - bx) * (py - by) - (ay - by) * (px - bx));
}

void draw_mesh(Panel& panel, const Mesh& mesh, const Camera& cam, bool back_distinct, double cut_z) {
    const Eigen::Index nv = mesh.vertices.rows();
    // Projected vertices, V x 3: screen x, screen y, depth.
    std::vector<Eigen::Vector3d> s(static_cast<std::size_t>(nv));
    for (Eigen::Index i = 0; i < nv; ++i) s[static_cast<std::size_t>(i)] = cam.project(mesh.vertices.row(i).transpose());
    const double limit = panel.size - 1;
    for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
        const auto ia = static_cast<std::size_t>(mesh.faces(f, 0)), ib = static_cast<std::size_t>(mesh.faces(f, 1)),
                   ic = static_cast<std::size_t>(mesh.faces(f, 2));
        const Eigen::Vector3d &a = s[ia], &b = s[ib], &c = s[ic];
        if ((a.z() + b.z() + c.z()) / 3 > cut_z) continue;  // in front of the section plane
        double area = edge(a.x(), a.y(), b.x(), b.y(), c.x(), c.y());
        if (area == 0) continue;  // seen edge-on
        const Eigen::Vector3d v0 = mesh.vertices.row(static_cast<Eigen::Index>(ia)).transpose();
        const Eigen::Vector3d n = (mesh.vertices.row(static_cast<Eigen::Index>(ib)).transpose() - v0)
                                      .cross(mesh.vertices.row(static_cast<Eigen::Index>(ic)).transpose() - v0);
        const double len = n.norm();
        if (!(len > 0)) continue;  // degenerate face
        const double facing = n.dot(cam.toward) / len;
        std::uint8_t colour[3];
        shade(facing >= 0 || !back_distinct ? RenderPalette::front : RenderPalette::back,
              kAmbient + (1 - kAmbient) * std::abs(facing), colour);
        // Pixel bounding box, clipped to the panel; pixel centres at (x + 0.5, y + 0.5).
        const double minx = std::min({a.x(), b.x(), c.x()}), maxx = std::max({a.x(), b.x(), c.x()});
        const double miny = std::min({a.y(), b.y(), c.y()}), maxy = std::max({a.y(), b.y(), c.y()});
        if (maxx < 0 || maxy < 0 || minx > limit + 1 || miny > limit + 1) continue;
        const int x_lo = static_cast<int>(std::max(0.0, std::floor(minx - 0.5)));
        const int x_hi = static_cast<int>(std::min(limit, std::ceil(maxx - 0.5)));
        const int y_lo = static_cast<int>(std::max(0.0, std::floor(miny - 0.5)));
        const int y_hi = static_cast<int>(std::min(limit, std::ceil(maxy - 0.5)));
        // Either winding: flip the sign so that inside means all three edge functions >= 0.
        const double sign = area > 0 ? 1.0 : -1.0;
        area *= sign;
        for (int y = y_lo; y <= y_hi; ++y) {
            const double py = y + 0.5;
            for (int x = x_lo; x <= x_hi; ++x) {
                const double px = x + 0.5;
                const double w0 = sign * edge(b.x(), b.y(), c.x(), c.y(), px, py);
                const double w1 = sign * edge(c.x(), c.y(), a.x(), a.y(), px, py);
                const double w2 = sign * edge(a.x(), a.y(), b.x(), b.y(), px, py);
                if (w0 < 0 || w1 < 0 || w2 < 0) continue;
                const double z = (w0 * a.z() + w1 * b.z() + w2 * c.z()) / area;
                panel.plot(x, y, static_cast<float>(z), colour);
            }
        }
    }
}

void draw_points(Panel& panel, const Points& points, const Camera& cam, int point_size, double cut_z) {
    for (Eigen::Index i = 0; i < points.rows(); ++i) {
        const Eigen::Vector3d p = cam.project(points.row(i).transpose());
        if (p.z() > cut_z) continue;  // in front of the section plane
        // 0 at the nearest possible depth, 1 at the farthest.
        const double t = std::clamp((cam.radius - p.z()) / (2 * cam.radius), 0.0, 1.0);
        std::uint8_t colour[3];
        for (int k = 0; k < 3; ++k)
            colour[k] = static_cast<std::uint8_t>(
                std::lround((1 - t) * RenderPalette::point_near[k] + t * RenderPalette::point_far[k]));
        const int x0 = static_cast<int>(std::lround(p.x() - 0.5 * point_size));
        const int y0 = static_cast<int>(std::lround(p.y() - 0.5 * point_size));
        for (int y = std::max(0, y0); y < std::min(panel.size, y0 + point_size); ++y)
            for (int x = std::max(0, x0); x < std::min(panel.size, x0 + point_size); ++x)
                panel.plot(x, y, static_cast<float>(p.z()), colour);
    }
}

// ---- labels: a 5 x 7 bitmap font for a-z 0-9 _ . - ----

struct Glyph {
    char c;
    const char* rows[7];
};

// clang-format off
constexpr Glyph kFont[] = {
    {'a', {".....", ".....", ".###.", "....#", ".####", "#...#", ".####"}},
    {'b', {"#....", "#....", "####.", "#...#", "#...#", "#...#", "####."}},
    {'c', {".....", ".....", ".###.", "#....", "#....", "#...#", ".###."}},
    {'d', {"....#", "....#", ".####", "#...#", "#...#", "#...#", ".####"}},
    {'e', {".....", ".....", ".###.", "#...#", "#####", "#....", ".###."}},
    {'f', {"..##.", ".#..#", ".#...", "###..", ".#...", ".#...", ".#..."}},
    {'g', {".....", ".####", "#...#", "#...#", ".####", "....#", ".###."}},
    {'h', {"#....", "#....", "#.##.", "##..#", "#...#", "#...#", "#...#"}},
    {'i', {"..#..", ".....", ".##..", "..#..", "..#..", "..#..", ".###."}},
    {'j', {"...#.", ".....", "..##.", "...#.", "...#.", "#..#.", ".##.."}},
    {'k', {"#....", "#....", "#..#.", "#.#..", "##...", "#.#..", "#..#."}},
    {'l', {".##..", "..#..", "..#..", "..#..", "..#..", "..#..", ".###."}},
    {'m', {".....", ".....", "##.#.", "#.#.#", "#.#.#", "#...#", "#...#"}},
    {'n', {".....", ".....", "#.##.", "##..#", "#...#", "#...#", "#...#"}},
    {'o', {".....", ".....", ".###.", "#...#", "#...#", "#...#", ".###."}},
    {'p', {".....", "####.", "#...#", "#...#", "####.", "#....", "#...."}},
    {'q', {".....", ".####", "#...#", "#...#", ".####", "....#", "....#"}},
    {'r', {".....", ".....", "#.##.", "##..#", "#....", "#....", "#...."}},
    {'s', {".....", ".....", ".####", "#....", ".###.", "....#", "####."}},
    {'t', {".#...", ".#...", "###..", ".#...", ".#...", ".#..#", "..##."}},
    {'u', {".....", ".....", "#...#", "#...#", "#...#", "#..##", ".##.#"}},
    {'v', {".....", ".....", "#...#", "#...#", "#...#", ".#.#.", "..#.."}},
    {'w', {".....", ".....", "#...#", "#...#", "#.#.#", "#.#.#", ".#.#."}},
    {'x', {".....", ".....", "#...#", ".#.#.", "..#..", ".#.#.", "#...#"}},
    {'y', {".....", "#...#", "#...#", "#...#", ".####", "....#", ".###."}},
    {'z', {".....", ".....", "#####", "...#.", "..#..", ".#...", "#####"}},
    {'0', {".###.", "#...#", "#..##", "#.#.#", "##..#", "#...#", ".###."}},
    {'1', {"..#..", ".##..", "..#..", "..#..", "..#..", "..#..", ".###."}},
    {'2', {".###.", "#...#", "....#", "...#.", "..#..", ".#...", "#####"}},
    {'3', {"#####", "...#.", "..#..", "...#.", "....#", "#...#", ".###."}},
    {'4', {"...#.", "..##.", ".#.#.", "#..#.", "#####", "...#.", "...#."}},
    {'5', {"#####", "#....", "####.", "....#", "....#", "#...#", ".###."}},
    {'6', {"..##.", ".#...", "#....", "####.", "#...#", "#...#", ".###."}},
    {'7', {"#####", "....#", "...#.", "..#..", ".#...", ".#...", ".#..."}},
    {'8', {".###.", "#...#", "#...#", ".###.", "#...#", "#...#", ".###."}},
    {'9', {".###.", "#...#", "#...#", ".####", "....#", "...#.", ".##.."}},
    {'_', {".....", ".....", ".....", ".....", ".....", ".....", "#####"}},
    {'.', {".....", ".....", ".....", ".....", ".....", ".##..", ".##.."}},
    {'-', {".....", ".....", ".....", "#####", ".....", ".....", "....."}},
};
// clang-format on

const Glyph* find_glyph(char c) {
    const char lower = (c >= 'A' && c <= 'Z') ? static_cast<char>(c - 'A' + 'a') : c;
    for (const Glyph& g : kFont)
        if (g.c == lower) return &g;
    return nullptr;  // space and unknown characters: blank
}

/// Draws `text` with its top-left corner at panel pixel (x, y), `scale` pixels per font pixel,
/// clipped to the panel (panel_w x panel_h pixels at (panel_x, panel_y)).
void draw_text_in(Image& image, int panel_x, int panel_y, int panel_w, int panel_h, int x, int y, int scale,
                  const std::string& text) {
    const int panel_size = panel_w;
    for (char ch : text) {
        if (x + 5 * scale > panel_size) break;
        if (const Glyph* g = find_glyph(ch)) {
            // Letters with a descender sit one font pixel lower.
            const int drop = (g->c == 'g' || g->c == 'p' || g->c == 'q' || g->c == 'y') ? scale : 0;
            for (int r = 0; r < 7; ++r)
                for (int col = 0; col < 5; ++col) {
                    if (g->rows[r][col] != '#') continue;
                    for (int dy = 0; dy < scale; ++dy)
                        for (int dx = 0; dx < scale; ++dx) {
                            const int px = x + col * scale + dx, py = y + drop + r * scale + dy;
                            if (px < 0 || py < 0 || px >= panel_w || py >= panel_h) continue;
                            std::uint8_t* p = image.pixel(panel_x + px, panel_y + py);
                            p[0] = RenderPalette::text[0];
                            p[1] = RenderPalette::text[1];
                            p[2] = RenderPalette::text[2];
                        }
                }
        }
        x += 6 * scale;
    }
}

std::string item_name(const RenderItem& item, std::size_t index) {
    return item.label.empty() ? "item " + std::to_string(index) : "item " + std::to_string(index) + " ('" + item.label + "')";
}

}  // namespace

void draw_text(Image& image, int x, int y, int scale, const std::string& text) {
    PCP_CHECK(scale >= 1 && image.width > 0 && image.height > 0 &&
                  image.rgb.size() == std::size_t(image.width) * std::size_t(image.height) * 3,
              "render::draw_text: needs a non-empty image and a scale of at least 1");
    draw_text_in(image, 0, 0, image.width, image.height, x, y, scale, text);
}

Image render(const std::vector<RenderItem>& items, const RenderOptions& options) {
    PCP_CHECK(!items.empty(), "render: nothing to draw (no items)");
    PCP_CHECK(items.size() <= 64, "render: " << items.size() << " items; at most 64 fit in one picture");
    PCP_CHECK(options.view_size >= 16 && options.view_size <= 4096,
              "render: view_size must be in [16, 4096] (got " << options.view_size << ")");
    PCP_CHECK(!options.views.empty() && options.views.size() <= 16,
              "render: need 1 to 16 views (got " << options.views.size() << ")");
    PCP_CHECK(options.point_size >= 1 && options.point_size <= 16,
              "render: point_size must be in [1, 16] (got " << options.point_size << ")");
    PCP_CHECK(options.margin >= 0 && options.margin <= 0.45, "render: margin must be in [0, 0.45] (got " << options.margin << ")");
    PCP_CHECK(std::isnan(options.section) || (options.section >= -1 && options.section <= 1),
              "render: section must be in [-1, 1] (got " << options.section << ")");
    for (const View& v : options.views)
        PCP_CHECK(std::isfinite(v.azimuth_deg) && std::isfinite(v.elevation_deg), "render: a view angle is not finite");

    // The shared frame: union of every item's vertices and points.
    Aabb box;
    bool any = false;
    auto grow = [&](const Points& p) {
        if (p.rows() == 0) return;
        const Eigen::Vector3d lo = p.colwise().minCoeff().transpose(), hi = p.colwise().maxCoeff().transpose();
        box.min = any ? box.min.cwiseMin(lo) : lo;
        box.max = any ? box.max.cwiseMax(hi) : hi;
        any = true;
    };
    for (std::size_t i = 0; i < items.size(); ++i) {
        const RenderItem& item = items[i];
        PCP_CHECK(item.mesh.vertices.allFinite(), "render: " << item_name(item, i) << ": a mesh vertex is not finite");
        PCP_CHECK(item.points.allFinite(), "render: " << item_name(item, i) << ": a point is not finite");
        if (item.mesh.faces.rows() > 0)
            PCP_CHECK(item.mesh.faces.minCoeff() >= 0 && item.mesh.faces.maxCoeff() < item.mesh.vertices.rows(),
                      "render: " << item_name(item, i) << ": a face index is out of range (" << item.mesh.vertices.rows()
                                 << " vertices)");
        grow(item.mesh.vertices);
        grow(item.points);
    }
    if (!any) box.max = Eigen::Vector3d::Ones();

    const int size = options.view_size;
    const int columns = static_cast<int>(items.size()), rows = static_cast<int>(options.views.size());
    Image image;
    image.width = columns * size;
    image.height = rows * size;
    image.rgb.resize(static_cast<std::size_t>(image.width) * image.height * 3);
    for (std::size_t i = 0; i < image.rgb.size(); i += 3)
        for (int k = 0; k < 3; ++k) image.rgb[i + static_cast<std::size_t>(k)] = RenderPalette::background[k];

    const int panels = columns * rows;
#pragma omp parallel for schedule(dynamic, 1)
    for (int p = 0; p < panels; ++p) {
        const int col = p % columns, row = p / columns;
        const RenderItem& item = items[static_cast<std::size_t>(col)];
        const Camera cam = make_camera(options.views[static_cast<std::size_t>(row)], box, size, options.margin);
        Panel panel(&image, col * size, row * size, size);
        const double cut_z = std::isfinite(options.section) ? options.section * cam.radius : std::numeric_limits<double>::infinity();
        if (item.mesh.faces.rows() > 0) draw_mesh(panel, item.mesh, cam, options.back_faces_distinct, cut_z);
        if (item.points.rows() > 0) draw_points(panel, item.points, cam, options.point_size, cut_z);
        if (options.labels && row == 0 && !item.label.empty()) {
            const int scale = std::max(1, size / 200);
            draw_text_in(image, col * size, 0, size, size, 4 * scale, 4 * scale, scale, item.label);
        }
    }

    // One-pixel separators on the first column / row of every panel but the first.
    for (int c = 1; c < columns; ++c)
        for (int y = 0; y < image.height; ++y) std::copy_n(RenderPalette::separator, 3, image.pixel(c * size, y));
    for (int r = 1; r < rows; ++r)
        for (int x = 0; x < image.width; ++x) std::copy_n(RenderPalette::separator, 3, image.pixel(x, r * size));
    return image;
}

}  // namespace pcp
