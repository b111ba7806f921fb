// The metadata text of network files (nn/checkpoint.hpp): "key=value" lines, in order, keys may
// repeat. One codec for prior files and both trainers' checkpoints: numbers are written with
// enough digits to read back exactly, float vectors as hexadecimal floats.
#pragma once

#include "pcp/nn/common.hpp"

#include <cstdint>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace pcp::nn {

class Metadata {
public:
    Metadata() = default;
    /// Parses `text`; `source` ("<path>: the prior file", "<path>: the checkpoint") starts every
    /// error message. A line without '=' is refused.
    Metadata(const std::string& text, std::string source);

    void add(const std::string& key, const std::string& value);
    template <class T>
    void add_number(const std::string& key, T value) {
        std::ostringstream s;
        s.precision(17);
        s << value;
        add(key, s.str());
    }
    void add_floats(const std::string& key, const Vec<float>& values);  ///< exact (hexadecimal)

    bool has(const std::string& key) const;
    const std::string& get(const std::string& key) const;  ///< the first value; throws if absent
    std::vector<std::string> all(const std::string& key) const;
    template <class T>
    T number(const std::string& key) const {
        const std::string& v = get(key);
        std::istringstream in(v);
        T x{};
        in >> x;
        check_parsed(!in.fail() && in.eof(), key, v);
        return x;
    }
    Vec<float> floats(const std::string& key, Eigen::Index n) const;  ///< exactly n values
    /// Throws "<source>: <message>" unless get(key) == expected.
    void expect(const std::string& key, const std::string& expected, const std::string& message) const;

    std::string text() const;

private:
    void check_parsed(bool ok, const std::string& key, const std::string& value) const;
    std::vector<std::pair<std::string, std::string>> entries_;
    std::string source_ = "metadata";
};

}  // namespace pcp::nn
