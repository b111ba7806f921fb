// The PLY reader and writer, written for libpcp (no tinyply, no CGAL): header parsing, ascii and
// binary (little and big endian) bodies with every PLY scalar type, elements in any order with
// list properties skipped correctly, the vertex element as a PointCloud (extra scalar properties
// by name) or vertex + face elements as a Mesh (polygons fan-triangulated). Declared counts are
// checked against the bytes that remain before anything is allocated, so a corrupt header cannot
// make the reader allocate more than the file size justifies.
#include "io/io_detail.hpp"
#include "pcp/core/error.hpp"

#include <cmath>
#include <cstring>
#include <limits>

namespace pcp::io_detail {
namespace {

enum class PlyType : std::uint8_t { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };
enum class PlyFormat { Ascii, BinaryLittleEndian, BinaryBigEndian };

struct PlyProperty {
    std::string name;
    PlyType type = PlyType::Float32;  // the item type for a list
    bool is_list = false;
    PlyType count_type = PlyType::UInt8;
};

struct PlyElement {
    std::string name;
    std::uint64_t count = 0;
    std::vector<PlyProperty> properties;
};

struct PlyHeader {
    PlyFormat format = PlyFormat::Ascii;
    std::vector<PlyElement> elements;
    std::size_t body_offset = 0;  // first byte after the end_header line
    std::size_t body_line = 0;    // 1-based line number of the first body line (ascii)
};

std::size_t type_size(PlyType t) {
    switch (t) {
        case PlyType::Int8:
        case PlyType::UInt8: return 1;
        case PlyType::Int16:
        case PlyType::UInt16: return 2;
        case PlyType::Int32:
        case PlyType::UInt32:
        case PlyType::Float32: return 4;
        case PlyType::Float64: return 8;
    }
    return 0;
}

bool is_integer_type(PlyType t) { return t != PlyType::Float32 && t != PlyType::Float64; }

bool parse_type(std::string_view s, PlyType& t) {
    if (s == "char" || s == "int8") t = PlyType::Int8;
    else if (s == "uchar" || s == "uint8") t = PlyType::UInt8;
    else if (s == "short" || s == "int16") t = PlyType::Int16;
    else if (s == "ushort" || s == "uint16") t = PlyType::UInt16;
    else if (s == "int" || s == "int32") t = PlyType::Int32;
    else if (s == "uint" || s == "uint32") t = PlyType::UInt32;
    else if (s == "float" || s == "float32") t = PlyType::Float32;
    else if (s == "double" || s == "float64") t = PlyType::Float64;
    else return false;
    return true;
}

PlyHeader parse_header(const std::string& path, const std::string& data) {
    LineReader lines(data);
    std::string_view line;
    std::vector<std::string_view> tok;
    PCP_CHECK(lines.next(line) && line == "ply",
              path << ": not a PLY file (the first line is not 'ply')");
    PlyHeader header;
    bool have_format = false;
    for (;;) {
        PCP_CHECK(lines.next(line), path << ": malformed PLY header: no 'end_header' line");
        const std::size_t ln = lines.line_number();
        split_tokens(line, tok);
        if (tok.empty()) continue;
        const std::string_view key = tok[0];
        if (key == "end_header") break;
        if (key == "comment" || key == "obj_info") continue;
        if (key == "format") {
            PCP_CHECK(tok.size() >= 2, path << ": malformed PLY header: line " << ln
                                            << ": 'format' without a format name");
            if (tok[1] == "ascii") header.format = PlyFormat::Ascii;
            else if (tok[1] == "binary_little_endian") header.format = PlyFormat::BinaryLittleEndian;
            else if (tok[1] == "binary_big_endian") header.format = PlyFormat::BinaryBigEndian;
            else
                PCP_FAIL(path << ": malformed PLY header: line " << ln << ": unknown format "
                              << quote_token(tok[1])
                              << " (expected ascii, binary_little_endian or binary_big_endian)");
            have_format = true;
        } else if (key == "element") {
            std::int64_t count = -1;
            PCP_CHECK(tok.size() == 3 && parse_int(tok[2], count) && count >= 0,
                      path << ": malformed PLY header: line " << ln
                           << ": expected 'element <name> <count>'");
            header.elements.push_back({std::string(tok[1]), static_cast<std::uint64_t>(count), {}});
        } else if (key == "property") {
            PCP_CHECK(!header.elements.empty(), path << ": malformed PLY header: line " << ln
                                                     << ": property before any element");
            PlyProperty prop;
            if (tok.size() == 5 && tok[1] == "list") {
                PCP_CHECK(parse_type(tok[2], prop.count_type) && is_integer_type(prop.count_type) &&
                              parse_type(tok[3], prop.type),
                          path << ": malformed PLY header: line " << ln
                               << ": bad list property types " << quote_token(line));
                prop.is_list = true;
                prop.name = tok[4];
            } else {
                PCP_CHECK(tok.size() == 3 && parse_type(tok[1], prop.type),
                          path << ": malformed PLY header: line " << ln << ": bad property line "
                               << quote_token(line) << " (expected 'property <type> <name>')");
                prop.name = tok[2];
            }
            header.elements.back().properties.push_back(prop);
        } else {
            PCP_FAIL(path << ": malformed PLY header: line " << ln << ": unexpected "
                          << quote_token(line) << " (is the 'end_header' line missing?)");
        }
    }
    PCP_CHECK(have_format, path << ": malformed PLY header: no 'format' line");
    header.body_offset = lines.position();
    header.body_line = lines.line_number() + 1;
    return header;
}

constexpr bool kHostBigEndian = __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__;

// Reads the body of a binary PLY. Every read checks the bounds; rows of fixed size are also
// checked as a block up front so the message can say how much data the header promised.
class BinarySource {
public:
    BinarySource(const std::string& path, const std::string& data, std::size_t offset, bool big)
        : path_(path),
          p_(reinterpret_cast<const unsigned char*>(data.data()) + offset),
          end_(reinterpret_cast<const unsigned char*>(data.data()) + data.size()),
          swap_(big != kHostBigEndian) {}

