// The public io entry points (read_point_cloud, write_point_cloud, read_mesh, write_mesh):
// dispatch by extension, whole-file loading, and the small parsing/formatting helpers that the
// format files (io_ply.cpp, io_text.cpp, io_npy.cpp) share.
#include "pcp/io/io.hpp"

#include "io/io_detail.hpp"
#include "pcp/core/error.hpp"
#include "pcp/core/files.hpp"

#include <cerrno>
#include <charconv>
#include <cstdio>
#include <cstring>
#include <ostream>

#include <sys/stat.h>

namespace pcp {
namespace io_detail {

std::string read_whole_file(const std::string& path) {
    struct stat st {};
    PCP_CHECK(::stat(path.c_str(), &st) == 0,
              path << ": cannot open file: " << std::strerror(errno));
    PCP_CHECK(!S_ISDIR(st.st_mode), path << ": is a directory, not a file");
    std::FILE* f = std::fopen(path.c_str(), "rb");
    PCP_CHECK(f != nullptr, path << ": cannot open file: " << std::strerror(errno));
    std::string data;
    char chunk[1 << 16];
    if (S_ISREG(st.st_mode)) data.reserve(static_cast<std::size_t>(st.st_size));
    for (;;) {
        const std::size_t got = std::fread(chunk, 1, sizeof(chunk), f);
        data.append(chunk, got);
        if (got < sizeof(chunk)) break;
    }
    const bool failed = std::ferror(f) != 0;
    std::fclose(f);
    PCP_CHECK(!failed, path << ": read error");
    PCP_CHECK(!data.empty(), path << ": file is empty");
    return data;
}

bool parse_double(std::string_view token, double& value) {
    const char* first = token.data();
    const char* last = first + token.size();
    if (first != last && *first == '+') ++first;
    if (first == last) return false;
    const auto result = std::from_chars(first, last, value);
    return result.ec == std::errc() && result.ptr == last;
}

bool parse_int(std::string_view token, std::int64_t& value) {
    const char* first = token.data();
    const char* last = first + token.size();
    if (first != last && *first == '+') ++first;
    if (first == last) return false;
    const auto result = std::from_chars(first, last, value);
    return result.ec == std::errc() && result.ptr == last;
}

void append_double(std::string& out, double value, int precision) {
    char buf[64];
    const auto result = precision <= 0
                            ? std::to_chars(buf, buf + sizeof(buf), value)
                            : std::to_chars(buf, buf + sizeof(buf), value,
                                            std::chars_format::general, precision);
    out.append(buf, result.ptr);
}

void append_int(std::string& out, std::int64_t value) {
    char buf[24];
    const auto result = std::to_chars(buf, buf + sizeof(buf), value);
    out.append(buf, result.ptr);
}

bool LineReader::next(std::string_view& line) {
    if (pos_ >= text_.size()) return false;
    std::size_t end = text_.find('\n', pos_);
    const std::size_t next_pos = end == std::string_view::npos ? text_.size() : end + 1;
    if (end == std::string_view::npos) end = text_.size();
    std::size_t stop = end;
    if (stop > pos_ && text_[stop - 1] == '\r') --stop;
    line = text_.substr(pos_, stop - pos_);
    pos_ = next_pos;
    ++line_number_;
    return true;
}

void split_tokens(std::string_view line, std::vector<std::string_view>& tokens, bool commas) {
    tokens.clear();
    std::size_t i = 0;
    const std::size_t n = line.size();
    auto is_sep = [commas](char c) { return is_space(c) || (commas && c == ','); };
    while (i < n) {
        while (i < n && is_sep(line[i])) ++i;
        if (i >= n) break;
        const std::size_t start = i;
        while (i < n && !is_sep(line[i])) ++i;
        tokens.push_back(line.substr(start, i - start));
    }
}

std::string quote_token(std::string_view token) {
    std::string s = "'";
    if (token.size() > 32) {
        s.append(token.substr(0, 29));
        s += "...";
    } else {
        s.append(token);
    }
    for (char& c : s)
        if (static_cast<unsigned char>(c) < 32 || static_cast<unsigned char>(c) > 126) c = '?';
    s += "'";
    return s;
}

std::vector<std::string> property_column_order(const PointCloud& cloud) {
    std::vector<std::string> order;
    const bool normals = cloud.properties.count("nx") && cloud.properties.count("ny") &&
                         cloud.properties.count("nz");
    if (normals) order = {"nx", "ny", "nz"};
    for (const auto& [name, values] : cloud.properties) {
        (void)values;
        if (normals && (name == "nx" || name == "ny" || name == "nz")) continue;
        order.push_back(name);
    }
    return order;
}

void check_property_sizes(const std::string& path, const PointCloud& cloud) {
    for (const auto& [name, values] : cloud.properties)
        PCP_CHECK(values.size() == cloud.points.rows(),
                  path << ": property '" << name << "' has " << values.size()
                       << " values but the cloud has " << cloud.points.rows() << " points");
}

std::vector<std::string> extra_column_names(std::size_t columns) {
    if (columns == 6) return {"nx", "ny", "nz"};
    std::vector<std::string> names;
    for (std::size_t c = 3; c < columns; ++c) names.push_back("c" + std::to_string(c));
    return names;
}

}  // namespace io_detail

namespace {

void check_faces_in_range(const std::string& path, const Mesh& mesh) {
    const Eigen::Index nv = mesh.vertices.rows();
    for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f)
        for (int k = 0; k < 3; ++k) {
            const std::int32_t v = mesh.faces(f, k);
            PCP_CHECK(v >= 0 && v < nv, path << ": face " << f << " refers to vertex " << v
                                             << " but the mesh has " << nv << " vertices");
        }
}

void write_bytes(const std::string& path, const std::string& bytes) {
    write_file_atomically(path, [&bytes](std::ostream& out) {
        out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    });
}

}  // namespace

