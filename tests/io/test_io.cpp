// Tests for pcp/io.hpp: round trips for every format, hand-rolled PLY files of every scalar type
// in ascii, binary little endian and binary big endian with elements in any order, text and
// NumPy variants, and one test per bad-input case checking that the message names the file and
// the problem. Every fixture is generated here under PCP_TEST_TMP_DIR.
#include "pcp/core/error.hpp"
#include "pcp/io/io.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <random>
#include <sstream>

namespace fs = std::filesystem;
using Catch::Contains;

namespace {

fs::path tmp_dir(const std::string& name) {
    fs::path dir = fs::path(PCP_TEST_TMP_DIR) / ("io_" + name);
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}

std::string put_file(const fs::path& path, const std::string& bytes) {
    std::ofstream(path, std::ios::binary) << bytes;
    return path.string();
}

std::string slurp(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::size_t entries(const fs::path& dir) {
    return static_cast<std::size_t>(std::distance(fs::directory_iterator(dir), fs::directory_iterator()));
}

// The message of the pcp::Error that `f` throws, or a marker if it throws nothing.
std::string error_of(const std::function<void()>& f) {
    try {
        f();
    } catch (const pcp::Error& e) {
        return e.what();
    }
    return "<no pcp::Error thrown>";
}

// Matches a one-line message naming the file and the problem.
class NamesMatcher : public Catch::MatcherBase<std::string> {
public:
    NamesMatcher(std::string path, std::string problem) : path_(std::move(path)), problem_(std::move(problem)) {}
    bool match(const std::string& s) const override {
        return s.find(path_) != std::string::npos && s.find(problem_) != std::string::npos &&
               s.find('\n') == std::string::npos;
    }
    std::string describe() const override {
        return "is one line naming '" + path_ + "' and containing '" + problem_ + "'";
    }

private:
    std::string path_, problem_;
};

NamesMatcher names(const std::string& path, const std::string& problem) { return {path, problem}; }

pcp::PointCloud random_cloud(int n, std::uint32_t seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> normal(0.0, 1.0);
    pcp::PointCloud cloud;
    cloud.points.resize(n, 3);
    for (int i = 0; i < n; ++i)
        for (int c = 0; c < 3; ++c) cloud.points(i, c) = 1e3 * normal(rng) + 1.0 / 3.0;
    if (n > 2) {  // values that a lossy writer would break
        cloud.points.row(0) << 1e300, -0.0, std::numeric_limits<double>::denorm_min();
        cloud.points.row(1) << 123456789.123456789, -1e-300, 0.1;
    }
    for (const char* name : {"nx", "ny", "nz", "sdf"}) {
        Eigen::VectorXd v(n);
        for (int i = 0; i < n; ++i) v(i) = normal(rng);
        cloud.properties[name] = v;
    }
    return cloud;
}

pcp::Mesh random_mesh(std::uint32_t seed) {
    pcp::PointCloud c = random_cloud(40, seed);
    pcp::Mesh mesh;
    mesh.vertices = c.points;
    mesh.faces.resize(60, 3);
    std::mt19937 rng(seed + 1);
    std::uniform_int_distribution<int> pick(0, 39);
    for (int f = 0; f < 60; ++f)
        for (int k = 0; k < 3; ++k) mesh.faces(f, k) = pick(rng);
    return mesh;
}

// Writes PLY values by type name, as ascii tokens or as binary of either byte order (the host
// is little endian; a static_assert in the test guards that).
struct PlyBytes {
    enum Kind { Ascii, LE, BE } kind;
    std::string s;

    template <class T>
    void raw(T v) {
        unsigned char b[sizeof(T)];
        std::memcpy(b, &v, sizeof(T));
        if (kind == BE) std::reverse(b, b + sizeof(T));
        s.append(reinterpret_cast<const char*>(b), sizeof(T));
    }
    void val(const std::string& type, double v) {
        if (kind == Ascii) {
            std::ostringstream o;
            o.precision(17);
            o << v << ' ';
            s += o.str();
        } else if (type == "char" || type == "int8") raw(static_cast<std::int8_t>(v));
        else if (type == "uchar" || type == "uint8") raw(static_cast<std::uint8_t>(v));
        else if (type == "short" || type == "int16") raw(static_cast<std::int16_t>(v));
        else if (type == "ushort" || type == "uint16") raw(static_cast<std::uint16_t>(v));
        else if (type == "int" || type == "int32") raw(static_cast<std::int32_t>(v));
        else if (type == "uint" || type == "uint32") raw(static_cast<std::uint32_t>(v));
        else if (type == "float" || type == "float32") raw(static_cast<float>(v));
        else raw(v);
    }
    void end_row() {
        if (kind == Ascii) s += '\n';
    }
};

const char* format_name(PlyBytes::Kind k) {
    return k == PlyBytes::Ascii ? "ascii" : k == PlyBytes::LE ? "binary_little_endian" : "binary_big_endian";
}

// A PLY with elements camera (list), face (lists, one quad), vertex (every scalar type, a list
// property, coordinates of type `coord`), tail: vertex is neither first nor last.
std::string every_type_ply(PlyBytes::Kind kind, const std::string& coord) {
    PlyBytes b{kind, {}};
    b.s = std::string("ply\nformat ") + format_name(kind) +
          " 1.0\ncomment hand-rolled by test_io\nobj_info nothing\n"
          "element camera 2\nproperty float32 fx\nproperty list uint8 int32 ids\n"
          "element face 2\nproperty uchar flags\nproperty list uchar int vertex_indices\n"
          "element vertex 3\n"
          "property char a\nproperty uchar b\nproperty short c\nproperty ushort d\n"
          "property int e\nproperty uint f\nproperty " + coord + " x\nproperty " + coord + " y\n"
          "property list ushort uint idx\nproperty " + coord + " z\n"
          "property int8 g\nproperty uint16 h\nproperty float32 nx\nproperty float64 sdf\n"
          "element tail 1\nproperty double w\nend_header\n";
    b.val("float", 1.5), b.val("uint8", 3), b.val("int32", 1), b.val("int32", 2), b.val("int32", 3), b.end_row();
    b.val("float", 2.5), b.val("uint8", 0), b.end_row();
    b.val("uchar", 9), b.val("uchar", 3), b.val("int", 0), b.val("int", 1), b.val("int", 2), b.end_row();
    b.val("uchar", 9), b.val("uchar", 4);
    for (int v : {0, 1, 2, 1}) b.val("int", v);
    b.end_row();
    for (int i = 0; i < 3; ++i) {
        b.val("char", -1 - i), b.val("uchar", 200 + i), b.val("short", -300 - i), b.val("ushort", 60000 + i);
        b.val("int", -70000 - i), b.val("uint", 4000000000.0 + i);
        b.val(coord, i + 1), b.val(coord, 2 * i);
        b.val("ushort", i);
        for (int k = 0; k < i; ++k) b.val("uint", 7);
        b.val(coord, 3 * i + 5);
        b.val("int8", -100 + i), b.val("uint16", 1000 + i), b.val("float32", 0.25 * i), b.val("float64", 0.1 * i);
        b.end_row();
    }
    b.val("double", 7.0), b.end_row();
    return b.s;
}

void check_every_type_cloud(const pcp::PointCloud& cloud) {
    REQUIRE(cloud.points.rows() == 3);
    for (int i = 0; i < 3; ++i) {
        CHECK(cloud.points(i, 0) == i + 1);
        CHECK(cloud.points(i, 1) == 2 * i);
        CHECK(cloud.points(i, 2) == 3 * i + 5);
        CHECK(cloud.properties.at("a")(i) == -1 - i);
        CHECK(cloud.properties.at("b")(i) == 200 + i);
        CHECK(cloud.properties.at("c")(i) == -300 - i);
        CHECK(cloud.properties.at("d")(i) == 60000 + i);
        CHECK(cloud.properties.at("e")(i) == -70000 - i);
        CHECK(cloud.properties.at("f")(i) == 4000000000.0 + i);
        CHECK(cloud.properties.at("g")(i) == -100 + i);
        CHECK(cloud.properties.at("h")(i) == 1000 + i);
        CHECK(cloud.properties.at("nx")(i) == 0.25 * i);
        CHECK(cloud.properties.at("sdf")(i) == 0.1 * i);
    }
    CHECK(cloud.properties.size() == 10);  // a..h, nx, sdf; not x/y/z, not the list idx
}

// A minimal valid PLY (3 float vertices) in the given format, with `count` declared.
std::string small_ply(PlyBytes::Kind kind, const std::string& count = "3") {
    PlyBytes b{kind, {}};
    b.s = std::string("ply\nformat ") + format_name(kind) + " 1.0\nelement vertex " + count +
          "\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
    for (int i = 0; i < 3; ++i) {
        for (int c = 0; c < 3; ++c) b.val("float", i + 0.5 * c);
        b.end_row();
    }
    return b.s;
}

// A .npy file of `rows` x `cols` values v(i, c) = i * 10 + c + 0.5.
// `shape` overrides the declared shape text.
std::string make_npy(char endian, int item, bool fortran, int rows, int cols, int version = 1,
                     const std::string& shape = "") {
    std::string dict = std::string("{'descr': '") + endian + 'f' + std::to_string(item) +
                       "', 'fortran_order': " + (fortran ? "True" : "False") + ", 'shape': " +
                       (shape.empty() ? "(" + std::to_string(rows) + ", " + std::to_string(cols) + ")" : shape) +
                       ", }";
    const std::size_t pre = version == 1 ? 10 : 12;
    dict.append((64 - (pre + dict.size() + 1) % 64) % 64, ' ');
    dict += '\n';
    PlyBytes b{endian == '>' ? PlyBytes::BE : PlyBytes::LE, std::string("\x93NUMPY", 6)};
    b.s += static_cast<char>(version);
    b.s += '\0';
    if (version == 1) b.raw(static_cast<std::uint16_t>(dict.size()));
    else b.raw(static_cast<std::uint32_t>(dict.size()));
    if (b.kind == PlyBytes::BE) {  // header length is always little endian
        const std::size_t n = version == 1 ? 2 : 4;
        std::reverse(b.s.end() - static_cast<std::ptrdiff_t>(n), b.s.end());
    }
    b.s += dict;
    for (int k = 0; k < rows * cols; ++k) {
        const int i = fortran ? k % rows : k / cols;
        const int c = fortran ? k / rows : k % cols;
        b.val(item == 4 ? "float" : "double", i * 10 + c + 0.5);
    }
    return b.s;
}

}  // namespace

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "the hand-rolled fixtures assume a little-endian host");