    double read(PlyType t, const PlyElement& e, std::uint64_t row) {
        const std::size_t n = type_size(t);
        if (static_cast<std::size_t>(end_ - p_) < n)
            PCP_FAIL(path_ << ": truncated binary body: the file ends in row " << row << " of element '"
                           << e.name << "' (the header declares " << e.count << " rows)");
        double v = 0;
        switch (t) {
            case PlyType::Int8: v = static_cast<std::int8_t>(*p_); break;
            case PlyType::UInt8: v = *p_; break;
            case PlyType::Int16: v = load<std::int16_t>(p_, swap_); break;
            case PlyType::UInt16: v = load<std::uint16_t>(p_, swap_); break;
            case PlyType::Int32: v = load<std::int32_t>(p_, swap_); break;
            case PlyType::UInt32: v = load<std::uint32_t>(p_, swap_); break;
            case PlyType::Float32: v = load<float>(p_, swap_); break;
            case PlyType::Float64: v = load<double>(p_, swap_); break;
        }
        p_ += n;
        return v;
    }

    void skip(PlyType t, const PlyElement& e, std::uint64_t row) { read(t, e, row); }

    // Throws unless `e.count` rows of at least `min_row_bytes` each can still follow.
    void check_room(const PlyElement& e, std::size_t min_row_bytes) const {
        const std::uint64_t left = static_cast<std::uint64_t>(end_ - p_);
        if (min_row_bytes == 0 || e.count <= left / min_row_bytes) return;
        PCP_FAIL(path_ << ": truncated binary body: the header declares " << e.count << " rows of element '"
                       << e.name << "' (at least " << min_row_bytes << " bytes each) but only "
                       << left << " bytes follow");
    }

    // Skips `e.count` rows of `row_bytes` bytes (an element without list properties).
    void skip_rows(const PlyElement& e, std::size_t row_bytes) {
        check_room(e, row_bytes);
        p_ += e.count * row_bytes;
    }

