// Tests of pcp/render/render.hpp: a cube is drawn in the centre of every view, inverted faces show
// the back-face colour, point clouds draw splats, the panels line up in one shared frame, and the
// PNG writer round-trips through libpng and fails cleanly on an unwritable directory.
#include "pcp/render/render.hpp"

#include "pcp/core/error.hpp"
#include "test_meshes.hpp"

#include <catch2/catch.hpp>

#include <png.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>

#include <unistd.h>

namespace fs = std::filesystem;

namespace {

/// The unit cube [0, 1]^3, 12 triangles counter-clockwise seen from outside.
pcp::Mesh unit_cube() {
    pcp::Mesh m;
    m.vertices.resize(8, 3);
    for (int i = 0; i < 8; ++i) m.vertices.row(i) << (i & 1), (i >> 1) & 1, (i >> 2) & 1;
    m.faces.resize(12, 3);
    m.faces << 0, 2, 1, 1, 2, 3,   // z = 0, normal -z
        4, 5, 6, 5, 7, 6,          // z = 1, +z
        0, 1, 4, 1, 5, 4,          // y = 0, -y
        2, 6, 3, 3, 6, 7,          // y = 1, +y
        0, 4, 2, 2, 4, 6,          // x = 0, -x
        1, 3, 5, 3, 7, 5;          // x = 1, +x
    return m;
}

pcp::Mesh flipped(pcp::Mesh m) {
    m.faces.col(1).swap(m.faces.col(2));
    return m;
}

bool same(const std::uint8_t* px, const std::uint8_t colour[3]) {
    return px[0] == colour[0] && px[1] == colour[1] && px[2] == colour[2];
}

/// Hue class of a pixel: front faces are blue-ish (b > r), back faces orange (r > b).
bool blueish(const std::uint8_t* px) { return px[2] > px[0] + 10; }
bool orange(const std::uint8_t* px) { return px[0] > px[2] + 40; }

fs::path tmp_dir(const std::string& name) {
    const fs::path dir = fs::path(PCP_TEST_TMP_DIR) / "render" / name;
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}

}  // namespace

TEST_CASE("render: a cube fills the centre of every view, front faces in the front colour", "[render]") {
    pcp::RenderOptions opts;
    opts.view_size = 64;
    const pcp::Image img = pcp::render({pcp::RenderItem{unit_cube(), {}, "cube"}}, opts);
    REQUIRE(img.width == 64);
    REQUIRE(img.height == 64 * 3);
    REQUIRE(img.rgb.size() == 64u * 64u * 3u * 3u);
    for (int v = 0; v < 3; ++v) {
        const std::uint8_t* centre = img.pixel(32, v * 64 + 32);
        INFO("view " << v << ": " << int(centre[0]) << " " << int(centre[1]) << " " << int(centre[2]));
        CHECK(!same(centre, pcp::RenderPalette::background));
        CHECK(blueish(centre));
    }
    // The corners of a panel stay background (the frame has a margin) but for the separators.
    CHECK(same(img.pixel(63, 63), pcp::RenderPalette::background));
    CHECK(same(img.pixel(0, 64), pcp::RenderPalette::separator));
}

TEST_CASE("render: an inverted cube shows the back-face colour where the normal one shows the front", "[render]") {
    pcp::RenderOptions opts;
    opts.view_size = 64;
    const pcp::Image img = pcp::render({{unit_cube(), {}, "ok"}, {flipped(unit_cube()), {}, "flip"}}, opts);
    REQUIRE(img.width == 128);
    for (int v = 0; v < 3; ++v) {
        const std::uint8_t* good = img.pixel(32, v * 64 + 32);
        const std::uint8_t* bad = img.pixel(64 + 32, v * 64 + 32);
        INFO("view " << v);
        CHECK(blueish(good));
        CHECK(orange(bad));
    }
    // Without the distinct colour the two columns look alike.
    opts.back_faces_distinct = false;
    const pcp::Image plain = pcp::render({{flipped(unit_cube()), {}, ""}}, opts);
    CHECK(blueish(plain.pixel(32, 32)));

    // An open sheet seen from behind: the unit square (normal +z) from the back view.
    opts.back_faces_distinct = true;
    opts.views = {pcp::View{0, 0}, pcp::View{180, 0}};
    const pcp::Image sheet = pcp::render({{pcp::test::unit_square(), {}, ""}}, opts);
    CHECK(blueish(sheet.pixel(32, 32)));
    CHECK(orange(sheet.pixel(32, 64 + 32)));
}