// ---- round trips ----

TEST_CASE("io: binary PLY point cloud round-trips bit-exactly", "[io]") {
    const fs::path dir = tmp_dir("ply_binary_rt");
    const std::string path = (dir / "cloud.ply").string();
    const pcp::PointCloud cloud = random_cloud(500, 42);
    pcp::write_point_cloud(path, cloud);
    CHECK(slurp(path).rfind("ply\nformat binary_little_endian 1.0\n", 0) == 0);
    const pcp::PointCloud back = pcp::read_point_cloud(path);
    CHECK(back.points == cloud.points);
    CHECK(std::signbit(back.points(0, 1)));
    REQUIRE(back.properties.size() == cloud.properties.size());
    for (const auto& [name, values] : cloud.properties) CHECK(back.properties.at(name) == values);
    CHECK(entries(dir) == 1);
}

TEST_CASE("io: ascii PLY point cloud round-trips exactly", "[io]") {
    const fs::path dir = tmp_dir("ply_ascii_rt");
    const std::string path = (dir / "cloud.ply").string();
    const pcp::PointCloud cloud = random_cloud(200, 7);
    pcp::write_point_cloud(path, cloud, true);
    CHECK(slurp(path).rfind("ply\nformat ascii 1.0\n", 0) == 0);
    const pcp::PointCloud back = pcp::read_point_cloud(path);
    CHECK(back.points == cloud.points);
    for (const auto& [name, values] : cloud.properties) CHECK(back.properties.at(name) == values);
}

