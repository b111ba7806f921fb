// The line-based text formats: .xyz/.txt/.pts point tables (whitespace or comma separated,
// '#' and '//' comment lines, an optional count line for .pts), Wavefront .obj meshes (v and f
// lines only) and .off meshes. Readers go through the whole-file buffer line by line, parse
// numbers with from_chars and report "<path>: line N: <problem>".
#include "io/io_detail.hpp"
#include "pcp/core/error.hpp"

#include <cmath>
#include <limits>

namespace pcp::io_detail {
namespace {

std::string_view trim_left(std::string_view s) {
    std::size_t i = 0;
    while (i < s.size() && is_space(s[i])) ++i;
    return s.substr(i);
}

bool is_comment_or_blank(std::string_view line) {
    const std::string_view t = trim_left(line);
    return t.empty() || t[0] == '#' || (t.size() >= 2 && t[0] == '/' && t[1] == '/');
}

double parse_coordinate(const std::string& path, const LineReader& lines, std::string_view tok) {
    double v = 0;
    PCP_CHECK(parse_double(tok, v), path << ": line " << lines.line_number()
                                         << ": non-numeric value " << quote_token(tok));
    return v;
}

void check_finite_point(const std::string& path, const LineReader& lines, const double* p) {
    PCP_CHECK(std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]),
              path << ": line " << lines.line_number() << ": non-finite coordinate (" << p[0] << ", "
                   << p[1] << ", " << p[2] << ")");
}

void append_row(std::string& out, const double* v, std::size_t n, int precision) {
    for (std::size_t c = 0; c < n; ++c) {
        if (c > 0) out += ' ';
        append_double(out, v[c], precision);
    }
    out += '\n';
}

Faces to_faces(const std::vector<std::int32_t>& tris) {
    return Eigen::Map<const Faces>(tris.data(), static_cast<Eigen::Index>(tris.size() / 3), 3);
}

Points to_points(const std::vector<double>& xyz) {
    return Eigen::Map<const Points>(xyz.data(), static_cast<Eigen::Index>(xyz.size() / 3), 3);
}

void fan_triangulate(const std::vector<std::int32_t>& poly, std::vector<std::int32_t>& tris) {
    for (std::size_t j = 1; j + 1 < poly.size(); ++j) {
        tris.push_back(poly[0]);
        tris.push_back(poly[j]);
        tris.push_back(poly[j + 1]);
    }
}

}  // namespace

// ---- .xyz / .txt / .pts ----

PointCloud read_xyz(const std::string& path, const std::string& data, bool allow_count_line) {
    LineReader lines(data);
    std::string_view line;
    std::vector<std::string_view> tok;
    std::vector<double> values;
    values.reserve(data.size() / 8);
    std::size_t cols = 0;
    bool first = true;
    while (lines.next(line)) {
        if (is_comment_or_blank(line)) continue;
        split_tokens(line, tok, true);
        if (tok.empty()) continue;
        std::int64_t count = 0;
        if (first && allow_count_line && tok.size() == 1 && parse_int(tok[0], count)) {
            first = false;
            continue;
        }
        first = false;
        if (cols == 0) {
            PCP_CHECK(tok.size() >= 3, path << ": line " << lines.line_number()
                                            << ": expected at least 3 columns (x y z), found "
                                            << tok.size());
            cols = tok.size();
        }
        PCP_CHECK(tok.size() == cols, path << ": line " << lines.line_number() << ": found "
                                           << tok.size() << " columns but the first data line has "
                                           << cols);
        const std::size_t at = values.size();
        for (std::string_view t : tok) values.push_back(parse_coordinate(path, lines, t));
        check_finite_point(path, lines, values.data() + at);
    }
    PointCloud cloud;
    const Eigen::Index n = cols == 0 ? 0 : static_cast<Eigen::Index>(values.size() / cols);
    cloud.points.resize(n, 3);
    const std::vector<std::string> names = extra_column_names(cols);
    for (const std::string& name : names) cloud.properties[name].resize(n);
    for (Eigen::Index i = 0; i < n; ++i) {
        const double* row = values.data() + static_cast<std::size_t>(i) * cols;
        cloud.points.row(i) << row[0], row[1], row[2];
        for (std::size_t c = 3; c < cols; ++c) cloud.properties[names[c - 3]](i) = row[c];
    }
    return cloud;
}