// Faces that share an edge leave no crack: a flat square cut into 8 x 8 cells of two triangles each
// (shared edges along the rows, the columns and the diagonals, many through pixel centres), drawn
// from the front and the back at several panel sizes, has no background pixel inside its outline.
// Before the edge function was made exactly antisymmetric, rounding (a fused multiply-add, another
// base point) gave a pixel centre on a shared edge a small negative value in both faces: under clang
// the unit square's diagonal left the back view's middle pixel empty.
TEST_CASE("render: faces that share an edge leave no crack between them", "[render]") {
    const int n = 8;
    pcp::Mesh grid;
    grid.vertices.resize((n + 1) * (n + 1), 3);
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) grid.vertices.row(j * (n + 1) + i) << double(i) / n, double(j) / n, 0;
    grid.faces.resize(2 * n * n, 3);
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const int v = j * (n + 1) + i, f = 2 * (j * n + i);
            grid.faces.row(f) << v, v + 1, v + n + 2;
            grid.faces.row(f + 1) << v, v + n + 2, v + n + 1;
        }
    pcp::RenderOptions opts;
    opts.labels = false;
    opts.views = {pcp::View{0, 0}, pcp::View{180, 0}};
    int cracks = 0, panels = 0;
    for (int size = 60; size <= 72; ++size) {
        opts.view_size = size;
        const pcp::Image img = pcp::render({pcp::RenderItem{grid, {}, ""}}, opts);
        for (int v = 0; v < 2; ++v) {
            // The square's extent in this panel, then every pixel inside it (one pixel in from
            // the outline) is drawn.
            auto drawn = [&](int x, int y) {
                const std::uint8_t* px = img.pixel(x, v * size + y);
                return !same(px, pcp::RenderPalette::background) && !same(px, pcp::RenderPalette::separator);
            };
            int x_lo = size, x_hi = -1, y_lo = size, y_hi = -1;
            for (int y = 0; y < size; ++y)
                for (int x = 0; x < size; ++x)
                    if (drawn(x, y)) x_lo = std::min(x_lo, x), x_hi = std::max(x_hi, x), y_lo = std::min(y_lo, y), y_hi = std::max(y_hi, y);
            REQUIRE(x_hi - x_lo > 20);
            ++panels;
            for (int y = y_lo + 1; y < y_hi; ++y)
                for (int x = x_lo + 1; x < x_hi; ++x)
                    if (!drawn(x, y)) {
                        UNSCOPED_INFO("panel size " << size << ", view " << v << ": empty pixel " << x << ", " << y);
                        ++cracks;
                    }
        }
    }
    CHECK(panels == 26);
    CHECK(cracks == 0);
}

TEST_CASE("render: a section through a closed cube shows its inside in the back-face colour", "[render]") {
    // Cut through the centre, the near half is gone and the camera looks at the inside of the far
    // faces: back faces (orange). A section behind the whole cube leaves nothing; out of range throws.
    pcp::RenderOptions opts;
    opts.view_size = 64;
    opts.section = 0;
    const pcp::Image cut = pcp::render({{unit_cube(), {}, ""}}, opts);
    for (int v = 0; v < 3; ++v) {
        INFO("view " << v);
        CHECK(orange(cut.pixel(32, v * 64 + 32)));
    }
    opts.section = -1;
    const pcp::Image none = pcp::render({{unit_cube(), {}, ""}}, opts);
    CHECK(same(none.pixel(32, 32), pcp::RenderPalette::background));
    opts.section = 1.5;
    CHECK_THROWS_AS(pcp::render({{unit_cube(), {}, ""}}, opts), pcp::Error);
}

TEST_CASE("render: points draw depth-coloured splats, items share one frame", "[render]") {
    pcp::Points pts(200, 3);
    for (int i = 0; i < 200; ++i) pts.row(i) << (i % 20) / 19.0, (i / 20) / 9.0, 0.5;
    pcp::RenderOptions opts;
    opts.view_size = 64;
    opts.labels = false;
    const pcp::Image img = pcp::render({{{}, pts, "pts"}}, opts);
    int drawn = 0;
    for (int y = 0; y < 64; ++y)
        for (int x = 0; x < 64; ++x)
            if (!same(img.pixel(x, y), pcp::RenderPalette::background)) ++drawn;
    CHECK(drawn > 100);
    CHECK(drawn < 64 * 64);

    // A small cube beside a large one: the small one occupies fewer pixels in its column because
    // both columns use the union frame.
    pcp::Mesh small = unit_cube();
    pcp::Mesh big = unit_cube();
    big.vertices *= 4.0;
    const pcp::Image pair = pcp::render({{small, {}, ""}, {big, {}, ""}}, opts);
    int small_px = 0, big_px = 0;
    for (int y = 0; y < 64; ++y)
        for (int x = 1; x < 63; ++x) {
            small_px += !same(pair.pixel(x, y), pcp::RenderPalette::background);
            big_px += !same(pair.pixel(64 + x, y), pcp::RenderPalette::background);
        }
    CHECK(small_px > 0);
    CHECK(big_px > 8 * small_px);
}