TEST_CASE("io: PLY of every scalar type in ascii, little and big endian, vertex among other elements",
          "[io]") {
    const fs::path dir = tmp_dir("ply_every_type");
    const char* types[] = {"char",  "uchar",  "short", "ushort",  "int",     "uint",
                           "float", "double", "int8",  "uint8",   "int16",   "uint16",
                           "int32", "uint32", "float32", "float64"};
    for (PlyBytes::Kind kind : {PlyBytes::Ascii, PlyBytes::LE, PlyBytes::BE})
        for (const char* coord : types) {
            INFO(format_name(kind) << " with " << coord << " coordinates");
            const std::string path = put_file(dir / "every.ply", every_type_ply(kind, coord));
            check_every_type_cloud(pcp::read_point_cloud(path));
            const pcp::Mesh mesh = pcp::read_mesh(path);
            CHECK(mesh.vertices.rows() == 3);
            REQUIRE(mesh.faces.rows() == 3);  // a triangle and a fan-triangulated quad
            CHECK(mesh.faces.row(0) == Eigen::RowVector3i(0, 1, 2));
            CHECK(mesh.faces.row(1) == Eigen::RowVector3i(0, 1, 2));
            CHECK(mesh.faces.row(2) == Eigen::RowVector3i(0, 2, 1));
        }
}

TEST_CASE("io: ascii PLY with CRLF lines, comments and one value per line", "[io]") {
    const fs::path dir = tmp_dir("ply_crlf");
    const std::string path = put_file(
        dir / "crlf.ply",
        "ply\r\nformat ascii 1.0\r\ncomment hello\r\nelement vertex 2\r\nproperty double x\r\n"
        "property double y\r\nproperty double z\r\nend_header\r\n1\r\n2\r\n3\r\n-4e-2 +5 6.5\r\n");
    const pcp::PointCloud cloud = pcp::read_point_cloud(path);
    REQUIRE(cloud.points.rows() == 2);
    CHECK(cloud.points.row(0) == Eigen::RowVector3d(1, 2, 3));
    CHECK(cloud.points.row(1) == Eigen::RowVector3d(-4e-2, 5, 6.5));
}

TEST_CASE("io: duplicate points and an empty vertex element are accepted", "[io]") {
    const fs::path dir = tmp_dir("ply_dupes");
    const std::string path = put_file(dir / "dup.xyz", "1 2 3\n1 2 3\n1 2 3\n");
    CHECK(pcp::read_point_cloud(path).points.rows() == 3);
    const std::string empty = put_file(
        dir / "empty.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 0\nproperty float x\n"
                           "property float y\nproperty float z\nend_header\n");
    CHECK(pcp::read_point_cloud(empty).points.rows() == 0);
}

