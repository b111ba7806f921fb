// pcp_reconstruct's options, report and memory check (see reconstruct_cli.hpp).
#include "reconstruct_cli.hpp"

#include "pcp/core/error.hpp"
#include "pcp/settings.hpp"

#include <algorithm>
#include <cstdio>
#include <map>
#include <sstream>

namespace pcp::cli {

std::string fmt(double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.6g", v);
    return buf;
}

/// What the fit uses as its prior, for the parameter table.
std::string prior_description(const ReconstructOptions& o, const std::string& prior_path, bool several) {
    if (!prior_path.empty()) return prior_path;
    if (o.fit.ablation == pcp::QueryAblation::NoPrior) return "none (F trained from scratch)";
    const std::string builtin = o.prior_tune_steps > 0
                                    ? "built-in, fine-tuned on the input for " + std::to_string(o.prior_tune_steps) + " steps"
                                    : "built-in (generic, trained on generated shapes)";
    if (o.prior_source == pcp::PriorSource::Builtin) return builtin;
    if (o.prior_source == pcp::PriorSource::Auto)
        return builtin + "; a self-prior instead if the input is noisy (denoised); --self-prior: always";
    return std::string("self-prior") + (several ? " on all inputs" : "") + " (" +
           (o.self_prior.max_steps > 0 ? std::to_string(o.self_prior.max_steps) + " steps"
                                        : std::to_string(o.self_prior.epochs) + " epochs") +
           ", " + std::to_string(o.self_prior.regions.grid) + "^3 grid, normalization " +
           pcp::to_string(o.self_prior.regions.normalization) + ")";
}

/// The stage table's name of the prior stage.
std::string prior_stage(const ReconstructOptions& o, const std::string& prior_path, const ReconstructReport& r) {
    if (!prior_path.empty()) return "prior (read)";
    if (!r.builtin_prior) return "self-prior";
    return o.prior_tune_steps > 0 ? "prior (built-in, tuned)" : "prior (built-in)";
}

/// What the field stage did (the winding sign, the visibility labels, the sign repair) and then
/// each pass that changed something, one line each.
void report_passes(const Log& log, const ReconstructReport& r) {
    std::ostringstream s;
    s << "  field: sign repair flipped " << r.sign_repair.flipped_components << " of " << r.sign_repair.components
      << " regions away from the data"
      << (r.sign_repair.label_flipped > 0 ? " (" + std::to_string(r.sign_repair.label_flipped) + " by the visibility labels)"
                                          : std::string())
      << (r.winding_sign.points == 0 ? std::string(", winding sign off")
          : r.winding_sign.skipped
              ? ", winding sign skipped (the " + std::string(r.winding_sign.by_labels ? "visibility labels orient" : "field orients") + " only " +
                std::string(r.winding_sign.sampled > 0 ? "about " : "") + std::to_string(r.winding_sign.confident) +
                " of " + std::to_string(r.winding_sign.points) + " points" +
                (r.winding_sign.sampled > 0 ? ", from a sample of " + std::to_string(r.winding_sign.sampled) : std::string()) +
                "; " + fmt(r.winding_sign.seconds) + " s)"
              : ", winding sign changed " + std::to_string(r.winding_corrected) + " field values (" +
                std::to_string(r.winding_sign.confident) + " of " + std::to_string(r.winding_sign.points) +
                " points oriented by the " + std::string(r.winding_sign.by_labels ? "visibility labels" : "field") +
                ", the others by their neighbours; " + fmt(r.winding_sign.seconds) + " s)")
      << (r.visibility.inside + r.visibility.outside + r.visibility.unknown + r.visibility.near > 0
              ? ", visibility labels " + std::to_string(r.visibility.inside) + " inside / " +
                std::to_string(r.visibility.outside) + " outside / " + std::to_string(r.visibility.unknown) +
                " unknown cells (" + fmt(r.visibility.seconds) + " s)"
              : std::string());
    log.info(s.str());
    for (const pcp::PassReport& pass : r.passes)
        if (!pass.summary.empty()) log.info("  " + pass.name + ": " + pass.summary + " (" + fmt(pass.seconds) + " s)");
}

/// Refused up front where a run cannot fit, rather than left to the OOM killer. Peak memory of a
/// run (docs/NOTEBOOK.md, "Memory at 1M points"): about 250 MiB, plus the query fit's pool (at most
/// steps x batch queries, about 52 bytes each while it is built), plus about 0.25 KiB per fitted
/// point (trees and per-point arrays), plus about 100 bytes per input point.
void check_fit_memory(const std::string& what, double fitted, double total, const ReconstructOptions& o, const std::string& hint) {
    const double pool = std::min(fitted * o.fit.sampling.queries_per_point * (1.0 + o.fit.sampling.uniform_fraction),
                                 static_cast<double>(o.fit.steps) * o.fit.queries_per_step);
    check_memory_for(what, 250.0 + 52.0 * pool / 1048576.0 + 2.5e-4 * fitted + 1e-4 * total, hint);
}

/// The command line with every setting that --help does not list, given as --NAME VALUE or
/// --NAME=VALUE, rewritten as --set NAME=VALUE.
std::vector<std::string> settings_as_set(int argc, char** argv) {
    std::vector<std::string> out{argv[0]};
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        const std::size_t eq = a.find('=');
        const std::string name = a.rfind("--", 0) == 0 ? a.substr(2, eq == std::string::npos ? std::string::npos : eq - 2) : "";
        const pcp::Setting* s = name.empty() ? nullptr : pcp::find_setting(name);
        if (!s || s->listed) {
            out.push_back(a);
            continue;
        }
        if (eq == std::string::npos && i + 1 >= argc) throw UsageError("--" + name + " needs a value");
        out.push_back("--set");
        out.push_back(name + "=" + (eq == std::string::npos ? std::string(argv[++i]) : a.substr(eq + 1)));
    }
    return out;
}

