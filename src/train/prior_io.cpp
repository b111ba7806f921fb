// Prior files and training checkpoints, on top of the network file format of nn/checkpoint.hpp
// (magic, format version, checksum, atomic writes). A prior file (".pcpm") holds the records
// "encoder" and "decoder" and, in the file's metadata, "key=value" lines: the format tag
// "pcp-prior 1", the settings needed to use the prior (region grid and normalisation, sampling,
// network sizes) and its provenance (inputs, steps, final loss, library version). Checkpoints of
// the trainers add the Adam state and a fingerprint of the inputs and settings, so that --resume
// refuses a checkpoint written for something else.
#include "pcp/core/error.hpp"
#include "pcp/nn/checkpoint.hpp"
#include "pcp/train/prior.hpp"
#include "pcp/version.hpp"

#include <map>
#include <sstream>

namespace pcp {

namespace {

constexpr const char* kPriorFormat = "pcp-prior 1";

std::string join_floats(const std::vector<float>& v) {
    std::ostringstream s;
    s.precision(9);
    for (std::size_t i = 0; i < v.size(); ++i) s << (i ? "," : "") << v[i];
    return s.str();
}

std::multimap<std::string, std::string> parse_metadata(const std::string& path, const std::string& text) {
    std::multimap<std::string, std::string> kv;
    std::istringstream in(text);
    std::string line;
    while (std::getline(in, line)) {
        const auto eq = line.find('=');
        PCP_CHECK(eq != std::string::npos, path << ": malformed prior metadata line '" << line << "'");
        kv.emplace(line.substr(0, eq), line.substr(eq + 1));
    }
    return kv;
}

const std::string& value_of(const std::multimap<std::string, std::string>& kv, const std::string& path,
                            const std::string& key) {
    const auto it = kv.find(key);
    PCP_CHECK(it != kv.end(), path << ": the prior file lacks '" << key << "'");
    return it->second;
}

template <class T>
T number_of(const std::multimap<std::string, std::string>& kv, const std::string& path, const std::string& key) {
    const std::string& v = value_of(kv, path, key);
    std::istringstream in(v);
    T x{};
    in >> x;
    PCP_CHECK(!in.fail() && in.eof(), path << ": bad value '" << v << "' for '" << key << "' in the prior file");
    return x;
}

}  // namespace

void save_prior(const std::string& path, const LocalPrior& prior) {
    std::ostringstream meta;
    meta.precision(17);
    meta << "format=" << kPriorFormat << "\n"
         << "library_version=" << PCP_VERSION_STRING << "\n"
         << "grid=" << prior.regions.grid << "\n"
         << "normalization=" << to_string(prior.regions.normalization) << "\n"
         << "min_region_points=" << prior.regions.min_points << "\n"
         << "sigma_neighbor=" << prior.sampling.sigma_neighbor << "\n"
         << "queries_per_point=" << prior.sampling.queries_per_point << "\n"
         << "spreads=" << join_floats(prior.sampling.spreads) << "\n"
         << "uniform_fraction=" << prior.sampling.uniform_fraction << "\n"
         << "uniform_margin=" << prior.sampling.uniform_margin << "\n"
         << "width=" << prior.network.width << "\n"
         << "depth=" << prior.network.depth << "\n"
         << "condition=" << prior.network.condition << "\n"
         << "pointnet_width=" << prior.network.pointnet_width << "\n"
         << "pointnet_hidden=" << prior.network.pointnet_hidden << "\n"
         << "steps=" << prior.provenance.steps << "\n"
         << "final_loss=" << prior.provenance.final_loss << "\n"
         << "trained_with=" << prior.provenance.library_version << "\n"
         << "settings=" << prior.provenance.settings << "\n";
    for (const std::string& input : prior.provenance.inputs) meta << "input=" << input << "\n";
    nn::NetFile<float> file;
    file.step = static_cast<std::uint64_t>(prior.provenance.steps);
    file.metadata = meta.str();
    file.nets.push_back(nn::make_record("encoder", prior.encoder()));
    file.nets.push_back(nn::make_record("decoder", prior.decoder()));
    nn::save_net_file(path, file);
}

LocalPrior load_prior(const std::string& path) {
    const nn::NetFile<float> file = nn::load_net_file<float>(path);
    const auto kv = parse_metadata(path, file.metadata);
    const auto format = kv.find("format");
    PCP_CHECK(format != kv.end(), path << ": not a prior file (a network file without prior settings)");
    PCP_CHECK(format->second == kPriorFormat,
              path << ": prior format '" << format->second << "' is not supported (this version reads '" << kPriorFormat << "')");
    LocalPrior prior;
    prior.regions.grid = number_of<int>(kv, path, "grid");
    prior.regions.normalization = parse_region_normalization(value_of(kv, path, "normalization"));
    prior.regions.min_points = number_of<Eigen::Index>(kv, path, "min_region_points");
    prior.sampling.sigma_neighbor = number_of<int>(kv, path, "sigma_neighbor");
    prior.sampling.queries_per_point = number_of<int>(kv, path, "queries_per_point");
    prior.sampling.spreads.clear();
    std::istringstream spreads(value_of(kv, path, "spreads"));
    for (std::string item; std::getline(spreads, item, ',');) prior.sampling.spreads.push_back(std::stof(item));
    prior.sampling.uniform_fraction = number_of<float>(kv, path, "uniform_fraction");
    prior.sampling.uniform_margin = number_of<float>(kv, path, "uniform_margin");
    prior.network.width = number_of<int>(kv, path, "width");
    prior.network.depth = number_of<int>(kv, path, "depth");
    prior.network.condition = number_of<int>(kv, path, "condition");
    prior.network.pointnet_width = number_of<int>(kv, path, "pointnet_width");
    prior.network.pointnet_hidden = number_of<int>(kv, path, "pointnet_hidden");
    prior.provenance.steps = number_of<std::int64_t>(kv, path, "steps");
    prior.provenance.final_loss = number_of<double>(kv, path, "final_loss");
    prior.provenance.library_version = value_of(kv, path, "trained_with");
    prior.provenance.settings = value_of(kv, path, "settings");
    for (auto [it, end] = kv.equal_range("input"); it != end; ++it) prior.provenance.inputs.push_back(it->second);
    prior.encoder() = nn::to_pointnet(file.get("encoder"));
    prior.decoder() = nn::to_branch_mlp(file.get("decoder"));
    PCP_CHECK(prior.decoder().shape.width == prior.network.width && prior.decoder().shape.depth == prior.network.depth &&
                  prior.decoder().shape.in_b == prior.network.condition && prior.encoder().shape.cond() == prior.network.condition,
              path << ": the stored networks do not match the prior's recorded sizes (corrupt file?)");
    return prior;
}

}  // namespace pcp