TEST_CASE("io: xyz round trip keeps normals and exact values", "[io]") {
    const fs::path dir = tmp_dir("xyz_rt");
    const std::string path = (dir / "cloud.xyz").string();
    pcp::PointCloud cloud = random_cloud(300, 3);
    cloud.properties.erase("sdf");
    pcp::write_point_cloud(path, cloud);
    const pcp::PointCloud back = pcp::read_point_cloud(path);
    CHECK(back.points == cloud.points);
    REQUIRE(back.properties.size() == 3);
    for (const char* n : {"nx", "ny", "nz"}) CHECK(back.properties.at(n) == cloud.properties.at(n));
}

TEST_CASE("io: text point tables: separators, comments, column counts, .pts count line", "[io]") {
    const fs::path dir = tmp_dir("xyz_variants");
    const std::string txt = put_file(dir / "a.txt",
                                     "# header comment\n// another\n\n 1,2,3 ,4\n\t5 6 7 8\r\n\n9, 10, 11, 12\n");
    const pcp::PointCloud a = pcp::read_point_cloud(txt);
    REQUIRE(a.points.rows() == 3);
    CHECK(a.points.row(2) == Eigen::RowVector3d(9, 10, 11));
    REQUIRE(a.properties.size() == 1);
    CHECK(a.properties.at("c3") == Eigen::Vector3d(4, 8, 12));

    const std::string pts = put_file(dir / "b.pts", "2\n0 0 0 1 1 1 1\n1 1 1 2 2 2 2\n");
    const pcp::PointCloud b = pcp::read_point_cloud(pts);
    REQUIRE(b.points.rows() == 2);
    CHECK(b.properties.size() == 4);  // c3..c6
    CHECK(b.properties.at("c6")(1) == 2);

    const std::string plain = put_file(dir / "c.xyz", "0.5 -1.5 2e3\n");
    const pcp::PointCloud c = pcp::read_point_cloud(plain);
    CHECK(c.points.row(0) == Eigen::RowVector3d(0.5, -1.5, 2e3));
    CHECK(c.properties.empty());
    // The count line is a .pts feature only.
    CHECK_THAT(error_of([&] { pcp::read_point_cloud(put_file(dir / "d.xyz", "2\n0 0 0\n1 1 1\n")); }),
               names("d.xyz", "line 1: expected at least 3 columns"));
}

TEST_CASE("io: npy round trip and every dtype/order/version variant", "[io]") {
    const fs::path dir = tmp_dir("npy");
    const std::string path = (dir / "cloud.npy").string();
    pcp::PointCloud cloud = random_cloud(100, 11);
    cloud.properties.erase("sdf");
    pcp::write_point_cloud(path, cloud);
    const pcp::PointCloud back = pcp::read_point_cloud(path);
    CHECK(back.points == cloud.points);
    for (const char* n : {"nx", "ny", "nz"}) CHECK(back.properties.at(n) == cloud.properties.at(n));
    const std::string bytes = slurp(path);
    CHECK(bytes.find('\n') + 1 == 128);  // header padded to a 64-byte boundary

    for (char endian : {'<', '>'})
        for (int item : {4, 8})
            for (bool fortran : {false, true})
                for (int version : {1, 2, 3})
                    for (int cols : {3, 5, 6}) {
                        INFO(endian << "f" << item << (fortran ? " F" : " C") << " v" << version
                                    << " cols " << cols);
                        const std::string p =
                            put_file(dir / "v.npy", make_npy(endian, item, fortran, 4, cols, version));
                        const pcp::PointCloud v = pcp::read_point_cloud(p);
                        REQUIRE(v.points.rows() == 4);
                        for (int i = 0; i < 4; ++i)
                            for (int c = 0; c < 3; ++c) CHECK(v.points(i, c) == i * 10 + c + 0.5);
                        if (cols == 6) {
                            CHECK(v.properties.at("nz")(3) == 35.5);
                        } else if (cols == 5) {
                            CHECK(v.properties.at("c4")(2) == 24.5);
                        } else {
                            CHECK(v.properties.empty());
                        }
                    }
}

TEST_CASE("io: mesh round trips through ply (binary, ascii), obj and off", "[io]") {
    const fs::path dir = tmp_dir("mesh_rt");
    const pcp::Mesh mesh = random_mesh(5);
    for (const char* name : {"m.ply", "m_ascii.ply", "m.obj", "m.off"}) {
        INFO(name);
        const std::string path = (dir / name).string();
        pcp::MeshWriteOptions opts;
        opts.ascii = std::string(name) == "m_ascii.ply";
        pcp::write_mesh(path, mesh, opts);
        const pcp::Mesh back = pcp::read_mesh(path);
        CHECK(back.vertices == mesh.vertices);
        CHECK(back.faces == mesh.faces);
    }
    CHECK(entries(dir) == 4);
    // Fewer digits on request, in text formats.
    pcp::MeshWriteOptions coarse;
    coarse.precision = 6;
    const std::string obj = (dir / "coarse.obj").string();
    pcp::write_mesh(obj, mesh, coarse);
    const pcp::Mesh approx = pcp::read_mesh(obj);
    CHECK(approx.vertices != mesh.vertices);
    CHECK(approx.vertices.isApprox(mesh.vertices, 1e-5));
}