TEST_CASE("render: bad items and options throw pcp::Error saying what is wrong", "[render]") {
    CHECK_THROWS_WITH(pcp::render({}), Catch::Contains("no items"));
    pcp::Mesh broken = unit_cube();
    broken.faces(3, 1) = 8;
    CHECK_THROWS_WITH(pcp::render({{broken, {}, "gt"}}), Catch::Contains("item 0 ('gt'): a face index is out of range"));
    pcp::RenderOptions opts;
    opts.view_size = 4;
    CHECK_THROWS_WITH(pcp::render({{unit_cube(), {}, ""}}, opts), Catch::Contains("view_size"));
}

TEST_CASE("render: write_png round-trips through libpng", "[render]") {
    pcp::Image img;
    img.width = 7;
    img.height = 5;
    img.rgb.resize(7 * 5 * 3);
    for (std::size_t i = 0; i < img.rgb.size(); ++i) img.rgb[i] = static_cast<std::uint8_t>((i * 37 + 11) % 256);
    const fs::path path = tmp_dir("png") / "small.png";
    pcp::write_png(path.string(), img);

    // Signature and IHDR size straight from the bytes, then a decode with libpng's own reader.
    std::ifstream in(path, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    REQUIRE(bytes.size() > 33);
    CHECK(png_sig_cmp(reinterpret_cast<png_const_bytep>(bytes.data()), 0, 8) == 0);
    CHECK(bytes.substr(12, 4) == "IHDR");
    auto be32 = [&](std::size_t at) {
        return (std::uint32_t(std::uint8_t(bytes[at])) << 24) | (std::uint32_t(std::uint8_t(bytes[at + 1])) << 16) |
               (std::uint32_t(std::uint8_t(bytes[at + 2])) << 8) | std::uint32_t(std::uint8_t(bytes[at + 3]));
    };
    CHECK(be32(16) == 7);
    CHECK(be32(20) == 5);

    png_image png{};
    png.version = PNG_IMAGE_VERSION;
    REQUIRE(png_image_begin_read_from_file(&png, path.c_str()) != 0);
    png.format = PNG_FORMAT_RGB;
    std::vector<std::uint8_t> decoded(PNG_IMAGE_SIZE(png));
    REQUIRE(png_image_finish_read(&png, nullptr, decoded.data(), 0, nullptr) != 0);
    CHECK(decoded == img.rgb);

    const pcp::Image back = pcp::read_png(path.string());
    CHECK(back.width == 7);
    CHECK(back.height == 5);
    CHECK(back.rgb == img.rgb);
    CHECK(pcp::encode_png(img) == std::vector<std::uint8_t>(bytes.begin(), bytes.end()));
    // No temporary file left next to it.
    int files = 0;
    for ([[maybe_unused]] const auto& e : fs::directory_iterator(path.parent_path())) ++files;
    CHECK(files == 1);
}

TEST_CASE("render: write_png to an unwritable directory throws naming the path, leaves nothing", "[render]") {
    pcp::Image img;
    img.width = img.height = 2;
    img.rgb.assign(12, 100);
    const fs::path dir = tmp_dir("locked");
    const fs::path locked = dir / "locked";
    fs::create_directories(locked);
    const bool root = ::geteuid() == 0;
    if (root) REQUIRE(std::system(("chattr +i '" + locked.string() + "' 2>/dev/null").c_str()) == 0);
    else fs::permissions(locked, fs::perms::owner_read | fs::perms::owner_exec);
    const std::string target = (locked / "out.png").string();
    bool threw = false;
    try {
        pcp::write_png(target, img);
    } catch (const pcp::Error& e) {
        threw = true;
        CHECK(std::string(e.what()).find(target) != std::string::npos);
    }
    if (root) std::system(("chattr -i '" + locked.string() + "'").c_str());
    else fs::permissions(locked, fs::perms::owner_all);
    CHECK(threw);
    CHECK(fs::is_empty(locked));

    CHECK_THROWS_WITH(pcp::write_png((dir / "no_such_dir" / "x.png").string(), img), Catch::Contains("no_such_dir"));
    pcp::Image empty;
    CHECK_THROWS_AS(pcp::write_png((dir / "empty.png").string(), empty), pcp::Error);
    CHECK(!fs::exists(dir / "empty.png"));
}
