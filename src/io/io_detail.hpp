// Private helpers shared by the io readers and writers (src/io*.cpp): whole-file loading with
// the common error messages, a line splitter for text formats, locale-independent number
// parsing and formatting, and the per-format entry points that src/io.cpp dispatches to.
#pragma once

#include "pcp/core/types.hpp"

#include <cstddef>
#include <cstring>
#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace pcp::io_detail {

/// The whole file as bytes. Throws "<path>: cannot open file: <reason>", "<path>: is a
/// directory" or "<path>: file is empty".
std::string read_whole_file(const std::string& path);

/// Parses all of `token` as a double (decimal or exponent form, optional leading '+', "nan" and
/// "inf" accepted: callers check finiteness where it matters). False if anything is left over.
bool parse_double(std::string_view token, double& value);

/// Parses all of `token` as a signed 64-bit decimal integer (optional leading '+').
bool parse_int(std::string_view token, std::int64_t& value);

/// Appends `value` in decimal: the shortest form that reads back bit-exactly if precision <= 0,
/// else `precision` significant digits (printf's %.*g).
void append_double(std::string& out, double value, int precision = 0);

/// Appends a decimal integer.
void append_int(std::string& out, std::int64_t value);

/// Walks a text buffer line by line, tracking 1-based line numbers. Lines exclude the '\n'
/// and a trailing '\r'.
class LineReader {
public:
    explicit LineReader(std::string_view text) : text_(text) {}
    /// False at the end of the buffer; otherwise sets `line` and advances.
    bool next(std::string_view& line);
    /// 1-based number of the line last returned by next().
    std::size_t line_number() const { return line_number_; }
    /// The unread rest of the buffer.
    std::string_view rest() const { return text_.substr(pos_); }
    std::size_t position() const { return pos_; }

private:
    std::string_view text_;
    std::size_t pos_ = 0;
    std::size_t line_number_ = 0;
};

/// Splits `line` at whitespace (and at commas if `commas`) into `tokens` (cleared first).
void split_tokens(std::string_view line, std::vector<std::string_view>& tokens, bool commas = false);

/// True for ' ', '\t', '\r', '\n', '\v', '\f'.
inline bool is_space(char c) {
    return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' || c == '\f';
}

/// A token shortened for an error message (at most 32 characters, quoted).
std::string quote_token(std::string_view token);

/// The order in which point-cloud properties become columns after x y z in .xyz and .npy:
/// nx ny nz first if all three exist, then the rest by name.
std::vector<std::string> property_column_order(const PointCloud& cloud);

/// Throws unless every property of `cloud` has one value per point.
void check_property_sizes(const std::string& path, const PointCloud& cloud);

/// Names of the extra columns after x y z for a table of `columns` columns: nx ny nz for six,
/// else c3, c4, ...
std::vector<std::string> extra_column_names(std::size_t columns);

// Per-format entry points; `data` is the whole file (see read_whole_file).
PointCloud read_ply_point_cloud(const std::string& path, const std::string& data);
Mesh read_ply_mesh(const std::string& path, const std::string& data);
PointCloud read_xyz(const std::string& path, const std::string& data, bool allow_count_line);
PointCloud read_npy(const std::string& path, const std::string& data);
Mesh read_obj(const std::string& path, const std::string& data);
Mesh read_off(const std::string& path, const std::string& data);

// Writers fill a byte buffer; src/io.cpp hands it to write_file_atomically.
std::string ply_point_cloud_bytes(const std::string& path, const PointCloud& cloud, bool ascii);
std::string xyz_bytes(const PointCloud& cloud);
std::string npy_bytes(const PointCloud& cloud);
std::string ply_mesh_bytes(const Mesh& mesh, bool ascii, int precision);
std::string obj_bytes(const Mesh& mesh, int precision);
std::string off_bytes(const Mesh& mesh, int precision);

/// A scalar of type T read from `p` (binary file data), with its bytes reversed if `swap`.
template <class T>
T load(const unsigned char* p, bool swap) {
    unsigned char b[sizeof(T)];
    if (swap)
        for (std::size_t k = 0; k < sizeof(T); ++k) b[k] = p[sizeof(T) - 1 - k];
    else
        std::memcpy(b, p, sizeof(T));
    T v;
    std::memcpy(&v, b, sizeof(T));
    return v;
}

}  // namespace pcp::io_detail