std::string xyz_bytes(const PointCloud& cloud) {
    const std::vector<std::string> order = property_column_order(cloud);
    std::string out = "# x y z";
    for (const std::string& name : order) out += " " + name;
    out += '\n';
    std::vector<const Eigen::VectorXd*> props;
    for (const std::string& name : order) props.push_back(&cloud.properties.at(name));
    std::vector<double> row(3 + props.size());
    for (Eigen::Index i = 0; i < cloud.points.rows(); ++i) {
        for (int c = 0; c < 3; ++c) row[static_cast<std::size_t>(c)] = cloud.points(i, c);
        for (std::size_t k = 0; k < props.size(); ++k) row[3 + k] = (*props[k])(i);
        append_row(out, row.data(), row.size(), 0);
    }
    return out;
}

// ---- .obj ----

Mesh read_obj(const std::string& path, const std::string& data) {
    LineReader lines(data);
    std::string_view line;
    std::vector<std::string_view> tok;
    std::vector<double> xyz;
    std::vector<std::int32_t> tris, poly;
    // Triangles whose positive indices pointed past the vertices read so far (OBJ lets faces
    // come first); checked against the final count: (first index in tris, line number).
    std::vector<std::pair<std::size_t, std::size_t>> forward;
    while (lines.next(line)) {
        const std::string_view t = trim_left(line);
        if (t.size() < 2 || !is_space(t[1]) || (t[0] != 'v' && t[0] != 'f')) continue;
        split_tokens(t, tok);
        if (t[0] == 'v') {
            PCP_CHECK(tok.size() >= 4, path << ": line " << lines.line_number()
                                            << ": a 'v' line needs three coordinates");
            const std::size_t at = xyz.size();
            for (int c = 1; c <= 3; ++c) xyz.push_back(parse_coordinate(path, lines, tok[c]));
            check_finite_point(path, lines, xyz.data() + at);
            PCP_CHECK(xyz.size() / 3 <= static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()),
                      path << ": line " << lines.line_number() << ": too many vertices");
            continue;
        }
        PCP_CHECK(tok.size() >= 4, path << ": line " << lines.line_number() << ": face has "
                                        << tok.size() - 1 << " vertices (a face needs at least 3)");
        const std::int64_t nv = static_cast<std::int64_t>(xyz.size() / 3);
        bool pending = false;
        poly.clear();
        for (std::size_t k = 1; k < tok.size(); ++k) {
            const std::string_view ref = tok[k].substr(0, tok[k].find('/'));
            std::int64_t idx = 0;
            PCP_CHECK(parse_int(ref, idx) && idx != 0,
                      path << ": line " << lines.line_number() << ": bad vertex index "
                           << quote_token(tok[k]));
            std::int64_t v = idx > 0 ? idx - 1 : nv + idx;
            PCP_CHECK(v >= 0 && v <= std::numeric_limits<std::int32_t>::max(),
                      path << ": line " << lines.line_number() << ": face refers to vertex " << idx
                           << " but only " << nv << " vertices are defined before it");
            pending = pending || v >= nv;
            poly.push_back(static_cast<std::int32_t>(v));
        }
        const std::size_t first_tri = tris.size();
        fan_triangulate(poly, tris);
        if (pending)
            for (std::size_t at = first_tri; at < tris.size(); at += 3)
                forward.emplace_back(at, lines.line_number());
    }
    const std::int64_t nv = static_cast<std::int64_t>(xyz.size() / 3);
    for (const auto& [at, ln] : forward)
        for (std::size_t k = 0; k < 3; ++k)
            PCP_CHECK(tris[at + k] < nv, path << ": line " << ln << ": face refers to vertex "
                                              << tris[at + k] + 1 << " but the file has " << nv
                                              << " vertices");
    Mesh mesh;
    mesh.vertices = to_points(xyz);
    mesh.faces = to_faces(tris);
    return mesh;
}

std::string obj_bytes(const Mesh& mesh, int precision) {
    std::string out = "# written by libpcp\n";
    for (Eigen::Index i = 0; i < mesh.vertices.rows(); ++i) {
        out += "v ";
        const double v[3] = {mesh.vertices(i, 0), mesh.vertices(i, 1), mesh.vertices(i, 2)};
        append_row(out, v, 3, precision);
    }
    for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
        out += 'f';
        for (int k = 0; k < 3; ++k) {
            out += ' ';
            append_int(out, static_cast<std::int64_t>(mesh.faces(f, k)) + 1);
        }
        out += '\n';
    }
    return out;
}

// ---- .off ----

