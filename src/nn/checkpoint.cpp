// Network files (see pcp/nn/checkpoint.hpp): serialisation into one byte buffer with a trailing
// FNV-1a checksum, atomic write, and a loader that checks size, magic, version, checksum and every
// length field before it trusts the content.
#include "pcp/nn/checkpoint.hpp"

#include "pcp/core/error.hpp"
#include "pcp/core/files.hpp"

#include <algorithm>
#include <cstring>
#include <fstream>
#include <iterator>
#include <ostream>

namespace pcp::nn {

namespace {

constexpr char kMagic[8] = {'P', 'C', 'P', 'N', 'N', 'E', 'T', '\n'};
constexpr std::size_t kFixedHeader = 8 + 4 + 4 + 8;  // magic, version, scalar bytes, payload size

class Writer {
public:
    template <class T>
    void put(const T& v) {
        const char* p = reinterpret_cast<const char*>(&v);
        buf.insert(buf.end(), p, p + sizeof(T));
    }
    void put_bytes(const void* p, std::size_t n) {
        const char* c = static_cast<const char*>(p);
        buf.insert(buf.end(), c, c + n);
    }
    std::string buf;
};

class Reader {
public:
    Reader(const std::string& path, const char* data, std::size_t size)
        : path_(path), p_(data), end_(data + size) {}
    template <class T>
    T get(const char* what) {
        need(sizeof(T), what);
        T v;
        std::memcpy(&v, p_, sizeof(T));
        p_ += sizeof(T);
        return v;
    }
    const char* take(std::size_t n, const char* what) {
        need(n, what);
        const char* r = p_;
        p_ += n;
        return r;
    }
    bool at_end() const { return p_ == end_; }

private:
    void need(std::size_t n, const char* what) {
        PCP_CHECK(std::size_t(end_ - p_) >= n,
                  path_ << ": corrupt network file: " << what << " runs past the end of the payload");
    }
    std::string path_;
    const char* p_;
    const char* end_;
};

template <class T, class S>
void put_scalars(Writer& w, const Vec<S>& v) {
    for (Eigen::Index i = 0; i < v.size(); ++i) w.put(static_cast<T>(v(i)));
}

template <class T, class S>
Vec<S> get_scalars(Reader& r, std::uint64_t n, const char* what) {
    const char* p = r.take(n * sizeof(T), what);
    Vec<S> v(static_cast<Eigen::Index>(n));
    for (std::uint64_t i = 0; i < n; ++i) {
        T x;
        std::memcpy(&x, p + i * sizeof(T), sizeof(T));
        v(static_cast<Eigen::Index>(i)) = static_cast<S>(x);
    }
    return v;
}

template <class T, class S>
std::string serialise(const NetFile<S>& f) {
    Writer w;
    w.put_bytes(kMagic, 8);
    w.put(kNetFileVersion);
    w.put(std::uint32_t(sizeof(T)));
    w.put(std::uint64_t(0));  // payload size, patched below
    const std::size_t payload_start = w.buf.size();
    w.put(f.step);
    for (int i = 0; i < 4; ++i) w.put(std::uint64_t(0));  // reserved
    w.put(std::uint64_t(f.metadata.size()));
    w.put_bytes(f.metadata.data(), f.metadata.size());
    w.put(std::uint32_t(f.nets.size()));
    for (const NetRecord<S>& n : f.nets) {
        w.put(std::uint32_t(n.name.size()));
        w.put_bytes(n.name.data(), n.name.size());
        w.put(static_cast<std::uint32_t>(n.kind));
        w.put(std::uint32_t(n.shape.size()));
        for (std::int32_t x : n.shape) w.put(x);
        w.put(std::uint64_t(n.params.size()));
        w.put(std::int64_t(n.adam.t));
        w.put(std::uint8_t(n.has_adam ? 1 : 0));
        put_scalars<T>(w, n.params);
        if (n.has_adam) {
            PCP_CHECK(n.adam.m.size() == n.params.size() && n.adam.v.size() == n.params.size(),
                      "nn::save_net_file: network '" << n.name
                                                     << "': Adam moments do not match the parameters");
            put_scalars<T>(w, n.adam.m);
            put_scalars<T>(w, n.adam.v);
        }
    }
    const std::uint64_t payload = w.buf.size() - payload_start;
    std::memcpy(&w.buf[payload_start - 8], &payload, 8);
    const std::uint64_t sum = fnv1a64(w.buf.data(), w.buf.size());
    w.put(sum);
    return std::move(w.buf);
}

template <class T, class S>
NetFile<S> parse(const std::string& path, Reader& r) {
    NetFile<S> f;
    f.step = r.template get<std::uint64_t>("step");
    for (int i = 0; i < 4; ++i) r.template get<std::uint64_t>("reserved words");
    const auto meta_len = r.template get<std::uint64_t>("metadata length");
    const char* meta = r.take(static_cast<std::size_t>(meta_len), "metadata");
    f.metadata.assign(meta, static_cast<std::size_t>(meta_len));
    const auto count = r.template get<std::uint32_t>("network count");
    for (std::uint32_t k = 0; k < count; ++k) {
        NetRecord<S> n;
        const auto len = r.template get<std::uint32_t>("name length");
        const char* name = r.take(len, "network name");
        n.name.assign(name, len);
        n.kind = static_cast<NetKind>(r.template get<std::uint32_t>("network kind"));
        PCP_CHECK(n.kind == NetKind::BranchMlp || n.kind == NetKind::PointNet,
                  path << ": corrupt network file: network '" << n.name << "' has unknown kind "
                       << static_cast<std::uint32_t>(n.kind));
        const auto ns = r.template get<std::uint32_t>("shape length");
        PCP_CHECK(ns <= 4096, path << ": corrupt network file: shape of '" << n.name
                                   << "' has " << ns << " entries");
        for (std::uint32_t i = 0; i < ns; ++i) n.shape.push_back(r.template get<std::int32_t>("shape"));
        const auto np = r.template get<std::uint64_t>("parameter count");
        n.adam.t = r.template get<std::int64_t>("Adam step");
        n.has_adam = r.template get<std::uint8_t>("Adam flag") != 0;
        PCP_CHECK(np <= (std::uint64_t(1) << 40), path << ": corrupt network file: '" << n.name
                                                        << "' claims " << np << " parameters");
        n.params = get_scalars<T, S>(r, np, "parameters");
        if (n.has_adam) {
            n.adam.m = get_scalars<T, S>(r, np, "Adam first moment");
            n.adam.v = get_scalars<T, S>(r, np, "Adam second moment");
        }
        f.nets.push_back(std::move(n));
    }
    PCP_CHECK(r.at_end(), path << ": corrupt network file: unexpected bytes after the last network");
    return f;
}

BranchMlpShape branch_shape_of(const std::vector<std::int32_t>& s, const std::string& name) {
    PCP_CHECK(s.size() == 5, "network '" << name << "': a BranchMlp shape has 5 entries, got "
                                         << s.size());
    return BranchMlpShape{s[0], s[1], s[2], s[3], s[4]};
}

PointNetShape pointnet_shape_of(const std::vector<std::int32_t>& s, const std::string& name) {
    PointNetShape r;
    PCP_CHECK(!s.empty() && s[0] >= 0 && std::size_t(s[0]) + 1 < s.size(),
              "network '" << name << "': malformed PointNet shape");
    r.point_widths.assign(s.begin() + 1, s.begin() + 1 + s[0]);
    const std::size_t h = 1 + std::size_t(s[0]);
    PCP_CHECK(s[h] >= 0 && h + 1 + std::size_t(s[h]) == s.size(),
              "network '" << name << "': malformed PointNet shape");
    r.head_widths.assign(s.begin() + h + 1, s.end());
    return r;
}

}  // namespace

template <class S>
const NetRecord<S>& NetFile<S>::get(const std::string& name) const {
    for (const auto& n : nets)
        if (n.name == name) return n;
    PCP_FAIL("network file has no network called '" << name << "'");
}

template <class S>
NetRecord<S> make_record(const std::string& name, const BranchMlp<S>& net,
                         const AdamState<S>* adam) {
    NetRecord<S> r;
    r.name = name;
    r.kind = NetKind::BranchMlp;
    const auto& s = net.shape;
    r.shape = {s.in_a, s.in_b, s.width, s.depth, s.out};
    r.params = net.params;
    if (adam) {
        r.has_adam = true;
        r.adam = *adam;
    }
    return r;
}

template <class S>
NetRecord<S> make_record(const std::string& name, const PointNet<S>& net,
                         const AdamState<S>* adam) {
    NetRecord<S> r;
    r.name = name;
    r.kind = NetKind::PointNet;
    r.shape.push_back(std::int32_t(net.shape.point_widths.size()));
    r.shape.insert(r.shape.end(), net.shape.point_widths.begin(), net.shape.point_widths.end());
    r.shape.push_back(std::int32_t(net.shape.head_widths.size()));
    r.shape.insert(r.shape.end(), net.shape.head_widths.begin(), net.shape.head_widths.end());
    r.params = net.params;
    if (adam) {
        r.has_adam = true;
        r.adam = *adam;
    }
    return r;
}

/// Copies the record's parameters into `net`, whose shape came from the record.
template <class S, class Net>
void copy_params(const NetRecord<S>& rec, Net& net) {
    PCP_CHECK(rec.params.size() == net.layout.size(),
              "network '" << rec.name << "': " << rec.params.size() << " parameters stored, its shape needs "
                          << net.layout.size());
    net.params = rec.params;
}

/// Refuses a record whose shape does not need exactly its stored parameters, before any network
/// of that shape is allocated (a damaged shape could otherwise ask for terabytes). `count` is the
/// shape's parameter count in double precision (no integer overflow), -1 for an invalid shape.
template <class S>
void check_param_count(const NetRecord<S>& rec, double count) {
    PCP_CHECK(count >= 0, "network '" << rec.name << "': invalid shape");
    PCP_CHECK(count == static_cast<double>(rec.params.size()),
              "network '" << rec.name << "': " << rec.params.size() << " parameters stored, its shape needs " << count);
}

double branch_param_count(const BranchMlpShape& s) {
    if (s.in_a < 1 || s.in_b < 0 || s.width < 1 || s.depth < 1 || s.out < 1) return -1;
    const double H = s.width;
    double n = H * s.in_a + H;
    if (s.in_b > 0) n += H * s.in_b + H;
    n += H * (s.in_b > 0 ? 2 * H : H) + H;
    n += (s.depth - 1) * (H * H + H);
    return n + s.out * H + s.out;
}

double pointnet_param_count(const PointNetShape& s) {
    double n = 0;
    for (const std::vector<int>* widths : {&s.point_widths, &s.head_widths}) {
        if (widths->size() < 2) return -1;
        for (std::size_t k = 0; k < widths->size(); ++k) {
            if ((*widths)[k] < 1) return -1;
            if (k > 0) n += static_cast<double>((*widths)[k]) * (*widths)[k - 1] + (*widths)[k];
        }
    }
    return n;
}

template <class S>
BranchMlp<S> to_branch_mlp(const NetRecord<S>& rec) {
    PCP_CHECK(rec.kind == NetKind::BranchMlp, "network '" << rec.name << "' is not a BranchMlp");
    const BranchMlpShape shape = branch_shape_of(rec.shape, rec.name);
    check_param_count(rec, branch_param_count(shape));
    BranchMlp<S> net(shape);
    copy_params(rec, net);
    return net;
}

template <class S>
PointNet<S> to_pointnet(const NetRecord<S>& rec) {
    PCP_CHECK(rec.kind == NetKind::PointNet, "network '" << rec.name << "' is not a PointNet");
    const PointNetShape shape = pointnet_shape_of(rec.shape, rec.name);
    check_param_count(rec, pointnet_param_count(shape));
    PointNet<S> net(shape);
    copy_params(rec, net);
    return net;
}

template <class S>
void save_net_file(const std::string& path, const NetFile<S>& file) {
    const std::string bytes = serialise<S>(file);
    write_file_atomically(path, [&](std::ostream& out) {
        out.write(bytes.data(), std::streamsize(bytes.size()));
    });
}

template <class S>
NetFile<S> load_net_file(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    PCP_CHECK(in, path << ": cannot open network file");
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    PCP_CHECK(!in.bad(), path << ": read error");
    return parse_net_file<S>(path, bytes);
}

template <class S>
NetFile<S> parse_net_file(const std::string& path, const std::string& bytes) {
    PCP_CHECK(std::memcmp(bytes.data(), kMagic, std::min<std::size_t>(8, bytes.size())) == 0,
              path << ": not a libpcp network file (bad magic)");
    PCP_CHECK(bytes.size() >= kFixedHeader,
              path << ": truncated network file: " << bytes.size() << " bytes, the header alone needs "
                   << kFixedHeader);
    std::uint32_t version, scalar;
    std::uint64_t payload;
    std::memcpy(&version, bytes.data() + 8, 4);
    std::memcpy(&scalar, bytes.data() + 12, 4);
    std::memcpy(&payload, bytes.data() + 16, 8);
    PCP_CHECK(version == kNetFileVersion,
              path << ": network file format version " << version << ", this build of libpcp reads version "
                   << kNetFileVersion << " (re-train or convert the file with a matching libpcp)");
    PCP_CHECK(scalar == 4 || scalar == 8,
              path << ": corrupt network file: scalar size " << scalar);
    const std::uint64_t expected = kFixedHeader + payload + 8;
    PCP_CHECK(payload <= bytes.size() && bytes.size() >= expected,
              path << ": truncated network file: " << bytes.size() << " bytes, the header announces "
                   << expected << " (interrupted copy?)");
    PCP_CHECK(bytes.size() == expected,
              path << ": corrupt network file: " << bytes.size() - expected << " unexpected trailing bytes");
    std::uint64_t stored;
    std::memcpy(&stored, bytes.data() + expected - 8, 8);
    PCP_CHECK(fnv1a64(bytes.data(), expected - 8) == stored,
              path << ": corrupt network file: checksum mismatch (the file was modified or damaged)");
    Reader r(path, bytes.data() + kFixedHeader, payload);
    return scalar == 4 ? parse<float, S>(path, r) : parse<double, S>(path, r);
}

#define PCP_NN_INSTANTIATE_CHECKPOINT(S)                                                           \
    template struct NetFile<S>;                                                                    \
    template NetRecord<S> make_record<S>(const std::string&, const BranchMlp<S>&,                  \
                                         const AdamState<S>*);                                     \
    template NetRecord<S> make_record<S>(const std::string&, const PointNet<S>&,                   \
                                         const AdamState<S>*);                                     \
    template BranchMlp<S> to_branch_mlp<S>(const NetRecord<S>&);                                   \
    template PointNet<S> to_pointnet<S>(const NetRecord<S>&);                                      \
    template void save_net_file<S>(const std::string&, const NetFile<S>&);                         \
    template NetFile<S> load_net_file<S>(const std::string&);                                      \
    template NetFile<S> parse_net_file<S>(const std::string&, const std::string&);
PCP_NN_INSTANTIATE_CHECKPOINT(float)
PCP_NN_INSTANTIATE_CHECKPOINT(double)
#undef PCP_NN_INSTANTIATE_CHECKPOINT

}  // namespace pcp::nn