/// The preset, then every setting given (listed options and --set), in the table's order; checked.
ReconstructOptions options_from(const cxxopts::ParseResult& args) {
    if (args.count("scene") && args.count("preset") && args["preset"].as<std::string>() != "scene")
        throw UsageError("--scene is --preset scene; it does not go with --preset " + args["preset"].as<std::string>());
    const bool read_prior = !args["prior"].as<std::string>().empty();
    if (args.count("self-prior") && read_prior)
        throw UsageError("--self-prior and --prior exclude each other (a self-prior is learned, --prior is read)");
    std::map<std::string, std::string> given;
    std::string last;
    if (args.count("set"))
        for (const std::string& item : args["set"].as<std::vector<std::string>>()) {
            const std::size_t eq = item.find('=');
            if (eq == std::string::npos) {  // cxxopts splits a list value at commas: join it again
                if (last.empty()) throw UsageError("--set takes NAME=VALUE (got '" + item + "')");
                given[last] += "," + item;
                continue;
            }
            last = item.substr(0, eq);
            if (!pcp::find_setting(last)) throw UsageError("--set: unknown setting '" + last + "' (--list-settings lists them)");
            given[last] = item.substr(eq + 1);
        }
    for (const pcp::Setting& s : pcp::reconstruct_settings())
        if (s.listed && args.count(s.name)) given[s.name] = args[s.name].as<std::string>();
    if (given.count("prior-source") && read_prior) throw UsageError("--prior-source and --prior exclude each other");
    ReconstructOptions o;
    try {
        o = ReconstructOptions::preset(args.count("scene") ? "scene" : args["preset"].as<std::string>());
        if (args.count("self-prior")) o.prior_source = pcp::PriorSource::SelfPrior;
        for (const pcp::Setting& s : pcp::reconstruct_settings())
            if (given.count(s.name)) pcp::set_option(o, s.name, given.at(s.name));
        pcp::check_options(o);
    } catch (const pcp::Error& e) {
        const std::string what = e.what();
        throw UsageError(pcp::find_setting(what.substr(0, what.find(' '))) ? "--" + what : what);
    }
    return o;
}

/// --list-settings: every setting with its value in the preset, its range and its help.
void list_settings(const ReconstructOptions& o) {
    std::string group;
    for (const pcp::Setting& s : pcp::reconstruct_settings()) {
        if (s.group != group) std::printf("\n%s\n", (group = s.group).c_str());
        std::printf("  %-24s %-10s %s; %s\n", s.name.c_str(), s.get(o).c_str(), s.range.c_str(), s.help.c_str());
    }
}

}  // namespace pcp::cli
