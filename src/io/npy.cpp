// NumPy .npy point tables: a reader for format versions 1, 2 and 3 (magic, version, header
// length, then a Python dict literal giving 'descr', 'fortran_order' and 'shape') with float32 or
// float64 data of either byte order in C or Fortran order, and a float64 C-order writer. Only
// 2-D arrays of shape (N, k >= 3) are point clouds; the byte count the shape implies is checked
// against the file before anything is allocated.
#include "io/io_detail.hpp"
#include "pcp/core/error.hpp"

#include <cmath>
#include <cstring>

namespace {
/// Columns beyond x, y, z become named properties; more than this is not a point cloud (and a
/// damaged shape of (0, 2^26) would otherwise name 67 million empty columns: found by fuzz_npy).
constexpr std::int64_t kMaxNpyColumns = 1024;
}  // namespace

namespace pcp::io_detail {
namespace {

constexpr char kMagic[] = "\x93NUMPY";
constexpr std::size_t kMagicSize = 6;
constexpr bool kHostBigEndian = __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__;

// Position just after "'key':" (or "\"key\":") and any spaces in `dict`, or npos.
std::size_t find_value(std::string_view dict, std::string_view key) {
    for (char q : {'\'', '"'}) {
        const std::string pattern = std::string(1, q) + std::string(key) + q;
        std::size_t at = dict.find(pattern);
        if (at == std::string_view::npos) continue;
        at += pattern.size();
        while (at < dict.size() && is_space(dict[at])) ++at;
        if (at >= dict.size() || dict[at] != ':') return std::string_view::npos;
        ++at;
        while (at < dict.size() && is_space(dict[at])) ++at;
        return at;
    }
    return std::string_view::npos;
}

}  // namespace

PointCloud read_npy(const std::string& path, const std::string& data) {
    PCP_CHECK(data.size() >= kMagicSize + 4 && data.compare(0, kMagicSize, kMagic, kMagicSize) == 0,
              path << ": not a NumPy .npy file (bad magic bytes)");
    const unsigned char* bytes = reinterpret_cast<const unsigned char*>(data.data());
    const int major = bytes[6];
    PCP_CHECK(major >= 1 && major <= 3,
              path << ": unsupported .npy format version " << major << " (supported: 1, 2, 3)");
    std::size_t header_len = 0, offset = 0;
    if (major == 1) {
        header_len = static_cast<std::size_t>(bytes[8]) | static_cast<std::size_t>(bytes[9]) << 8;
        offset = 10;
    } else {
        PCP_CHECK(data.size() >= 12, path << ": truncated .npy header");
        header_len = static_cast<std::size_t>(bytes[8]) | static_cast<std::size_t>(bytes[9]) << 8 |
                     static_cast<std::size_t>(bytes[10]) << 16 | static_cast<std::size_t>(bytes[11]) << 24;
        offset = 12;
    }
    PCP_CHECK(header_len <= data.size() - offset,
              path << ": truncated .npy header (declares " << header_len << " bytes, "
                   << data.size() - offset << " follow)");
    const std::string_view dict(data.data() + offset, header_len);
    offset += header_len;

    // descr: '<f8', '>f4', '=f8', ...
    std::size_t at = find_value(dict, "descr");
    PCP_CHECK(at != std::string_view::npos && (dict[at] == '\'' || dict[at] == '"'),
              path << ": malformed .npy header: no 'descr' string (structured dtypes are not supported)");
    const std::size_t end = dict.find(dict[at], at + 1);
    PCP_CHECK(end != std::string_view::npos, path << ": malformed .npy header: unterminated 'descr'");
    const std::string_view descr = dict.substr(at + 1, end - at - 1);
    PCP_CHECK(descr.size() == 3 && (descr[0] == '<' || descr[0] == '>' || descr[0] == '=') &&
                  descr[1] == 'f' && (descr[2] == '4' || descr[2] == '8'),
              path << ": unsupported .npy dtype " << quote_token(descr)
                   << " (supported: float32 or float64, e.g. '<f4', '<f8', '>f8')");
    const bool big = descr[0] == '>' || (descr[0] == '=' && kHostBigEndian);
    const bool swap = big != kHostBigEndian;
    const std::size_t item = descr[2] == '4' ? 4 : 8;

    at = find_value(dict, "fortran_order");
    PCP_CHECK(at != std::string_view::npos &&
                  (dict.substr(at, 4) == "True" || dict.substr(at, 5) == "False"),
              path << ": malformed .npy header: no 'fortran_order' True/False");
    const bool fortran = dict.substr(at, 4) == "True";

    at = find_value(dict, "shape");
    PCP_CHECK(at != std::string_view::npos && dict[at] == '(',
              path << ": malformed .npy header: no 'shape' tuple");
    const std::size_t close = dict.find(')', at);
    PCP_CHECK(close != std::string_view::npos, path << ": malformed .npy header: unterminated 'shape'");
    std::vector<std::string_view> parts;
    split_tokens(dict.substr(at + 1, close - at - 1), parts, true);
    std::vector<std::int64_t> shape;
    for (std::string_view p : parts) {
        std::int64_t d = -1;
        PCP_CHECK(parse_int(p, d) && d >= 0,
                  path << ": malformed .npy header: bad shape entry " << quote_token(p));
        shape.push_back(d);
    }
    std::string shape_text = "(";
    for (std::size_t k = 0; k < shape.size(); ++k)
        shape_text += (k ? ", " : "") + std::to_string(shape[k]);
    shape_text += shape.size() == 1 ? ",)" : ")";
    PCP_CHECK(shape.size() == 2 && shape[1] >= 3 && shape[1] <= kMaxNpyColumns,
              path << ": unsupported .npy shape " << shape_text
                   << " (a point cloud is (N, 3), (N, 6) with normals, or (N, k) with 3 <= k <= " << kMaxNpyColumns << ")");

    const std::uint64_t rows = static_cast<std::uint64_t>(shape[0]);
    const std::uint64_t cols = static_cast<std::uint64_t>(shape[1]);
    const std::uint64_t left = data.size() - offset;
    // rows * cols * item must equal `left`; divide rather than multiply so that a corrupt shape
    // cannot overflow.
    const bool fits = rows == 0 || (cols <= left / item && rows <= left / (cols * item));
    PCP_CHECK(fits && rows * cols * item == left,
              path << ": " << (fits && rows * cols * item < left ? "unexpected trailing bytes" : "truncated .npy data")
                   << ": shape " << shape_text << " of " << (item == 4 ? "float32" : "float64") << " needs "
                   << (fits ? std::to_string(rows * cols * item) : std::string("more")) << " bytes but "
                   << left << " follow the header");

    const Eigen::Index n = static_cast<Eigen::Index>(rows);
    const unsigned char* body = bytes + offset;
    // Element (i, c) is at i * cols + c (C order) or c * rows + i (Fortran order).
    auto value = [&](std::uint64_t i, std::uint64_t c) {
        const std::uint64_t k = fortran ? c * rows + i : i * cols + c;
        return item == 4 ? load<float>(body + k * 4, swap) : load<double>(body + k * 8, swap);
    };
    PointCloud cloud;
    cloud.points.resize(n, 3);
    const std::vector<std::string> names = extra_column_names(static_cast<std::size_t>(cols));
    for (const std::string& name : names) cloud.properties[name].resize(n);
    for (std::uint64_t i = 0; i < rows; ++i) {
        const Eigen::Index r = static_cast<Eigen::Index>(i);
        for (std::uint64_t c = 0; c < 3; ++c) cloud.points(r, static_cast<Eigen::Index>(c)) = value(i, c);
        PCP_CHECK(cloud.points.row(r).allFinite(),
                  path << ": point " << i << " has a non-finite coordinate (" << cloud.points(r, 0) << ", "
                       << cloud.points(r, 1) << ", " << cloud.points(r, 2) << ")");
        for (std::uint64_t c = 3; c < cols; ++c) cloud.properties[names[c - 3]](r) = value(i, c);
    }
    return cloud;
}

std::string npy_bytes(const PointCloud& cloud) {
    const std::vector<std::string> order = property_column_order(cloud);
    const Eigen::Index n = cloud.points.rows();
    const std::size_t cols = 3 + order.size();
    std::string dict = "{'descr': '<f8', 'fortran_order': False, 'shape': (" + std::to_string(n) + ", " +
                       std::to_string(cols) + "), }";
    // Version 1: 10 bytes of preamble; pad the dict with spaces so the data starts on a
    // 64-byte boundary, ending the header with '\n' as NumPy does.
    std::size_t total = 10 + dict.size() + 1;
    dict.append((64 - total % 64) % 64, ' ');
    dict += '\n';
    std::string out(kMagic, kMagicSize);
    out += static_cast<char>(1);
    out += static_cast<char>(0);
    out += static_cast<char>(dict.size() & 0xff);
    out += static_cast<char>((dict.size() >> 8) & 0xff);
    out += dict;
    std::vector<const Eigen::VectorXd*> props;
    for (const std::string& name : order) props.push_back(&cloud.properties.at(name));
    out.reserve(out.size() + static_cast<std::size_t>(n) * cols * 8);
    auto put = [&out](double v) {
        unsigned char b[8];
        std::memcpy(b, &v, 8);
        if (kHostBigEndian)
            for (int k = 0; k < 4; ++k) std::swap(b[k], b[7 - k]);
        out.append(reinterpret_cast<const char*>(b), 8);
    };
    for (Eigen::Index i = 0; i < n; ++i) {
        for (int c = 0; c < 3; ++c) put(cloud.points(i, c));
        for (const Eigen::VectorXd* v : props) put((*v)(i));
    }
    return out;
}

}  // namespace pcp::io_detail
