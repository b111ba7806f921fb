// The key=value metadata codec of network files (see pcp/nn/metadata.hpp).
#include "pcp/nn/metadata.hpp"

#include "pcp/core/error.hpp"

#include <cstdio>
#include <cstdlib>

namespace pcp::nn {

Metadata::Metadata(const std::string& text, std::string source) : source_(std::move(source)) {
    std::istringstream in(text);
    std::string line;
    while (std::getline(in, line)) {
        const auto eq = line.find('=');
        PCP_CHECK(eq != std::string::npos, source_ << ": malformed metadata line '" << line << "'");
        entries_.emplace_back(line.substr(0, eq), line.substr(eq + 1));
    }
}

void Metadata::add(const std::string& key, const std::string& value) {
    PCP_CHECK(key.find_first_of("=\n") == std::string::npos && value.find('\n') == std::string::npos,
              "nn::Metadata: key '" << key << "' or its value holds '=' or a line break");
    entries_.emplace_back(key, value);
}

void Metadata::add_floats(const std::string& key, const Vec<float>& values) {
    std::string s;
    char buf[48];
    for (Eigen::Index i = 0; i < values.size(); ++i) {
        std::snprintf(buf, sizeof buf, i ? " %a" : "%a", static_cast<double>(values(i)));
        s += buf;
    }
    add(key, s);
}

bool Metadata::has(const std::string& key) const {
    for (const auto& [k, v] : entries_)
        if (k == key) return true;
    return false;
}

const std::string& Metadata::get(const std::string& key) const {
    for (const auto& [k, v] : entries_)
        if (k == key) return v;
    PCP_FAIL(source_ << " lacks '" << key << "'");
}

std::vector<std::string> Metadata::all(const std::string& key) const {
    std::vector<std::string> out;
    for (const auto& [k, v] : entries_)
        if (k == key) out.push_back(v);
    return out;
}

Vec<float> Metadata::floats(const std::string& key, Eigen::Index n) const {
    const std::string& text = get(key);
    const char* p = text.c_str();
    Vec<float> v(n);
    for (Eigen::Index i = 0; i < n; ++i) {
        char* end = nullptr;
        v(i) = static_cast<float>(std::strtod(p, &end));
        PCP_CHECK(end != p, source_ << ": corrupt '" << key << "' (" << i << " of " << n << " values)");
        p = end;
    }
    return v;
}

void Metadata::expect(const std::string& key, const std::string& expected, const std::string& message) const {
    PCP_CHECK(get(key) == expected, source_ << ": " << message);
}

std::string Metadata::text() const {
    std::string s;
    for (const auto& [k, v] : entries_) s += k + "=" + v + "\n";
    return s;
}

void Metadata::check_parsed(bool ok, const std::string& key, const std::string& value) const {
    PCP_CHECK(ok, source_ << ": bad value '" << value << "' for '" << key << "'");
}

}  // namespace pcp::nn