    std::string where() const { return {}; }

private:
    const std::string& path_;
    const unsigned char* p_;
    const unsigned char* end_;
    bool swap_;
};

// Reads the body of an ascii PLY as a stream of whitespace-separated tokens (rows need not be
// one per line), tracking line numbers for messages.
class AsciiSource {
public:
    AsciiSource(const std::string& path, const std::string& data, std::size_t offset, std::size_t line)
        : path_(path), data_(data), pos_(offset), line_(line) {}

    double read(PlyType t, const PlyElement& e, std::uint64_t row) {
        const std::string_view tok = next(e, row);
        double v = 0;
        std::int64_t i = 0;
        if (is_integer_type(t) && parse_int(tok, i)) return static_cast<double>(i);
        PCP_CHECK(parse_double(tok, v), path_ << ": line " << line_ << ": non-numeric value "
                                              << quote_token(tok) << " in element '" << e.name
                                              << "' row " << row);
        return v;
    }

    void skip(PlyType, const PlyElement& e, std::uint64_t row) { next(e, row); }

    // Each value takes at least one character, so more values than bytes cannot follow.
    void check_room(const PlyElement& e, std::size_t min_row_values) const {
        const std::uint64_t left = data_.size() - pos_;
        if (min_row_values == 0 || e.count <= left / min_row_values) return;
        PCP_FAIL(path_ << ": the header declares " << e.count << " rows of element '" << e.name
                       << "' but only " << left << " bytes of data follow");
    }

    void skip_rows(const PlyElement& e, std::size_t) {
        if (e.properties.empty()) return;
        check_room(e, e.properties.size());
        for (std::uint64_t r = 0; r < e.count; ++r)
            for (std::size_t k = 0; k < e.properties.size(); ++k) next(e, r);
    }

    std::string where() const { return "line " + std::to_string(line_) + ": "; }

private:
    std::string_view next(const PlyElement& e, std::uint64_t row) {
        const std::size_t n = data_.size();
        while (pos_ < n && is_space(data_[pos_])) {
            if (data_[pos_] == '\n') ++line_;
            ++pos_;
        }
        if (pos_ >= n)
            PCP_FAIL(path_ << ": unexpected end of file in row " << row << " of element '" << e.name
                           << "': the header declares " << e.count << " rows");
        const std::size_t start = pos_;
        while (pos_ < n && !is_space(data_[pos_])) ++pos_;
        return std::string_view(data_).substr(start, pos_ - start);
    }