TEST_CASE("io: obj with slashes, negative indices, polygons and ignored lines", "[io]") {
    const fs::path dir = tmp_dir("obj");
    const std::string path = put_file(dir / "q.obj",
                                      "# comment\nmtllib x.mtl\no quad\nv 0 0 0\nv 1 0 0\nv 1 1 0 1.0\n"
                                      "v 0 1 0 0.5 0.5 0.5\nvt 0 0\nvn 0 0 1\ng g1\nusemtl m\ns off\n"
                                      "f 1/1/1 2/2/1 3/3/1 4/4/1\nf -4//1 -3//1 -2//1\nf 1/1 3/3 4/4\n"
                                      "l 1 2\n");
    const pcp::Mesh m = pcp::read_mesh(path);
    CHECK(m.vertices.rows() == 4);
    REQUIRE(m.faces.rows() == 4);
    CHECK(m.faces.row(0) == Eigen::RowVector3i(0, 1, 2));
    CHECK(m.faces.row(1) == Eigen::RowVector3i(0, 2, 3));
    CHECK(m.faces.row(2) == Eigen::RowVector3i(0, 1, 2));
    CHECK(m.faces.row(3) == Eigen::RowVector3i(0, 2, 3));
    // Faces may come before the vertices they use.
    const pcp::Mesh fwd = pcp::read_mesh(put_file(dir / "fwd.obj", "f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n"));
    CHECK(fwd.faces.rows() == 1);
}

TEST_CASE("io: off with COFF colours, comments, a quad and counts on the header line", "[io]") {
    const fs::path dir = tmp_dir("off");
    const pcp::Mesh m = pcp::read_mesh(put_file(
        dir / "c.off", "COFF\n# comment\n4 2 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n1 1 0 0 0 255 255\n"
                       "0 1 0 9 9 9 255\n\n4 0 1 2 3 200 0 0\n3 0 2 3\n"));
    CHECK(m.vertices.rows() == 4);
    REQUIRE(m.faces.rows() == 3);
    CHECK(m.faces.row(1) == Eigen::RowVector3i(0, 2, 3));
    const pcp::Mesh one = pcp::read_mesh(put_file(dir / "h.off", "OFF 3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"));
    CHECK(one.faces.rows() == 1);
}

// ---- bad input: one test per case ----

TEST_CASE("io: missing file", "[io]") {
    const fs::path dir = tmp_dir("err_missing");
    const std::string path = (dir / "nothere.ply").string();
    CHECK_THAT(error_of([&] { pcp::read_point_cloud(path); }), names("nothere.ply", "cannot open file"));
    CHECK_THAT(error_of([&] { pcp::read_mesh((dir / "nothere.obj").string()); }),
               names("nothere.obj", "No such file"));
}

TEST_CASE("io: unreadable file (a directory)", "[io]") {
    const fs::path dir = tmp_dir("err_dir");
    fs::create_directories(dir / "cloud.ply");
    CHECK_THAT(error_of([&] { pcp::read_point_cloud((dir / "cloud.ply").string()); }),
               names("cloud.ply", "is a directory"));
}

TEST_CASE("io: empty file", "[io]") {
    const fs::path dir = tmp_dir("err_empty");
    for (const char* name : {"e.ply", "e.xyz", "e.npy", "e.obj"}) {
        const std::string path = put_file(dir / name, "");
        const bool mesh = std::string(name) == "e.obj";
        CHECK_THAT(error_of([&] { mesh ? (void)pcp::read_mesh(path) : (void)pcp::read_point_cloud(path); }),
                   names(name, "file is empty"));
    }
}

TEST_CASE("io: a PLY with zero vertices reads as an empty cloud", "[io][fuzz]") {
    // Found by tests/fuzz/fuzz_ply.cpp: UBSan reported pointer arithmetic on the null data of the
    // empty point matrix.
    const fs::path dir = tmp_dir("zero_vertices");
    const std::string path = put_file(dir / "z.ply",
                                      "ply\nformat ascii 1.0\nelement vertex 0\nproperty double x\nproperty double y\n"
                                      "property double z\nproperty float nx\nend_header\n");
    const pcp::PointCloud cloud = pcp::read_point_cloud(path);
    CHECK(cloud.points.rows() == 0);
}

TEST_CASE("io: a PLY list length beyond any integer is an error, not an overflow", "[io][fuzz]") {
    // Found by tests/fuzz/fuzz_ply.cpp: UBSan reported the conversion of a list length of 8.9e68
    // (a float count type, or an ascii token) to an integer.
    const fs::path dir = tmp_dir("huge_list");
    const std::string path = put_file(dir / "l.ply",
                                      "ply\nformat ascii 1.0\nelement vertex 1\nproperty double x\nproperty double y\n"
                                      "property double z\nproperty list uchar int extra\nend_header\n0 0 0 8.9e68 1 2\n");
    CHECK_THAT(error_of([&] { (void)pcp::read_point_cloud(path); }), Contains("invalid list length"));
}

