// Prior files and training checkpoints, on top of the network file format of nn/checkpoint.hpp
// (magic, format version, checksum, atomic writes). A prior file (".pcpm") holds the records
// "encoder" and "decoder" and, in the file's metadata, "key=value" lines: the format tag
// "pcp-prior 1", the settings needed to use the prior (region grid and normalisation, sampling,
// network sizes) and its provenance (inputs, steps, final loss, library version). Checkpoints of
// the trainers add the Adam state and a fingerprint of the inputs and settings, so that --resume
// refuses a checkpoint written for something else.
#include "pcp/core/error.hpp"
#include "pcp/nn/checkpoint.hpp"
#include "pcp/nn/metadata.hpp"
#include "pcp/train/prior.hpp"
#include "train/prior_io.hpp"
#include "pcp/version.hpp"

#include <cmath>
#include <cstdlib>
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

}  // namespace

void save_prior(const std::string& path, const LocalPrior& prior) {
    nn::Metadata meta;
    meta.add("format", kPriorFormat);
    meta.add("library_version", PCP_VERSION_STRING);
    meta.add_number("grid", prior.regions.grid);
    meta.add("normalization", to_string(prior.regions.normalization));
    meta.add_number("min_region_points", prior.regions.min_points);
    meta.add_number("sigma_neighbor", prior.sampling.sigma_neighbor);
    meta.add_number("queries_per_point", prior.sampling.queries_per_point);
    meta.add("spreads", join_floats(prior.sampling.spreads));
    meta.add_number("uniform_fraction", prior.sampling.uniform_fraction);
    meta.add_number("uniform_margin", prior.sampling.uniform_margin);
    meta.add_number("width", prior.network.width);
    meta.add_number("depth", prior.network.depth);
    meta.add_number("condition", prior.network.condition);
    meta.add_number("pointnet_width", prior.network.pointnet_width);
    meta.add_number("pointnet_hidden", prior.network.pointnet_hidden);
    meta.add_number("steps", prior.provenance.steps);
    meta.add_number("final_loss", prior.provenance.final_loss);
    meta.add("trained_with", prior.provenance.library_version);
    meta.add("settings", prior.provenance.settings);
    for (const std::string& input : prior.provenance.inputs) meta.add("input", input);
    nn::NetFile<float> file;
    file.step = static_cast<std::uint64_t>(prior.provenance.steps);
    file.metadata = meta.text();
    file.nets.push_back(nn::make_record("encoder", prior.encoder()));
    file.nets.push_back(nn::make_record("decoder", prior.decoder()));
    nn::save_net_file(path, file);
}

LocalPrior load_prior(const std::string& path) {
    return detail::prior_from_net_file(path, nn::load_net_file<float>(path));
}

LocalPrior detail::prior_from_net_file(const std::string& path, const nn::NetFile<float>& file) {
    const nn::Metadata kv(file.metadata, path + ": the prior file");
    PCP_CHECK(kv.has("format"), path << ": not a prior file (a network file without prior settings)");
    PCP_CHECK(kv.get("format") == kPriorFormat,
              path << ": prior format '" << kv.get("format") << "' is not supported (this version reads '" << kPriorFormat << "')");
    LocalPrior prior;
    prior.regions.grid = kv.number<int>("grid");
    prior.regions.normalization = parse_region_normalization(kv.get("normalization"));
    prior.regions.min_points = kv.number<Eigen::Index>("min_region_points");
    prior.sampling.sigma_neighbor = kv.number<int>("sigma_neighbor");
    prior.sampling.queries_per_point = kv.number<int>("queries_per_point");
    prior.sampling.spreads.clear();
    std::istringstream spreads(kv.get("spreads"));
    for (std::string item; std::getline(spreads, item, ',');) {
        char* end = nullptr;
        const float v = std::strtof(item.c_str(), &end);
        PCP_CHECK(!item.empty() && end == item.c_str() + item.size() && std::isfinite(v) && v > 0.0f,
                  path << ": bad query spread '" << item << "' in the prior's settings (corrupt file?)");
        prior.sampling.spreads.push_back(v);
    }
    prior.sampling.uniform_fraction = kv.number<float>("uniform_fraction");
    prior.sampling.uniform_margin = kv.number<float>("uniform_margin");
    prior.network.width = kv.number<int>("width");
    prior.network.depth = kv.number<int>("depth");
    prior.network.condition = kv.number<int>("condition");
    prior.network.pointnet_width = kv.number<int>("pointnet_width");
    prior.network.pointnet_hidden = kv.number<int>("pointnet_hidden");
    prior.provenance.steps = kv.number<std::int64_t>("steps");
    prior.provenance.final_loss = kv.number<double>("final_loss");
    prior.provenance.library_version = kv.get("trained_with");
    prior.provenance.settings = kv.get("settings");
    prior.provenance.inputs = kv.all("input");
    // Settings a reconstruction sizes its work by: refused when outside what any trainer writes.
    const auto in_range = [&](const char* key, double v, double lo, double hi) {
        PCP_CHECK(std::isfinite(v) && v >= lo && v <= hi,
                  path << ": the prior's setting " << key << " = " << v << " is outside " << lo << ".." << hi << " (corrupt file?)");
    };
    in_range("grid", prior.regions.grid, 1, 64);
    in_range("min_region_points", static_cast<double>(prior.regions.min_points), 1, 1e9);
    in_range("sigma_neighbor", prior.sampling.sigma_neighbor, 1, 1024);
    in_range("queries_per_point", prior.sampling.queries_per_point, 1, 10000);
    PCP_CHECK(!prior.sampling.spreads.empty() && prior.sampling.spreads.size() <= 64,
              path << ": the prior's settings hold " << prior.sampling.spreads.size() << " query spreads (corrupt file?)");
    in_range("uniform_fraction", prior.sampling.uniform_fraction, 0, 1);
    in_range("uniform_margin", prior.sampling.uniform_margin, 0, 10);
    prior.encoder() = nn::to_pointnet(file.get("encoder"));
    prior.decoder() = nn::to_branch_mlp(file.get("decoder"));
    PCP_CHECK(prior.decoder().shape.width == prior.network.width && prior.decoder().shape.depth == prior.network.depth &&
                  prior.decoder().shape.in_b == prior.network.condition && prior.encoder().shape.cond() == prior.network.condition,
              path << ": the stored networks do not match the prior's recorded sizes (corrupt file?)");
    return prior;
}

}  // namespace pcp