    const std::string& path_;
    const std::string& data_;
    std::size_t pos_;
    std::size_t line_;
};

// Smallest number of bytes (binary) or tokens (ascii) one row of `e` can occupy.
std::size_t min_row_size(const PlyElement& e, bool binary) {
    std::size_t s = 0;
    for (const PlyProperty& p : e.properties)
        s += binary ? type_size(p.is_list ? p.count_type : p.type) : 1;
    return s;
}

bool has_lists(const PlyElement& e) {
    for (const PlyProperty& p : e.properties)
        if (p.is_list) return true;
    return false;
}

template <class Source>
std::int64_t read_list_count(Source& src, const PlyProperty& p, const PlyElement& e, std::uint64_t row,
                             const std::string& path) {
    const double c = src.read(p.count_type, e, row);
    PCP_CHECK(c >= 0 && c <= 2147483647.0 && c == std::floor(c),
              path << ": " << src.where() << "invalid list length " << c << " in row " << row
                   << " of element '" << e.name << "'");
    return static_cast<std::int64_t>(c);
}

template <class Source>
void skip_element(Source& src, const PlyElement& e, bool binary, const std::string& path) {
    if (!has_lists(e)) {
        src.skip_rows(e, min_row_size(e, binary));
        return;
    }
    src.check_room(e, min_row_size(e, binary));
    for (std::uint64_t r = 0; r < e.count; ++r)
        for (const PlyProperty& p : e.properties) {
            if (!p.is_list) {
                src.skip(p.type, e, r);
                continue;
            }
            const std::int64_t n = read_list_count(src, p, e, r, path);
            for (std::int64_t k = 0; k < n; ++k) src.skip(p.type, e, r);
        }
}

// Reads the vertex element: x, y, z into `cloud.points` and, if `keep_properties`, every other
// scalar property into `cloud.properties`. List properties are skipped.
template <class Source>
void read_vertices(Source& src, const PlyElement& e, bool binary, bool keep_properties,
                   const std::string& path, PointCloud& cloud) {
    int xyz[3] = {-1, -1, -1};
    const char* names[3] = {"x", "y", "z"};
    for (std::size_t k = 0; k < e.properties.size(); ++k)
        for (int c = 0; c < 3; ++c)
            if (!e.properties[k].is_list && e.properties[k].name == names[c]) xyz[c] = static_cast<int>(k);
    for (int c = 0; c < 3; ++c)
        PCP_CHECK(xyz[c] >= 0, path << ": malformed PLY header: the vertex element has no '" << names[c]
                                    << "' property");
    src.check_room(e, min_row_size(e, binary));
    const Eigen::Index n = static_cast<Eigen::Index>(e.count);
    cloud.points.resize(n, 3);

    // Destination of property k for row i: dest[k] + i * stride[k] (nullptr = skip).
    std::vector<double*> dest(e.properties.size(), nullptr);
    std::vector<Eigen::Index> stride(e.properties.size(), 1);
    for (int c = 0; c < 3; ++c) {
        if (n == 0) break;  // no rows: nothing to point at (and data() is null)
        dest[static_cast<std::size_t>(xyz[c])] = cloud.points.data() + c;
        stride[static_cast<std::size_t>(xyz[c])] = 3;
    }
    if (keep_properties)
        for (std::size_t k = 0; k < e.properties.size(); ++k) {
            const PlyProperty& p = e.properties[k];
            if (p.is_list || dest[k] != nullptr) continue;
            Eigen::VectorXd& v = cloud.properties[p.name];
            v.resize(n);
            dest[k] = v.data();
        }

    for (Eigen::Index i = 0; i < n; ++i) {
        const std::uint64_t row = static_cast<std::uint64_t>(i);
        for (std::size_t k = 0; k < e.properties.size(); ++k) {
            const PlyProperty& p = e.properties[k];
            if (p.is_list) {
                const std::int64_t len = read_list_count(src, p, e, row, path);
                for (std::int64_t j = 0; j < len; ++j) src.skip(p.type, e, row);
            } else if (dest[k] != nullptr) {
                dest[k][i * stride[k]] = src.read(p.type, e, row);
            } else {
                src.skip(p.type, e, row);
            }
        }
        const auto pt = cloud.points.row(i);
        PCP_CHECK(std::isfinite(pt(0)) && std::isfinite(pt(1)) && std::isfinite(pt(2)),
                  path << ": " << src.where() << "vertex " << i << " has a non-finite coordinate ("
                       << pt(0) << ", " << pt(1) << ", " << pt(2) << ")");
    }
}

// Index of the face element's vertex-index list property, or throws.
std::size_t face_list_property(const PlyElement& e, const std::string& path) {
    int found = -1, lists = 0, last_list = -1;
    for (std::size_t k = 0; k < e.properties.size(); ++k) {
        const PlyProperty& p = e.properties[k];
        if (!p.is_list) continue;
        ++lists;
        last_list = static_cast<int>(k);
        if (p.name == "vertex_indices" || p.name == "vertex_index") found = static_cast<int>(k);
    }
    if (found < 0 && lists == 1) found = last_list;
    PCP_CHECK(found >= 0, path << ": malformed PLY header: the face element has no 'vertex_indices' "
                               "list property");
    return static_cast<std::size_t>(found);
}

// Reads the face element into triangles (fan triangulation), checking indices against the
// vertex count the header declares.
template <class Source>
void read_faces(Source& src, const PlyElement& e, bool binary, std::uint64_t vertex_count,
                const std::string& path, std::vector<std::int32_t>& tris) {
    const std::size_t list = face_list_property(e, path);
    src.check_room(e, min_row_size(e, binary));
    tris.reserve(static_cast<std::size_t>(e.count) * 3);
    std::vector<std::int32_t> poly;
    for (std::uint64_t r = 0; r < e.count; ++r)
        for (std::size_t k = 0; k < e.properties.size(); ++k) {
            const PlyProperty& p = e.properties[k];
            if (!p.is_list) {
                src.skip(p.type, e, r);
                continue;
            }
            const std::int64_t len = read_list_count(src, p, e, r, path);
            if (k != list) {
                for (std::int64_t j = 0; j < len; ++j) src.skip(p.type, e, r);
                continue;
            }
            const std::string where = src.where();
            PCP_CHECK(len >= 3, path << ": " << where << "face " << r << " has " << len
                                     << " vertices (a face needs at least 3)");
            poly.clear();
            for (std::int64_t j = 0; j < len; ++j) {
                const double v = src.read(p.type, e, r);
                PCP_CHECK(v >= 0 && v < static_cast<double>(vertex_count) && v == std::floor(v),
                          path << ": " << where << "face " << r << " refers to vertex " << v
                               << " but the file has " << vertex_count << " vertices");
                poly.push_back(static_cast<std::int32_t>(v));
            }
            for (std::size_t j = 1; j + 1 < poly.size(); ++j) {
                tris.push_back(poly[0]);
                tris.push_back(poly[j]);
                tris.push_back(poly[j + 1]);
            }
        }
}

const PlyElement* find_element(const PlyHeader& h, const char* name) {
    for (const PlyElement& e : h.elements)
        if (e.name == name) return &e;
    return nullptr;
}

// Walks the elements in file order: reads the vertex element (and the face element if `faces`
// is given), skips the others, and stops once everything wanted has been read.
template <class Source>
void read_body(Source& src, const PlyHeader& h, const std::string& path, bool keep_properties,
               PointCloud& cloud, std::vector<std::int32_t>* faces) {
    const bool binary = h.format != PlyFormat::Ascii;
    const PlyElement* vertex = find_element(h, "vertex");
    const PlyElement* face = faces != nullptr ? find_element(h, "face") : nullptr;
    bool vertex_done = false, face_done = face == nullptr;
    for (const PlyElement& e : h.elements) {
        if (vertex_done && face_done) break;
        if (&e == vertex) {
            read_vertices(src, e, binary, keep_properties, path, cloud);
            vertex_done = true;
        } else if (&e == face) {
            read_faces(src, e, binary, vertex->count, path, *faces);
            face_done = true;
        } else {
            skip_element(src, e, binary, path);
        }
    }
}

void read_ply(const std::string& path, const std::string& data, bool keep_properties, PointCloud& cloud,
              std::vector<std::int32_t>* faces) {
    const PlyHeader h = parse_header(path, data);
    PCP_CHECK(find_element(h, "vertex") != nullptr,
              path << ": malformed PLY header: no 'vertex' element");
    if (faces != nullptr) {
        PCP_CHECK(find_element(h, "face") != nullptr,
                  path << ": no 'face' element: this PLY file is a point cloud, not a mesh");
        PCP_CHECK(find_element(h, "vertex")->count <=
                      static_cast<std::uint64_t>(std::numeric_limits<std::int32_t>::max()),
                  path << ": too many vertices for a mesh (more than 2^31 - 1)");
    }
    if (h.format == PlyFormat::Ascii) {
        AsciiSource src(path, data, h.body_offset, h.body_line);
        read_body(src, h, path, keep_properties, cloud, faces);
    } else {
        BinarySource src(path, data, h.body_offset, h.format == PlyFormat::BinaryBigEndian);
        read_body(src, h, path, keep_properties, cloud, faces);
    }
}

// ---- writing ----

void append_le_double(std::string& out, double v) {
    unsigned char b[8];
    std::memcpy(b, &v, 8);
    if (kHostBigEndian)
        for (int k = 0; k < 4; ++k) std::swap(b[k], b[7 - k]);
    out.append(reinterpret_cast<const char*>(b), 8);
}

void append_le_int32(std::string& out, std::int32_t v) {
    unsigned char b[4];
    std::memcpy(b, &v, 4);
    if (kHostBigEndian) {
        std::swap(b[0], b[3]);
        std::swap(b[1], b[2]);
    }
    out.append(reinterpret_cast<const char*>(b), 4);
}

std::string ply_header_start(bool ascii, Eigen::Index vertices) {
    std::string h = "ply\nformat ";
    h += ascii ? "ascii 1.0\n" : "binary_little_endian 1.0\n";
    h += "comment written by libpcp\nelement vertex " + std::to_string(vertices) +
         "\nproperty double x\nproperty double y\nproperty double z\n";
    return h;
}

}  // namespace

PointCloud read_ply_point_cloud(const std::string& path, const std::string& data) {
    PointCloud cloud;
    read_ply(path, data, true, cloud, nullptr);
    return cloud;
}

Mesh read_ply_mesh(const std::string& path, const std::string& data) {
    PointCloud cloud;
    std::vector<std::int32_t> tris;
    read_ply(path, data, false, cloud, &tris);
    Mesh mesh;
    mesh.vertices = std::move(cloud.points);
    mesh.faces = Eigen::Map<const Faces>(tris.data(), static_cast<Eigen::Index>(tris.size() / 3), 3);
    return mesh;
}

std::string ply_point_cloud_bytes(const std::string& path, const PointCloud& cloud, bool ascii) {
    std::vector<const Eigen::VectorXd*> props;
    std::string out = ply_header_start(ascii, cloud.points.rows());
    for (const auto& [name, values] : cloud.properties) {
        bool ok = !name.empty() && name != "x" && name != "y" && name != "z";
        for (char c : name) ok = ok && !is_space(c) && static_cast<unsigned char>(c) > 32;
        PCP_CHECK(ok, path << ": property name " << quote_token(name)
                           << " cannot be written to PLY (empty, x/y/z, or contains whitespace)");
        out += "property double " + name + "\n";
        props.push_back(&values);
    }
    out += "end_header\n";
    const Eigen::Index n = cloud.points.rows();
    out.reserve(out.size() + static_cast<std::size_t>(n) * (3 + props.size()) * (ascii ? 25 : 8));
    for (Eigen::Index i = 0; i < n; ++i) {
        for (int c = 0; c < 3; ++c) {
            if (ascii) {
                if (c > 0) out += ' ';
                append_double(out, cloud.points(i, c));
            } else {
                append_le_double(out, cloud.points(i, c));
            }
        }
        for (const Eigen::VectorXd* v : props) {
            if (ascii) {
                out += ' ';
                append_double(out, (*v)(i));
            } else {
                append_le_double(out, (*v)(i));
            }
        }
        if (ascii) out += '\n';
    }
    return out;
}

std::string ply_mesh_bytes(const Mesh& mesh, bool ascii, int precision) {
    std::string out = ply_header_start(ascii, mesh.vertices.rows());
    out += "element face " + std::to_string(mesh.faces.rows()) +
           "\nproperty list uchar int vertex_indices\nend_header\n";
    for (Eigen::Index i = 0; i < mesh.vertices.rows(); ++i) {
        for (int c = 0; c < 3; ++c) {
            if (ascii) {
                if (c > 0) out += ' ';
                append_double(out, mesh.vertices(i, c), precision);
            } else {
                append_le_double(out, mesh.vertices(i, c));
            }
        }
        if (ascii) out += '\n';
    }
    for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
        if (ascii) {
            out += '3';
            for (int k = 0; k < 3; ++k) {
                out += ' ';
                append_int(out, mesh.faces(f, k));
            }
            out += '\n';
        } else {
            out += static_cast<char>(3);
            for (int k = 0; k < 3; ++k) append_le_int32(out, mesh.faces(f, k));
        }
    }
    return out;
}

}  // namespace pcp::io_detail