PointCloud read_point_cloud(const std::string& path) {
    const std::string ext = file_extension(path);
    PCP_CHECK(ext == ".ply" || ext == ".xyz" || ext == ".txt" || ext == ".pts" || ext == ".npy",
              path << ": unsupported point cloud extension '" << ext
                   << "' (supported: .ply, .xyz, .txt, .pts, .npy)");
    const std::string data = io_detail::read_whole_file(path);
    if (ext == ".ply") return io_detail::read_ply_point_cloud(path, data);
    if (ext == ".npy") return io_detail::read_npy(path, data);
    return io_detail::read_xyz(path, data, ext == ".pts");
}

void write_point_cloud(const std::string& path, const PointCloud& cloud, bool ascii) {
    const std::string ext = file_extension(path);
    PCP_CHECK(ext == ".ply" || ext == ".xyz" || ext == ".npy",
              path << ": unsupported point cloud extension '" << ext
                   << "' for writing (supported: .ply, .xyz, .npy)");
    io_detail::check_property_sizes(path, cloud);
    if (ext == ".ply") write_bytes(path, io_detail::ply_point_cloud_bytes(path, cloud, ascii));
    else if (ext == ".xyz") write_bytes(path, io_detail::xyz_bytes(cloud));
    else write_bytes(path, io_detail::npy_bytes(cloud));
}

Mesh read_mesh(const std::string& path) {
    const std::string ext = file_extension(path);
    PCP_CHECK(ext == ".ply" || ext == ".obj" || ext == ".off",
              path << ": unsupported mesh extension '" << ext << "' (supported: .ply, .obj, .off)");
    const std::string data = io_detail::read_whole_file(path);
    if (ext == ".ply") return io_detail::read_ply_mesh(path, data);
    if (ext == ".obj") return io_detail::read_obj(path, data);
    return io_detail::read_off(path, data);
}

void write_mesh(const std::string& path, const Mesh& mesh, const MeshWriteOptions& options) {
    const std::string ext = file_extension(path);
    PCP_CHECK(ext == ".ply" || ext == ".obj" || ext == ".off",
              path << ": unsupported mesh extension '" << ext
                   << "' for writing (supported: .ply, .obj, .off)");
    PCP_CHECK(options.precision >= 1 && options.precision <= 17,
              path << ": MeshWriteOptions::precision must be in 1..17, got " << options.precision);
    check_faces_in_range(path, mesh);
    if (ext == ".ply")
        write_bytes(path, io_detail::ply_mesh_bytes(mesh, options.ascii, options.precision));
    else if (ext == ".obj") write_bytes(path, io_detail::obj_bytes(mesh, options.precision));
    else write_bytes(path, io_detail::off_bytes(mesh, options.precision));
}

}  // namespace pcp