TEST_CASE("io: an .npy shape of millions of columns is refused before naming them", "[io][fuzz]") {
    // Found by the fuzz smoke of fuzz_npy: shape (0, 67108864) passed the size check (no rows)
    // and then 67 million column names were allocated.
    const fs::path dir = tmp_dir("npy_columns");
    std::string header = "{'descr': '<f8', 'fortran_order': False, 'shape': (0, 67108864), }";
    while ((10 + header.size() + 1) % 64 != 0) header += ' ';
    header += '\n';
    std::string bytes = "\x93NUMPY";
    bytes += '\x01';
    bytes += '\x00';
    bytes += static_cast<char>(header.size() & 0xff);
    bytes += static_cast<char>(header.size() >> 8);
    bytes += header;
    const std::string path = put_file(dir / "c.npy", bytes);
    CHECK_THAT(error_of([&] { (void)pcp::read_point_cloud(path); }), Contains("unsupported .npy shape") && Contains("k <= 1024"));
}

TEST_CASE("io: truncated binary body", "[io]") {
    const fs::path dir = tmp_dir("err_truncated");
    for (PlyBytes::Kind kind : {PlyBytes::LE, PlyBytes::BE}) {
        std::string bytes = small_ply(kind);
        bytes.resize(bytes.size() - 5);
        const std::string path = put_file(dir / "cut.ply", bytes);
        CHECK_THAT(error_of([&] { pcp::read_point_cloud(path); }),
                   names("cut.ply", "truncated binary body") && Contains("3 rows of element 'vertex'"));
    }
    // A list element that runs out of bytes in the middle of a row.
    std::string mesh = every_type_ply(PlyBytes::LE, "float");
    const std::size_t body = mesh.find("end_header\n") + 11;
    const std::string cut = put_file(dir / "cut_list.ply", mesh.substr(0, body + 12));
    CHECK_THAT(error_of([&] { pcp::read_point_cloud(cut); }),
               names("cut_list.ply", "truncated binary body") && Contains("element 'camera'"));
    std::string npy = make_npy('<', 8, false, 10, 3);
    npy.resize(npy.size() - 8);
    const std::string np = put_file(dir / "cut.npy", npy);
    CHECK_THAT(error_of([&] { pcp::read_point_cloud(np); }), names("cut.npy", "truncated .npy data"));
}

TEST_CASE("io: header counts that exceed the data (no huge allocation)", "[io]") {
    const fs::path dir = tmp_dir("err_counts");
    const std::string ascii = put_file(dir / "more.ply", small_ply(PlyBytes::Ascii, "5"));
    CHECK_THAT(error_of([&] { pcp::read_point_cloud(ascii); }),
               names("more.ply", "unexpected end of file in row 3 of element 'vertex'") &&
                   Contains("declares 5 rows"));
    // Billions of rows declared: refused from the file size before any allocation.
    for (PlyBytes::Kind kind : {PlyBytes::Ascii, PlyBytes::LE}) {
        const std::string huge = put_file(dir / "huge.ply", small_ply(kind, "4000000000000"));
        CHECK_THAT(error_of([&] { pcp::read_point_cloud(huge); }),
                   names("huge.ply", "declares 4000000000000 rows of element 'vertex'"));
    }
    const std::string npy =
        put_file(dir / "huge.npy", make_npy('<', 4, false, 2, 3, 1, "(9223372036854775807, 3)"));
    CHECK_THAT(error_of([&] { pcp::read_point_cloud(npy); }), names("huge.npy", "truncated .npy data"));
    const std::string off = put_file(dir / "huge.off", "OFF\n4000000000 1 0\n0 0 0\n");
    CHECK_THAT(error_of([&] { pcp::read_mesh(off); }), names("huge.off", "declares 4000000000 vertices"));
    const std::string off2 = put_file(dir / "short.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n");
    CHECK_THAT(error_of([&] { pcp::read_mesh(off2); }),
               names("short.off", "unexpected end of file after 0 faces"));
}