Mesh read_off(const std::string& path, const std::string& data) {
    LineReader lines(data);
    std::string_view line;
    std::vector<std::string_view> tok;
    // Next non-comment, non-blank line split into tokens; false at the end of the file.
    auto next_data_line = [&]() {
        while (lines.next(line))
            if (!is_comment_or_blank(line)) {
                split_tokens(line, tok);
                return true;
            }
        return false;
    };
    PCP_CHECK(next_data_line(), path << ": no OFF header line");
    const std::string_view magic = tok[0];
    PCP_CHECK(magic == "OFF" || magic == "COFF" || magic == "NOFF" || magic == "CNOFF",
              path << ": line " << lines.line_number() << ": not an OFF file (expected 'OFF', found "
                   << quote_token(magic) << ")");
    std::vector<std::string_view> counts(tok.begin() + 1, tok.end());
    if (counts.empty()) {
        PCP_CHECK(next_data_line(), path << ": malformed OFF header: no vertex/face count line");
        counts = tok;
    }
    std::int64_t nv = -1, nf = -1;
    PCP_CHECK(counts.size() >= 2 && parse_int(counts[0], nv) && parse_int(counts[1], nf) && nv >= 0 &&
                  nf >= 0,
              path << ": line " << lines.line_number()
                   << ": malformed OFF header: expected '<vertices> <faces> <edges>'");
    // Every vertex and face line takes at least a few bytes: refuse counts the file cannot hold
    // before reserving memory for them.
    const std::uint64_t left = lines.rest().size();
    PCP_CHECK(static_cast<std::uint64_t>(nv) <= left / 6 && static_cast<std::uint64_t>(nf) <= left / 8,
              path << ": the header declares " << nv << " vertices and " << nf << " faces but only "
                   << left << " bytes of data follow");
    std::vector<double> xyz;
    xyz.reserve(static_cast<std::size_t>(nv) * 3);
    for (std::int64_t i = 0; i < nv; ++i) {
        PCP_CHECK(next_data_line(), path << ": unexpected end of file after " << i
                                         << " vertices: the header declares " << nv);
        PCP_CHECK(tok.size() >= 3, path << ": line " << lines.line_number()
                                        << ": a vertex line needs three coordinates");
        const std::size_t at = xyz.size();
        for (int c = 0; c < 3; ++c) xyz.push_back(parse_coordinate(path, lines, tok[c]));
        check_finite_point(path, lines, xyz.data() + at);
    }
    std::vector<std::int32_t> tris, poly;
    tris.reserve(static_cast<std::size_t>(nf) * 3);
    for (std::int64_t f = 0; f < nf; ++f) {
        PCP_CHECK(next_data_line(), path << ": unexpected end of file after " << f
                                         << " faces: the header declares " << nf);
        std::int64_t n = 0;
        PCP_CHECK(parse_int(tok[0], n) && n >= 3 && tok.size() >= static_cast<std::size_t>(n) + 1,
                  path << ": line " << lines.line_number()
                       << ": a face line needs a vertex count of at least 3 and that many indices");
        poly.clear();
        for (std::int64_t k = 1; k <= n; ++k) {
            std::int64_t v = -1;
            PCP_CHECK(parse_int(tok[static_cast<std::size_t>(k)], v),
                      path << ": line " << lines.line_number() << ": bad vertex index "
                           << quote_token(tok[static_cast<std::size_t>(k)]));
            PCP_CHECK(v >= 0 && v < nv, path << ": line " << lines.line_number() << ": face " << f
                                             << " refers to vertex " << v << " but the file has " << nv
                                             << " vertices");
            poly.push_back(static_cast<std::int32_t>(v));
        }
        fan_triangulate(poly, tris);
    }
    Mesh mesh;
    mesh.vertices = to_points(xyz);
    mesh.faces = to_faces(tris);
    return mesh;
}

std::string off_bytes(const Mesh& mesh, int precision) {
    std::string out = "OFF\n";
    append_int(out, mesh.vertices.rows());
    out += ' ';
    append_int(out, mesh.faces.rows());
    out += " 0\n";
    for (Eigen::Index i = 0; i < mesh.vertices.rows(); ++i) {
        const double v[3] = {mesh.vertices(i, 0), mesh.vertices(i, 1), mesh.vertices(i, 2)};
        append_row(out, v, 3, precision);
    }
    for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
        out += '3';
        for (int k = 0; k < 3; ++k) {
            out += ' ';
            append_int(out, mesh.faces(f, k));
        }
        out += '\n';
    }
    return out;
}

}  // namespace pcp::io_detail