TEST_CASE("io: malformed PLY header", "[io]") {
    const fs::path dir = tmp_dir("err_header");
    const std::string no_end = put_file(
        dir / "noend.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n");
    CHECK_THAT(error_of([&] { pcp::read_point_cloud(no_end); }), names("noend.ply", "no 'end_header' line"));
    const std::string no_end_body = put_file(
        dir / "noend2.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n1 2 3\n");
    CHECK_THAT(error_of([&] { pcp::read_point_cloud(no_end_body); }),
               names("noend2.ply", "line 5") && Contains("end_header"));
    const std::string no_vertex = put_file(
        dir / "novertex.ply", "ply\nformat ascii 1.0\nelement point 1\nproperty float x\nend_header\n1\n");
    CHECK_THAT(error_of([&] { pcp::read_point_cloud(no_vertex); }), names("novertex.ply", "no 'vertex' element"));
    const std::string no_z = put_file(dir / "noz.ply",
                                      "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                                      "property float y\nproperty float w\nend_header\n1 2 3\n");
    CHECK_THAT(error_of([&] { pcp::read_point_cloud(no_z); }), names("noz.ply", "has no 'z' property"));
    const std::string bad_type = put_file(dir / "type.ply",
                                          "ply\nformat ascii 1.0\nelement vertex 1\nproperty float128 x\nend_header\n");
    CHECK_THAT(error_of([&] { pcp::read_point_cloud(bad_type); }), names("type.ply", "line 4: bad property"));
    const std::string bad_format = put_file(dir / "fmt.ply", "ply\nformat binary_middle_endian 1.0\nend_header\n");
    CHECK_THAT(error_of([&] { pcp::read_point_cloud(bad_format); }), names("fmt.ply", "unknown format"));
    const std::string not_ply = put_file(dir / "notply.ply", "solid cube\nfacet normal 0 0 1\n");
    CHECK_THAT(error_of([&] { pcp::read_point_cloud(not_ply); }), names("notply.ply", "not a PLY file"));
    const std::string cloud_only = put_file(dir / "cloud.ply", small_ply(PlyBytes::LE));
    CHECK_THAT(error_of([&] { pcp::read_mesh(cloud_only); }), names("cloud.ply", "no 'face' element"));
}

TEST_CASE("io: non-numeric tokens report the line", "[io]") {
    const fs::path dir = tmp_dir("err_token");
    std::string ply = small_ply(PlyBytes::Ascii);
    ply.replace(ply.rfind("2.5"), 3, "2,5");
    const std::string p = put_file(dir / "tok.ply", ply);
    CHECK_THAT(error_of([&] { pcp::read_point_cloud(p); }), names("tok.ply", "line 10: non-numeric value '2,5'"));
    const std::string x = put_file(dir / "tok.xyz", "1 2 3\n# ok\n4 five 6\n");
    CHECK_THAT(error_of([&] { pcp::read_point_cloud(x); }), names("tok.xyz", "line 3: non-numeric value 'five'"));
    const std::string o = put_file(dir / "tok.obj", "v 0 0 0\nv 1 0 x\n");
    CHECK_THAT(error_of([&] { pcp::read_mesh(o); }), names("tok.obj", "line 2: non-numeric value 'x'"));
    const std::string f = put_file(dir / "idx.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 three\n");
    CHECK_THAT(error_of([&] { pcp::read_mesh(f); }), names("idx.obj", "line 4: bad vertex index 'three'"));
    const std::string off = put_file(dir / "tok.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 zero\n3 0 1 2\n");
    CHECK_THAT(error_of([&] { pcp::read_mesh(off); }), names("tok.off", "line 5: non-numeric value 'zero'"));
    const std::string cols = put_file(dir / "cols.xyz", "1 2 3\n4 5 6 7\n");
    CHECK_THAT(error_of([&] { pcp::read_point_cloud(cols); }), names("cols.xyz", "line 2: found 4 columns"));
}

TEST_CASE("io: NaN and Inf coordinates name the point or line", "[io]") {
    const fs::path dir = tmp_dir("err_nan");
    std::string ply = small_ply(PlyBytes::Ascii);
    ply.replace(ply.rfind("1.5"), 3, "nan");
    const std::string a = put_file(dir / "nan.ply", ply);
    CHECK_THAT(error_of([&] { pcp::read_point_cloud(a); }),
               names("nan.ply", "line 9: vertex 1 has a non-finite coordinate"));
    PlyBytes b{PlyBytes::BE, small_ply(PlyBytes::BE, "4")};
    b.val("float", 0), b.val("float", std::numeric_limits<float>::infinity()), b.val("float", 0);
    const std::string bin = put_file(dir / "inf.ply", b.s);
    CHECK_THAT(error_of([&] { pcp::read_point_cloud(bin); }),
               names("inf.ply", "vertex 3 has a non-finite coordinate (0, inf, 0)"));
    const std::string x = put_file(dir / "inf.xyz", "1 2 3\n-inf 0 0\n");
    CHECK_THAT(error_of([&] { pcp::read_point_cloud(x); }), names("inf.xyz", "line 2: non-finite coordinate"));
    std::string npy = make_npy('<', 8, false, 3, 3);
    const double nan = std::numeric_limits<double>::quiet_NaN();
    std::memcpy(&npy[npy.size() - 8], &nan, 8);
    const std::string n = put_file(dir / "nan.npy", npy);
    CHECK_THAT(error_of([&] { pcp::read_point_cloud(n); }), names("nan.npy", "point 2 has a non-finite coordinate"));
    const std::string o = put_file(dir / "nan.obj", "v 0 0 0\nv NaN 0 0\n");
    CHECK_THAT(error_of([&] { pcp::read_mesh(o); }), names("nan.obj", "line 2: non-finite coordinate"));
}

TEST_CASE("io: unknown extension lists the supported ones and writes nothing", "[io]") {
    const fs::path dir = tmp_dir("err_ext");
    const std::string pcd = put_file(dir / "cloud.pcd", "whatever");
    CHECK_THAT(error_of([&] { pcp::read_point_cloud(pcd); }),
               names("cloud.pcd", "unsupported point cloud extension '.pcd'") &&
                   Contains(".ply, .xyz, .txt, .pts, .npy"));
    CHECK_THAT(error_of([&] { pcp::read_mesh((dir / "m.stl").string()); }),
               names("m.stl", "unsupported mesh extension '.stl' (supported: .ply, .obj, .off)"));
    CHECK_THAT(error_of([&] { pcp::write_mesh((dir / "m.stl").string(), random_mesh(1)); }),
               names("m.stl", "supported: .ply, .obj, .off"));
    CHECK_THAT(error_of([&] { pcp::write_point_cloud((dir / "c.txt").string(), random_cloud(5, 1)); }),
               names("c.txt", "supported: .ply, .xyz, .npy"));
    CHECK(entries(dir) == 1);
}

TEST_CASE("io: face indices out of range", "[io]") {
    const fs::path dir = tmp_dir("err_faces");
    const std::string ply = put_file(dir / "f.ply",
                                     "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                     "property float z\nelement face 2\nproperty list uchar int vertex_indices\n"
                                     "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 3\n");
    CHECK_THAT(error_of([&] { pcp::read_mesh(ply); }),
               names("f.ply", "line 14: face 1 refers to vertex 3 but the file has 3 vertices"));
    const std::string two = put_file(dir / "two.ply",
                                     "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                     "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                                     "end_header\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n");
    CHECK_THAT(error_of([&] { pcp::read_mesh(two); }), names("two.ply", "face 0 has 2 vertices"));
    const std::string obj = put_file(dir / "f.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 4\n");
    CHECK_THAT(error_of([&] { pcp::read_mesh(obj); }),
               names("f.obj", "line 5: face refers to vertex 4 but the file has 3 vertices"));
    const std::string neg = put_file(dir / "neg.obj", "v 0 0 0\nv 1 0 0\nf -1 -2 -3\n");
    CHECK_THAT(error_of([&] { pcp::read_mesh(neg); }), names("neg.obj", "line 3: face refers to vertex -3"));
    const std::string off = put_file(dir / "f.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 -1\n");
    CHECK_THAT(error_of([&] { pcp::read_mesh(off); }), names("f.off", "line 6: face 0 refers to vertex -1"));

    pcp::Mesh bad = random_mesh(2);
    bad.faces(7, 1) = 40;
    const fs::path out_dir = tmp_dir("err_faces_write");
    for (const char* name : {"bad.ply", "bad.obj", "bad.off"})
        CHECK_THAT(error_of([&] { pcp::write_mesh((out_dir / name).string(), bad); }),
                   names(name, "face 7 refers to vertex 40 but the mesh has 40 vertices"));
    CHECK(entries(out_dir) == 0);
}

TEST_CASE("io: bad point clouds are refused on write and leave no file", "[io]") {
    const fs::path dir = tmp_dir("err_write");
    pcp::PointCloud cloud = random_cloud(10, 4);
    cloud.properties["short"] = Eigen::VectorXd::Zero(9);
    for (const char* name : {"a.ply", "a.xyz", "a.npy"})
        CHECK_THAT(error_of([&] { pcp::write_point_cloud((dir / name).string(), cloud); }),
                   names(name, "property 'short' has 9 values but the cloud has 10 points"));
    cloud.properties.erase("short");
    cloud.properties["has space"] = Eigen::VectorXd::Zero(10);
    CHECK_THAT(error_of([&] { pcp::write_point_cloud((dir / "b.ply").string(), cloud); }),
               names("b.ply", "property name 'has space' cannot be written"));
    CHECK(entries(dir) == 0);
}

TEST_CASE("io: every truncation of valid files reads or throws pcp::Error", "[io]") {
    // Garbage must never crash or hang: cut valid files at every length, and flip bytes.
    const fs::path dir = tmp_dir("fuzz");
    const std::pair<const char*, std::string> files[] = {
        {"a.ply", every_type_ply(PlyBytes::Ascii, "float")},
        {"l.ply", every_type_ply(PlyBytes::LE, "double")},
        {"b.ply", every_type_ply(PlyBytes::BE, "ushort")},
        {"c.npy", make_npy('>', 4, true, 3, 6, 2)},
        {"d.xyz", "1 2 3 4 5 6\n7 8 9 10 11 12\n"},
        {"e.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/2 3/3\n"},
        {"f.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"},
    };
    std::mt19937 rng(42);
    std::size_t errors = 0, reads = 0;
    for (const auto& [name, bytes] : files) {
        const bool mesh = std::string(name).find(".obj") != std::string::npos ||
                          std::string(name).find(".off") != std::string::npos;
        auto attempt = [&, name = name](const std::string& content) {
            const std::string path = put_file(dir / name, content);
            try {
                if (mesh) pcp::read_mesh(path);
                else pcp::read_point_cloud(path);
                ++reads;
            } catch (const pcp::Error&) {
                ++errors;
            }
        };
        for (std::size_t len = 0; len <= bytes.size(); ++len) attempt(bytes.substr(0, len));
        for (int trial = 0; trial < 200; ++trial) {
            std::string flipped = bytes;
            flipped[rng() % flipped.size()] = static_cast<char>(rng());
            attempt(flipped);
        }
    }
    CHECK(errors > 100);
    CHECK(reads > 100);
}
