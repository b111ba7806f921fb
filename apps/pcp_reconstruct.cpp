// pcp_reconstruct [INPUT] -o OUT: point cloud -> mesh by PCP. Without INPUT it runs on the
// embedded default shape (a block with sharp edges, a through-hole and a thin fin, sampled with
// noise). Without --prior it fits against the built-in generic prior, fine-tuned on the input
// (presets default and fast), or with --self-prior (--preset paper, scene) first learns a self-prior
// on the input (its region grid and normalisation, --prior-grid / --prior-normalization, are the
// paper's ablation tables 11-12).
// Progress, checkpoints of the query-network stage (OUT.ckpt, every --checkpoint-every steps and
// on SIGINT/SIGTERM), --resume, and a final report with times, memory, loss, mesh size and
// closedness. Several inputs (files, directories, --list) with --output-dir DIR: one query network
// for all of them, each query conditioned on its cloud's one-hot code (pcp::reconstruct_many), one
// mesh per input (DIR/<input name>.ply), checkpoint DIR/pcp_many.ckpt.
#include "cli_common.hpp"

#include "pcp/core/error.hpp"
#include "pcp/core/files.hpp"
#include "pcp/io/io.hpp"
#include "pcp/cloud/normalize.hpp"
#include "pcp/train/prior.hpp"
#include "pcp/reconstruct.hpp"
#include "pcp/cloud/regions.hpp"
#include "pcp/cloud/shapes.hpp"

#include <algorithm>
#include <optional>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

namespace {

/// The value of an on | off option when given (true: on); a usage error naming it otherwise.
std::optional<bool> on_off(const cxxopts::ParseResult& args, const std::string& name) {
    if (!args.count(name)) return std::nullopt;
    const std::string v = args[name].as<std::string>();
    if (v != "on" && v != "off") throw pcp::cli::UsageError("--" + name + " must be on or off (got '" + v + "')");
    return v == "on";
}

/// The value of an auto | on | off option when given as on or off (true: on); nothing for auto or
/// when absent; a usage error naming it otherwise.
std::optional<bool> auto_on_off(const cxxopts::ParseResult& args, const std::string& name) {
    if (!args.count(name)) return std::nullopt;
    const std::string v = args[name].as<std::string>();
    if (v != "auto" && v != "on" && v != "off") throw pcp::cli::UsageError("--" + name + " must be auto, on or off (got '" + v + "')");
    if (v == "auto") return std::nullopt;
    return v == "on";
}

struct BuiltinShapeOptions {
    long points = 20000;    ///< points sampled on the default shape
    double noise = 0.002;   ///< Gaussian noise (shape units; the shape is about 1 long)
};

std::string fmt(double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.6g", v);
    return buf;
}

std::string to_string(pcp::PriorSource source) {
    switch (source) {
        case pcp::PriorSource::Builtin: return "builtin";
        case pcp::PriorSource::SelfPrior: return "self";
        case pcp::PriorSource::Auto: break;
    }
    return "auto";
}

/// What the fit uses as its prior, for the parameter table.
std::string prior_description(const pcp::ReconstructOptions& o, const std::string& prior_path, bool several) {
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
std::string prior_stage(const pcp::ReconstructOptions& o, const std::string& prior_path, const pcp::ReconstructReport& r) {
    if (!prior_path.empty()) return "prior (read)";
    if (!r.builtin_prior) return "self-prior";
    return o.prior_tune_steps > 0 ? "prior (built-in, tuned)" : "prior (built-in)";
}

/// Several inputs, one fit (pcp::reconstruct_many): --output-dir DIR gets DIR/<stem>.ply per input.
int run_many(const cxxopts::ParseResult& args, pcp::ReconstructOptions o, const pcp::cli::Log& log,
             const std::string& precision, const std::vector<std::string>& positional, const std::string& list_file,
             const std::string& output_dir) {
    namespace fs = std::filesystem;
    if (output_dir.empty()) throw pcp::cli::UsageError("several inputs need --output-dir DIR (one mesh per input)");
    if (args.count("output")) throw pcp::cli::UsageError("-o names one mesh; with several inputs use --output-dir DIR");
    if (!args["normals"].as<std::string>().empty()) throw pcp::cli::UsageError("--normals takes one input");
    if (o.fit.ablation != pcp::QueryAblation::None)
        throw pcp::cli::UsageError("several inputs are fitted with the method itself: no --ablation");
    const std::vector<std::string> inputs = pcp::cli::collect_inputs(positional, list_file);
    if (inputs.empty()) throw pcp::cli::UsageError("no input point clouds");
    const std::string prior_path = args["prior"].as<std::string>();
    // Outputs: DIR/<stem>.ply, one per input; when two inputs share a stem (case/input.ply),
    // DIR/<parent directory>_<stem>.ply for all; still the same: refused.
    std::vector<std::string> stems;
    for (const std::string& in : inputs) stems.push_back(fs::path(in).stem().string());
    const bool shared_stems = std::any_of(stems.begin(), stems.end(), [&](const std::string& a) {
        return std::count(stems.begin(), stems.end(), a) > 1;
    });
    std::vector<std::string> outputs;
    for (std::size_t i = 0; i < inputs.size(); ++i) {
        const std::string parent = fs::absolute(fs::path(inputs[i])).parent_path().filename().string();
        const std::string name = shared_stems ? parent + "_" + stems[i] : stems[i];
        const std::string out = (fs::path(output_dir) / (name + ".ply")).string();
        for (std::size_t j = 0; j < i; ++j)
            if (outputs[j] == out)
                throw pcp::cli::UsageError(inputs[j] + " and " + inputs[i] + " would both write " + out + "; rename one");
        outputs.push_back(out);
    }
    std::error_code ec;
    fs::create_directories(output_dir, ec);
    if (ec || !fs::is_directory(output_dir))
        throw pcp::Error(output_dir + ": cannot create the output directory" + (ec ? " (" + ec.message() + ")" : std::string()));
    std::vector<std::string> protected_files = inputs;
    if (!prior_path.empty()) protected_files.push_back(prior_path);
    for (const std::string& out : outputs) pcp::check_output_path(out, protected_files);

    const auto t_start = std::chrono::steady_clock::now();
    std::vector<pcp::Points> clouds;
    double total_points = 0, fitted_points = 0;
    for (const std::string& in : inputs) {
        clouds.push_back(pcp::cli::load_checked_cloud(in, pcp::min_points_for(o.fit.sampling)).points);
        const auto n = static_cast<double>(clouds.back().rows());
        total_points += n;
        fitted_points += o.max_fit_points > 0 ? std::min(n, static_cast<double>(o.max_fit_points)) : n;
    }
    {
        // The single-input model (main below) summed over the inputs; one pool for all of them.
        const double pool = std::min(fitted_points * o.fit.sampling.queries_per_point * (1.0 + o.fit.sampling.uniform_fraction),
                                     static_cast<double>(o.fit.steps) * o.fit.queries_per_step);
        pcp::cli::check_memory_for(std::to_string(inputs.size()) + " inputs: fitting " + std::to_string(static_cast<long>(fitted_points)) +
                                       " points",
                                   250.0 + 52.0 * pool / 1048576.0 + 2.5e-4 * fitted_points + 1e-4 * total_points,
                                   "fit fewer inputs at once, or fewer points with --max-points");
    }
    pcp::LocalPrior prior;
    if (!prior_path.empty()) prior = pcp::load_prior(prior_path);
    const double t_read = pcp::cli::seconds_since(t_start);

    pcp::cli::print_parameter_table(
        log, {{"inputs", std::to_string(inputs.size()) + " clouds, " + std::to_string(static_cast<long>(total_points)) +
                             " points (one query network, a one-hot code per cloud)"},
              {"output directory", output_dir},
              {"prior", prior_description(o, prior_path, true)},
              {"preset", args.count("scene") ? std::string("scene") : args["preset"].as<std::string>()},
              {"query-net steps x batch", std::to_string(o.fit.steps) + " x " + std::to_string(o.fit.queries_per_step) +
                                              " (shared: about " + std::to_string(o.fit.steps * o.fit.queries_per_step /
                                                                                  static_cast<std::int64_t>(inputs.size())) +
                                              " queries per cloud)"},
              {"resolution", std::to_string(o.resolution)},
              {"precision", precision},
              {"seed", std::to_string(o.fit.schedule.seed)}});
    const auto stage_memory = std::make_shared<pcp::cli::StageMemory>();
    o.progress = pcp::cli::make_progress_printer(log, o.fit.schedule.progress_every, stage_memory);
    o.fit.schedule.checkpoint_path = (fs::path(output_dir) / "pcp_many.ckpt").string();
    o.fit.schedule.resume = args.count("resume") > 0;
    std::vector<pcp::ReconstructReport> reports;
    const std::vector<pcp::Mesh> meshes = pcp::reconstruct_many(clouds, prior_path.empty() ? nullptr : &prior, o, &reports);
    if (meshes.empty()) throw pcp::cli::Cancelled("interrupted; continue the query-network stage with --resume");
    pcp::MeshWriteOptions wo;
    wo.ascii = args.count("ascii") > 0;
    double grid_s = 0, mesh_s = 0;
    for (std::size_t i = 0; i < meshes.size(); ++i) {
        pcp::write_mesh(outputs[i], meshes[i], wo);
        const pcp::ReconstructReport& r = reports[i];
        grid_s += r.seconds_grid;
        mesh_s += r.seconds_mesh + r.seconds_denoise;
        std::ostringstream line;
        line << "wrote " << outputs[i] << " (" << inputs[i] << ", " << r.input_points << " points): " << meshes[i].vertices.rows()
             << " vertices, " << meshes[i].faces.rows() << " faces, " << (r.closed ? "closed" : "NOT closed") << ", grid "
             << fmt(r.seconds_grid) << " s, mesh " << fmt(r.seconds_mesh) << " s";
        log.info(line.str());
    }
    if (!o.keep_checkpoints) fs::remove(o.fit.schedule.checkpoint_path, ec);
    const double total_s = pcp::cli::seconds_since(t_start);
    const pcp::ReconstructReport& r0 = reports.front();
    pcp::cli::print_stage_table(log, {{"read", t_read, -1},
                                      {prior_stage(o, prior_path, r0), r0.seconds_prior, stage_memory->of("prior")},
                                      {"query net (" + std::to_string(r0.fit_steps) + " steps, all clouds)", r0.seconds_fit,
                                       stage_memory->of("query-net")},
                                      {"SDF grids and sign repairs", grid_s, stage_memory->of("sdf-grid")},
                                      {"denoise, marching cubes, surface fits", mesh_s, -1},
                                      {"total (peak memory of the run)", total_s, pcp::cli::peak_rss_mib()}});
    std::ostringstream s;
    s << "| clouds " << meshes.size() << " | read " << fmt(t_read) << " s | prior " << fmt(r0.seconds_prior) << " s (loss "
      << fmt(r0.prior_loss) << ") | query net " << fmt(r0.seconds_fit) << " s (" << r0.fit_steps << " steps, loss "
      << fmt(r0.fit_loss) << ") | SDF grids " << fmt(grid_s) << " s | meshes " << fmt(mesh_s) << " s | total " << fmt(total_s)
      << " s | per cloud " << fmt(total_s / static_cast<double>(meshes.size())) << " s | precision " << precision
      << " | peak memory " << fmt(pcp::cli::peak_rss_mib()) << " MiB";
    log.info(s.str());
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    return pcp::cli::run_main("pcp_reconstruct", [&] {
        const pcp::ReconstructOptions d = pcp::ReconstructOptions::preset("default");
        const BuiltinShapeOptions builtin_defaults;
        cxxopts::Options options("pcp_reconstruct",
                                 "Reconstruct a mesh from an unoriented point cloud (.ply .xyz .txt .pts .npy) with PCP.\n"
                                 "Without INPUT, runs on the embedded default shape. Option defaults are those of --preset default.");
        options.positional_help("[INPUT...]");
        options.add_options()
            ("input", "Point cloud file; several (files or directories of them) with --output-dir: one query network for "
                      "all, a one-hot code per cloud (the paper's multi-cloud fit)", cxxopts::value<std::vector<std::string>>())
            ("o,output", "Output mesh (.ply .obj .off)", cxxopts::value<std::string>()->default_value("pcp_mesh.ply"))
            ("output-dir", "With several inputs: write DIR/<input name>.ply for each (DIR/<its directory>_<name>.ply when "
                           "names repeat; created if missing)",
             cxxopts::value<std::string>()->default_value(""))
            ("list", "A file naming input clouds, one per line ('#' comments; relative to the file); implies several "
                     "inputs (--output-dir)", cxxopts::value<std::string>()->default_value(""))
            ("normals", "Also write the input points with their oriented normals (nx ny nz, outward, from the "
                        "fitted surface: see --normals-from; .ply .xyz .npy)", cxxopts::value<std::string>()->default_value(""))
            ("normals-from", "mesh | pca | field: the final mesh's normal at the nearest point; the PCA normal "
                             "turned to the mesh's side; or the PCA normal oriented by the fitted field's own votes",
             cxxopts::value<std::string>()->default_value(pcp::to_string(d.normal_source)))
            ("prior", "A prior trained by pcp_train (default: see --prior-source)", cxxopts::value<std::string>()->default_value(""))
            ("prior-tune-steps", "Fine-tune the built-in prior on the input for this many steps first (0 = frozen)",
             cxxopts::value<long>()->default_value(std::to_string(d.prior_tune_steps)))
            ("prior-source", "auto | builtin | self: without --prior, fit against the built-in generic prior "
                             "(fine-tuned on the input for --prior-tune-steps), against a self-prior learned on the "
                             "input first, or (auto) the built-in one for clean clouds and a self-prior for noisy ones",
             cxxopts::value<std::string>()->default_value(to_string(d.prior_source)))
            ("self-prior", "The same as --prior-source self (also implied by the --prior-* options below)")
            ("preset", "paper | default | fast | scene (explicit options below override it)", cxxopts::value<std::string>()->default_value("default"))
            ("scene", "Scene mode, the same as --preset scene: a room or other open surfaces, 512 cells, faces kept only "
                      "where the data supports them (open where the data ends), no repairs that close or flip surfaces")
            ("ascii", "Write an ascii .ply")
            ("resume", "Continue the query-network stage from OUT.ckpt")
            ("builtin-points", "Points sampled on the embedded default shape", cxxopts::value<long>()->default_value(std::to_string(builtin_defaults.points)))
            ("builtin-noise", "Noise of the embedded default shape", cxxopts::value<double>()->default_value(fmt(builtin_defaults.noise)))
            ("denoise", "Denoise the input first: passes of moving each point onto the plane of its nearest "
                        "neighbours, or to its own side's mode (--denoise-mode-width) (0 = off), or auto (" +
                            std::to_string(d.denoise.auto_passes) + " passes if the cloud is noisy: pcp::noise_ratio > 0.25); "
                        "not in the paper; helps noisy scans, thins thin parts of clean ones",
             cxxopts::value<std::string>()->default_value(d.denoise.automatic ? "auto" : std::to_string(d.denoise.passes)))
            ("denoise-neighbors", "Neighbours per plane fit of --denoise (3..256)",
             cxxopts::value<int>()->default_value(std::to_string(d.denoise.neighbors)))
            ("denoise-mode-width", "0: --denoise projects onto the plane; W > 0: moves each point along the plane's "
                                   "normal to the mode of its neighbours' heights nearest its own (kernel W x the cloud's "
                                   "noise), keeping the two sides of a thin part apart (docs/BENCHMARKS.md)",
             cxxopts::value<double>()->default_value(fmt(d.denoise.mode_width)));
        options.add_options("Self-prior (stage 1 learned on the input, --self-prior; any of these implies --prior-source self)")
            ("prior-epochs", "Self-prior epochs (passes over the input's regions)", cxxopts::value<int>()->default_value(std::to_string(d.self_prior.epochs)))
            ("prior-steps", "Stop the self-prior after this many steps instead (0 = epochs x regions)",
             cxxopts::value<long>()->default_value(std::to_string(d.self_prior.max_steps)))
            ("prior-grid", "Self-prior region grid: cells per axis (1 = no split, the paper's 0^3)",
             cxxopts::value<int>()->default_value(std::to_string(d.self_prior.regions.grid)))
            ("prior-normalization", "Self-prior per-region normalisation: none | center | scale | both",
             cxxopts::value<std::string>()->default_value(pcp::to_string(d.self_prior.regions.normalization)));
        pcp::cli::add_sampling_options(options, "Queries (both stages)", d.fit.sampling);
        options.add_options("Query network (stage 2)")
            ("steps", "Query-network steps", cxxopts::value<long>()->default_value(std::to_string(d.fit.steps)))
            ("batch", "Queries per step", cxxopts::value<int>()->default_value(std::to_string(d.fit.queries_per_step)))
            ("batch-parts", "Split each step's batch into this many parts, one thread each (0 = one per thread; 1 = "
                            "the whole batch, its products split over the threads); speed only",
             cxxopts::value<int>()->default_value(std::to_string(d.fit.batch_parts)))
            ("lr", "Learning rate", cxxopts::value<double>()->default_value(fmt(d.fit.schedule.learning_rate)))
            ("width", "Query-network width", cxxopts::value<int>()->default_value(std::to_string(d.fit.width)))
            ("depth", "Query-network hidden layers", cxxopts::value<int>()->default_value(std::to_string(d.fit.depth)))
            ("ablation", "The paper's stage-2 ablations: none (the method) | no-shift | direct | free-code | pointnet-code | "
                         "no-prior | tune-prior (see include/pcp/train/query_fit.hpp)",
             cxxopts::value<std::string>()->default_value(pcp::to_string(d.fit.ablation)))
            ("checkpoint-every", "Steps between checkpoints", cxxopts::value<long>()->default_value(std::to_string(d.fit.schedule.checkpoint_every)))
            ("progress-every", "Steps between progress lines", cxxopts::value<long>()->default_value(std::to_string(d.fit.schedule.progress_every)));
        pcp::cli::add_precision_option(options, "Query network (stage 2)");
        options.add_options("Meshing")
            ("grid-precision", "fp32 | training: precision of the SDF evaluations for meshing and the sign repair; "
                               "fp32 (default) even when training runs bf16, or the training's",
             cxxopts::value<std::string>()->default_value(d.fp32_grid ? "fp32" : "training"));
        options.add_options("Meshing")
            ("max-points", "Fit inputs of more points on a uniform random subsample of this many (0 = all points; "
                           "bounds the memory of huge inputs; the mesh and --normals still cover every point)",
             cxxopts::value<long>()->default_value(std::to_string(d.max_fit_points)))
            ("resolution", "Marching-cubes cells along the longest axis", cxxopts::value<int>()->default_value(std::to_string(d.resolution)))
            ("grid-far-factor", "The fine grid (dense for the cavity and tunnel fills, or its narrow band) and the sign repair's coarse grid: blocks whose corners are farther than this x the "
                                "block's half-diagonal from the zero set, all of one sign, are interpolated from their corners "
                                "instead of evaluated (0: evaluate every sample)",
             cxxopts::value<double>()->default_value(fmt(d.grid.far_factor)))
            ("grid-far-levels", "Both grids: levels of that test, each splitting the cells that are not far into 8 halves "
                                "(1: the 8-cell blocks only; 3: down to 2-cell cells, the rest evaluated)",
             cxxopts::value<int>()->default_value(std::to_string(d.grid.far_levels)))
            ("iso", "Iso level", cxxopts::value<double>()->default_value(fmt(d.iso)))
            ("thin-offset", "Keep thin parts whole: near the data, extract at iso + this (unit-box units, the cloud's longest edge 1), then move the mesh back by it (0: off)",
             cxxopts::value<double>()->default_value(fmt(d.thin_offset)))
            ("sheet-gap", "Least gap between the two sides of a thin part, which the fit brings onto the same data (unit-box "
                          "units; 0: off; include/pcp/mesh/surface/sheet_gap.hpp)",
             cxxopts::value<double>()->default_value(fmt(d.sheet_gap.enabled ? d.sheet_gap.min_gap : 0.0)))
            ("thin-probe", "Where the field has no inside this many grid cells under a point of the data, raise the thin level "
                           "there until it has (0: off)",
             cxxopts::value<double>()->default_value(fmt(d.thin_probe)))
            ("margin", "Margin around the cloud's unit box", cxxopts::value<double>()->default_value(fmt(d.margin)))
            ("sign-repair", "on | off: flip regions of the fitted field whose sign the data does not support, on a coarse "
                            "grid (not in the paper; include/pcp/mesh/sign/sign_repair.hpp)",
             cxxopts::value<std::string>()->default_value(d.sign_repair.enabled ? "on" : "off"))
            ("sign-repair-resolution", "Cells per axis of the sign repair's coarse grid",
             cxxopts::value<int>()->default_value(std::to_string(d.sign_repair.resolution)))
            ("label-votes", "With N > 0, the sign repair also flips a region away from the data when at least N of its "
                            "samples, and more than agree, are on the other side by visibility through the cloud (0 = off; "
                            "not in the paper; include/pcp/mesh/sign/sign_repair.hpp)",
             cxxopts::value<int>()->default_value(std::to_string(d.sign_repair.min_label_votes)))
            ("winding-sign", "on | off: away from the data, give the field the sign of the generalised winding number of "
                             "the oriented input points (hollow walls, inner sheets, plugged holes, bubbles; not in the paper; "
                             "include/pcp/mesh/sign/winding_sign.hpp)",
             cxxopts::value<std::string>()->default_value(d.winding_sign.enabled ? "on" : "off"))
            ("winding-normals", "labels | field: orient the winding number's points by which side the visibility labels "
                                "see outside, by the field where the "
                                "labels orient fewer than half of them; or by the field only",
             cxxopts::value<std::string>()->default_value(d.winding_sign.orient_by_labels ? "labels" : "field"))
            ("winding-near", "Distance from the data, in sampling scales, within which the field keeps its own sign",
             cxxopts::value<double>()->default_value(fmt(d.winding_sign.near_k)))
            ("cavity-fill", "on | off: fill the pockets of the fitted field's outside that the outside cannot reach (the hollow "
                            "shells of noisy scans; evaluates the whole grid; not in the paper; include/pcp/mesh/repair/cavity_fill.hpp)",
             cxxopts::value<std::string>()->default_value(d.cavity_fill.enabled ? "on" : "off"))
            ("fine-repair", "on | off: flip thin regions of the fine grid whose boundary is mostly a zero crossing away from "
                            "the data (membranes across holes; not in the paper; include/pcp/mesh/repair/fine_repair.hpp)",
             cxxopts::value<std::string>()->default_value(d.fine_repair.enabled ? "on" : "off"))
            ("tunnel-fill", "on | off: plug the passages through the solid that are two cells across or less (the small "
                            "handles of a bumpy field; evaluates the whole grid; not in the paper; include/pcp/mesh/repair/tunnel_fill.hpp)",
             cxxopts::value<std::string>()->default_value(d.tunnel_fill.enabled ? "on" : "off"))
            ("through-carve", "on | off: make outside the inside samples of the fine grid that lie on lines crossing no wall of "
                              "the data (openings a few sample spacings wide that the field spans; not in the paper; "
                              "include/pcp/mesh/repair/through_carve.hpp)",
             cxxopts::value<std::string>()->default_value(d.through_carve.enabled ? "on" : "off"))
            ("mc-ambiguity", "join | decider | separate: how marching cubes cuts a grid face whose diagonal corners share "
                             "a sign: the inside joined (the default: the mesh has the topology the grid repairs count), "
                             "by the bilinear saddle (asymptotic decider), or the inside separated (include/pcp/mesh/grid/marching_cubes.hpp)",
             cxxopts::value<std::string>()->default_value("join"))
            ("shell-centre", "on | off: on a noisy (denoised) cloud, put the surface in the middle of the noise band's "
                             "shell instead of on its outer wall (not in the paper; include/pcp/mesh/surface/shell_centre.hpp)",
             cxxopts::value<std::string>()->default_value(d.shell_centre.enabled ? "on" : "off"))
            ("surface-fit", "on | off: remove mesh components with no input points near them and move the surface onto "
                            "the data (not in the paper; include/pcp/mesh/surface/surface_fit.hpp)",
             cxxopts::value<std::string>()->default_value(d.surface_fit.enabled ? "on" : "off"))
            ("surface-fit-iterations", "Rounds of the surface fit's move onto the data (0: the component filter only)",
             cxxopts::value<int>()->default_value(std::to_string(d.surface_fit.iterations)))
            ("recentre", "auto | on | off: before the surface fit, move the mesh onto the middle of the input points' "
                         "noise, averaged over a few sampling scales (auto: when the cloud was denoised, that is noisy; "
                         "not in the paper; include/pcp/mesh/surface/surface_fit.hpp)",
             cxxopts::value<std::string>()->default_value("auto"))
            ("smooth", "auto | on | off: bilateral smoothing of the final mesh (auto: when the cloud was denoised, that is "
                       "noisy; not in the paper; include/pcp/mesh/surface/smooth.hpp)",
             cxxopts::value<std::string>()->default_value("auto"))
            ("fair", "on | off: place the surface where no input point lies under it as the smoothest surface that "
                     "joins the supported rest (not in the paper; off in the scene mode; include/pcp/mesh/surface/surface_fit.hpp)",
             cxxopts::value<std::string>()->default_value(d.fairing.enabled ? "on" : "off"))
            ("keep-checkpoint", "Keep OUT.ckpt (the finished query network) and OUT.ckpt.prior, so that a run with --resume "
                                "re-meshes without training again");
        options.parse_positional({"input"});
        pcp::cli::add_common_options(options);
        cxxopts::ParseResult args;
        pcp::cli::CommonFlags common;
        if (!pcp::cli::parse_command_line(options, argc, argv, args, common)) return 0;
        const std::string precision = pcp::cli::apply_precision(args);
        const pcp::cli::Log log{&common};

        pcp::ReconstructOptions o;
        try {
            if (args.count("scene") && args.count("preset") && args["preset"].as<std::string>() != "scene")
                throw pcp::cli::UsageError("--scene is --preset scene; it does not go with --preset " + args["preset"].as<std::string>());
            o = pcp::ReconstructOptions::preset(args.count("scene") ? "scene" : args["preset"].as<std::string>());
        } catch (const pcp::Error& e) {
            throw pcp::cli::UsageError(e.what());
        }
        if (args.count("self-prior") && !args["prior"].as<std::string>().empty())
            throw pcp::cli::UsageError("--self-prior and --prior exclude each other (a self-prior is learned, --prior is read)");
        if (args.count("prior-source")) {
            const std::string v = args["prior-source"].as<std::string>();
            if (v == "auto") o.prior_source = pcp::PriorSource::Auto;
            else if (v == "builtin") o.prior_source = pcp::PriorSource::Builtin;
            else if (v == "self") o.prior_source = pcp::PriorSource::SelfPrior;
            else throw pcp::cli::UsageError("--prior-source must be auto, builtin or self (got '" + v + "')");
            if (!args["prior"].as<std::string>().empty())
                throw pcp::cli::UsageError("--prior-source and --prior exclude each other");
        }
        if (args.count("self-prior") || args.count("prior-epochs") || args.count("prior-steps") || args.count("prior-grid") ||
            args.count("prior-normalization"))
            o.prior_source = pcp::PriorSource::SelfPrior;
        if (args.count("prior-tune-steps")) o.prior_tune_steps = args["prior-tune-steps"].as<long>();
        if (o.prior_tune_steps < 0) throw pcp::cli::UsageError("--prior-tune-steps must be >= 0");
        if (args.count("prior-epochs")) o.self_prior.epochs = args["prior-epochs"].as<int>();
        if (o.self_prior.epochs < 1) throw pcp::cli::UsageError("--prior-epochs must be >= 1");
        if (args.count("prior-steps")) o.self_prior.max_steps = args["prior-steps"].as<long>();
        if (o.self_prior.max_steps < 0) throw pcp::cli::UsageError("--prior-steps must be >= 0");
        if (args.count("prior-grid")) o.self_prior.regions.grid = args["prior-grid"].as<int>();
        if (o.self_prior.regions.grid < 1 || o.self_prior.regions.grid > 64)
            throw pcp::cli::UsageError("--prior-grid must be in [1, 64] (got " + std::to_string(o.self_prior.regions.grid) + ")");
        if (args.count("prior-normalization")) {
            try {
                o.self_prior.regions.normalization = pcp::parse_region_normalization(args["prior-normalization"].as<std::string>());
            } catch (const pcp::Error& e) {
                throw pcp::cli::UsageError(std::string("--prior-normalization: ") + e.what());
            }
        }
        if (args.count("steps")) o.fit.steps = args["steps"].as<long>();
        if (args.count("batch")) o.fit.queries_per_step = args["batch"].as<int>();
        if (args.count("batch-parts")) {
            o.fit.batch_parts = args["batch-parts"].as<int>();
            if (o.fit.batch_parts < 0)
                throw pcp::cli::UsageError("--batch-parts must be >= 0 (got " + std::to_string(o.fit.batch_parts) + ")");
        }
        if (args.count("lr")) o.fit.schedule.learning_rate = args["lr"].as<double>();
        if (args.count("width")) o.fit.width = args["width"].as<int>();
        if (args.count("depth")) o.fit.depth = args["depth"].as<int>();
        try {
            o.fit.ablation = pcp::parse_query_ablation(args["ablation"].as<std::string>());
        } catch (const pcp::Error& e) {
            throw pcp::cli::UsageError(e.what());
        }
        pcp::cli::apply_sampling_flags(args, o.fit.sampling);
        pcp::cli::apply_sampling_flags(args, o.self_prior.sampling);
        if (args.count("checkpoint-every")) o.fit.schedule.checkpoint_every = args["checkpoint-every"].as<long>();
        if (args.count("progress-every")) o.fit.schedule.progress_every = args["progress-every"].as<long>();
        if (args.count("resolution")) o.resolution = args["resolution"].as<int>();
        o.max_fit_points = args["max-points"].as<long>();
        if (o.max_fit_points != 0 && o.max_fit_points < pcp::min_points_for(o.fit.sampling))
            throw pcp::cli::UsageError("--max-points must be 0 or >= " + std::to_string(pcp::min_points_for(o.fit.sampling)));
        if (args.count("grid-far-factor")) o.grid.far_factor = args["grid-far-factor"].as<double>();
        if (!(o.grid.far_factor >= 0) || !std::isfinite(o.grid.far_factor))
            throw pcp::cli::UsageError("--grid-far-factor must be a finite number >= 0 (0 = evaluate every sample)");
        if (args.count("grid-far-levels")) o.grid.far_levels = args["grid-far-levels"].as<int>();
        if (o.grid.far_levels < 1 || o.grid.far_levels > 4)
            throw pcp::cli::UsageError("--grid-far-levels must be 1, 2, 3 or 4 (the 8-cell blocks halved at most down to 1 cell)");
        // The sign repair's coarse grid the same way.
        o.sign_repair.far_factor = o.grid.far_factor;
        o.sign_repair.far_levels = o.grid.far_levels;
        if (args.count("iso")) o.iso = args["iso"].as<double>();
        if (args.count("thin-offset")) o.thin_offset = args["thin-offset"].as<double>();
        if (args.count("thin-probe")) o.thin_probe = args["thin-probe"].as<double>();
        if (args.count("sheet-gap")) {
            const double gap = args["sheet-gap"].as<double>();
            if (!std::isfinite(gap) || gap < 0 || gap >= 0.1) throw pcp::cli::UsageError("--sheet-gap must be in [0, 0.1) (unit-box units)");
            o.sheet_gap.enabled = gap > 0;
            if (gap > 0) o.sheet_gap.min_gap = gap;
        }
        if (args.count("margin")) o.margin = args["margin"].as<double>();
        if (o.fit.steps < 1 || o.fit.queries_per_step < 1 || !(o.fit.schedule.learning_rate > 0) || o.fit.width < 1 ||
            o.fit.depth < 1 || o.fit.schedule.progress_every < 1 || o.fit.schedule.checkpoint_every < 0)
            throw pcp::cli::UsageError("steps, batch, width, depth and learning rate must be positive");
        if (o.resolution < 8 || o.resolution > 2048) throw pcp::cli::UsageError("--resolution must be in [8, 2048]");
        if (!(o.margin >= 0)) throw pcp::cli::UsageError("--margin must be >= 0");
        if (args.count("denoise")) {
            const std::string v = args["denoise"].as<std::string>();
            o.denoise.automatic = v == "auto";
            if (!o.denoise.automatic) {
                std::size_t used = 0;
                int passes = -1;
                try {
                    passes = std::stoi(v, &used);
                } catch (const std::exception&) {
                }
                if (used != v.size() || passes < 0 || passes > 100)
                    throw pcp::cli::UsageError("--denoise must be auto or a number of passes in [0, 100] (got '" + v + "')");
                o.denoise.passes = passes;
            }
        }
        if (args.count("denoise-neighbors")) o.denoise.neighbors = args["denoise-neighbors"].as<int>();
        if (o.denoise.neighbors < 3 || o.denoise.neighbors > 256)
            throw pcp::cli::UsageError("--denoise-neighbors must be in [3, 256]");
        if (args.count("denoise-mode-width")) o.denoise.mode_width = args["denoise-mode-width"].as<double>();
        if (!(o.denoise.mode_width >= 0) || !std::isfinite(o.denoise.mode_width))
            throw pcp::cli::UsageError("--denoise-mode-width must be a finite number >= 0");
        if (const auto on = on_off(args, "sign-repair")) o.sign_repair.enabled = *on;
        {
            const std::string v = args["grid-precision"].as<std::string>();
            if (v != "fp32" && v != "training")
                throw pcp::cli::UsageError("--grid-precision must be fp32 or training (got '" + v + "')");
            o.fp32_grid = v == "fp32";
        }
        if (args.count("sign-repair-resolution")) o.sign_repair.resolution = args["sign-repair-resolution"].as<int>();
        if (o.sign_repair.resolution < pcp::SignRepairOptions::kMinResolution ||
            o.sign_repair.resolution > pcp::SignRepairOptions::kMaxResolution)
            throw pcp::cli::UsageError("--sign-repair-resolution must be in [" + std::to_string(pcp::SignRepairOptions::kMinResolution) +
                                       ", " + std::to_string(pcp::SignRepairOptions::kMaxResolution) + "]");
        if (args.count("label-votes")) o.sign_repair.min_label_votes = args["label-votes"].as<int>();
        if (o.sign_repair.min_label_votes < 0) throw pcp::cli::UsageError("--label-votes must be >= 0");
        if (const auto on = on_off(args, "winding-sign")) o.winding_sign.enabled = *on;
        if (args.count("winding-normals")) {
            const std::string w = args["winding-normals"].as<std::string>();
            if (w != "labels" && w != "field") throw pcp::cli::UsageError("--winding-normals must be labels or field (got '" + w + "')");
            o.winding_sign.orient_by_labels = w == "labels";
        }
        if (args.count("winding-near")) o.winding_sign.near_k = args["winding-near"].as<double>();
        if (!(o.winding_sign.near_k >= 0 && o.winding_sign.near_k <= 100))
            throw pcp::cli::UsageError("--winding-near must be in [0, 100]");
        if (const auto on = auto_on_off(args, "smooth")) o.smoothing.enabled = o.noisy.smooth = *on;
        if (const auto on = auto_on_off(args, "recentre")) o.recentre.enabled = o.noisy.recentre = *on;
        if (const auto on = on_off(args, "cavity-fill")) o.cavity_fill.enabled = *on;
        if (const auto on = on_off(args, "fine-repair")) o.fine_repair.enabled = *on;
        if (const auto on = on_off(args, "tunnel-fill")) o.tunnel_fill.enabled = *on;
        if (const auto on = on_off(args, "through-carve")) o.through_carve.enabled = *on;
        if (args.count("mc-ambiguity")) {
            const std::string v = args["mc-ambiguity"].as<std::string>();
            if (v == "join") o.marching_cubes.ambiguity = pcp::McAmbiguity::JoinInside;
            else if (v == "decider") o.marching_cubes.ambiguity = pcp::McAmbiguity::AsymptoticDecider;
            else if (v == "separate") o.marching_cubes.ambiguity = pcp::McAmbiguity::SeparateInside;
            else throw pcp::cli::UsageError("--mc-ambiguity must be join, decider or separate (got '" + v + "')");
        }
        if (const auto on = on_off(args, "shell-centre")) o.shell_centre.enabled = *on;
        if (const auto on = on_off(args, "surface-fit")) o.surface_fit.enabled = *on;
        if (const auto on = on_off(args, "fair")) o.fairing.enabled = *on;
        if (args.count("surface-fit-iterations")) o.surface_fit.iterations = args["surface-fit-iterations"].as<int>();
        if (o.surface_fit.iterations < 0 || o.surface_fit.iterations > 100)
            throw pcp::cli::UsageError("--surface-fit-iterations must be in [0, 100]");
        o.keep_checkpoints = args.count("keep-checkpoint") > 0;
        if (args["builtin-points"].as<long>() < pcp::min_points_for(o.fit.sampling))
            throw pcp::cli::UsageError("--builtin-points must be >= " + std::to_string(pcp::min_points_for(o.fit.sampling)));
        o.fit.schedule.seed = o.self_prior.schedule.seed = common.seed;

        const std::vector<std::string> positional =
            args.count("input") ? args["input"].as<std::vector<std::string>>() : std::vector<std::string>{};
        const std::string list_file = args["list"].as<std::string>();
        const std::string output_dir = args["output-dir"].as<std::string>();
        if (positional.size() > 1 || !list_file.empty() || !output_dir.empty())
            return run_many(args, o, log, precision, positional, list_file, output_dir);

        const bool builtin = positional.empty();
        const std::string input = builtin ? "<default shape>" : positional.front();
        const std::string output = args["output"].as<std::string>();
        const std::string prior_path = args["prior"].as<std::string>();
        const std::string ext = pcp::file_extension(output);
        PCP_CHECK(ext == ".ply" || ext == ".obj" || ext == ".off",
                  output << ": unknown mesh extension '" << ext << "' (use .ply, .obj or .off)");
        std::vector<std::string> inputs;
        if (!builtin) inputs.push_back(input);
        if (!prior_path.empty()) inputs.push_back(prior_path);
        pcp::check_output_path(output, inputs);
        const std::string normals_path = args["normals"].as<std::string>();
        try {
            o.normal_source = pcp::parse_normal_source(args["normals-from"].as<std::string>());
        } catch (const pcp::Error& e) {
            throw pcp::cli::UsageError(std::string("--normals-from: ") + e.what());
        }
        if (!normals_path.empty()) {
            const std::string next = pcp::file_extension(normals_path);
            PCP_CHECK(next == ".ply" || next == ".xyz" || next == ".npy",
                      normals_path << ": unknown point cloud extension '" << next << "' for --normals (use .ply, .xyz or .npy)");
            pcp::check_output_path(normals_path, inputs);
            PCP_CHECK(std::filesystem::weakly_canonical(normals_path) != std::filesystem::weakly_canonical(output),
                      normals_path << ": --normals names the output mesh; choose another name");
        }

        const auto t_start = std::chrono::steady_clock::now();
        pcp::PointCloud cloud;
        if (builtin) {
            cloud = pcp::sample_default_shape(args["builtin-points"].as<long>(), args["builtin-noise"].as<double>(), common.seed);
            pcp::check_point_cloud(cloud.points, input, pcp::min_points_for(o.fit.sampling));
        } else {
            cloud = pcp::cli::load_checked_cloud(input, pcp::min_points_for(o.fit.sampling));
        }
        {
            // Peak memory of a run (docs/BENCHMARKS.md, "Memory at 1M points"): about 250 MiB, plus
            // the query fit's pool (at most steps x batch queries, about 52 bytes each while it is
            // built), plus about 0.25 KiB per fitted point (trees and per-point arrays), plus about
            // 100 bytes per input point (the cloud, its subsample, the normals). Refused up front
            // where that cannot fit, rather than left to the OOM killer.
            const auto n = static_cast<double>(cloud.points.rows());
            const double fitted = o.max_fit_points > 0 ? std::min(n, static_cast<double>(o.max_fit_points)) : n;
            const double pool = std::min(fitted * o.fit.sampling.queries_per_point * (1.0 + o.fit.sampling.uniform_fraction),
                                         static_cast<double>(o.fit.steps) * o.fit.queries_per_step);
            pcp::cli::check_memory_for(input + ": fitting " + std::to_string(static_cast<long>(fitted)) + " points",
                                       250.0 + 52.0 * pool / 1048576.0 + 2.5e-4 * fitted + 1e-4 * n,
                                       "fit fewer with --max-points");
        }
        pcp::LocalPrior prior;
        if (!prior_path.empty()) prior = pcp::load_prior(prior_path);
        const double t_read = pcp::cli::seconds_since(t_start);

        const bool subsampled = o.max_fit_points > 0 && cloud.points.rows() > o.max_fit_points;
        pcp::cli::print_parameter_table(log, {{"input", input + " (" + std::to_string(cloud.points.rows()) + " points" +
                                                            (subsampled ? "; the fit uses a random " + std::to_string(o.max_fit_points) +
                                                                              " of them (--max-points)" : std::string()) + ")"},
                                              {"output", output},
                                              {"prior", prior_description(o, prior_path, false)},
                                              {"preset", args.count("scene") ? std::string("scene") : args["preset"].as<std::string>()},
                                              {"denoise", std::string(o.denoise.automatic ? "auto, " + std::to_string(o.denoise.neighbors) + " neighbours"
                                                          : o.denoise.passes > 0 ? std::to_string(o.denoise.passes) + " passes, " +
                                                                                       std::to_string(o.denoise.neighbors) + " neighbours"
                                                                                 : "off") +
                                                              (o.denoise.mode_width > 0 && (o.denoise.automatic || o.denoise.passes > 0)
                                                                   ? ", to the own side's mode (width " + fmt(o.denoise.mode_width) + ")"
                                                                   : "")},
                                              {"query-net steps x batch", std::to_string(o.fit.steps) + " x " + std::to_string(o.fit.queries_per_step)},
                                              {"ablation", pcp::to_string(o.fit.ablation)},
                                              {"resolution", std::to_string(o.resolution)},
                                              {"sign repair", o.sign_repair.enabled ? "on (coarse grid " + std::to_string(std::min(o.sign_repair.resolution, o.resolution)) + ")" : "off"},
                                              {"precision", precision + (o.fp32_grid && precision.rfind("bf16", 0) == 0 ? ", SDF grid fp32" : "")},
                                              {"seed", std::to_string(common.seed)}});
        const auto stage_memory = std::make_shared<pcp::cli::StageMemory>();
        o.progress = pcp::cli::make_progress_printer(log, o.fit.schedule.progress_every, stage_memory);
        o.fit.schedule.checkpoint_path = output + ".ckpt";
        o.fit.schedule.resume = args.count("resume") > 0;
        pcp::ReconstructReport report;
        pcp::Points normals;
        const pcp::Mesh mesh = pcp::reconstruct(cloud.points, prior_path.empty() ? nullptr : &prior, o, &report,
                                                normals_path.empty() ? nullptr : &normals);
        if (report.cancelled) throw pcp::cli::Cancelled("interrupted; continue the query-network stage with --resume");
        pcp::MeshWriteOptions wo;
        wo.ascii = args.count("ascii") > 0;
        pcp::write_mesh(output, mesh, wo);
        if (!normals_path.empty()) {
            pcp::PointCloud oriented;
            oriented.points = cloud.points;
            oriented.properties["nx"] = normals.col(0);
            oriented.properties["ny"] = normals.col(1);
            oriented.properties["nz"] = normals.col(2);
            pcp::write_point_cloud(normals_path, oriented, wo.ascii);
            log.info("wrote " + normals_path + ": " + std::to_string(normals.rows()) + " oriented normals (" +
                     (o.normal_source == pcp::NormalSource::Field
                          ? std::to_string(report.normals.confident) + " oriented by the field's own vote, " +
                                std::to_string(report.normals.weak_orientation) + " by their neighbours"
                          : o.normal_source == pcp::NormalSource::Mesh ? std::string("the mesh's, at the nearest point")
                                                                       : std::string("PCA, turned to the mesh's side")) +
                     "; " + fmt(report.normals.seconds) + " s)");
        }
        std::error_code ec;
        if (!o.keep_checkpoints) std::filesystem::remove(o.fit.schedule.checkpoint_path, ec);
        std::ostringstream s;
        s << "wrote " << output << ": " << mesh.vertices.rows() << " vertices, " << mesh.faces.rows() << " faces, "
          << (report.closed ? "closed" : "NOT closed") << (report.sign_flipped ? " (sign flipped to face outward)" : "")
          << (report.winding_sign.points == 0 ? std::string(", winding sign off")
              : report.winding_sign.skipped
                  ? ", winding sign skipped (the " + std::string(report.winding_sign.by_labels ? "visibility labels orient" : "field orients") + " only " +
                        std::string(report.winding_sign.sampled > 0 ? "about " : "") + std::to_string(report.winding_sign.confident) +
                        " of " + std::to_string(report.winding_sign.points) + " points" +
                        (report.winding_sign.sampled > 0 ? ", from a sample of " + std::to_string(report.winding_sign.sampled) : std::string()) +
                        "; " + fmt(report.winding_sign.seconds) + " s)"
                  : ", winding sign changed " + std::to_string(report.winding_corrected) + " field values (" +
                        std::to_string(report.winding_sign.confident) + " of " + std::to_string(report.winding_sign.points) +
                        " points oriented by the " + std::string(report.winding_sign.by_labels ? "visibility labels" : "field") +
                        ", the others by their neighbours; " + fmt(report.winding_sign.seconds) + " s)")
          << (report.visibility.inside + report.visibility.outside + report.visibility.unknown + report.visibility.near > 0
                  ? ", visibility labels " + std::to_string(report.visibility.inside) + " inside / " +
                        std::to_string(report.visibility.outside) + " outside / " + std::to_string(report.visibility.unknown) +
                        " unknown cells (" + fmt(report.visibility.seconds) + " s)"
                  : std::string())
          << ", sign repair flipped " << report.sign_repair.flipped_components << " of " << report.sign_repair.components
          << " regions away from the data"
          << (report.sign_repair.label_flipped > 0 ? " (" + std::to_string(report.sign_repair.label_flipped) + " by the visibility labels)"
                                                   : std::string());
        log.info(s.str());
        for (const pcp::PassReport& pass : report.passes)
            if (!pass.summary.empty()) log.info("  " + pass.name + ": " + pass.summary + " (" + fmt(pass.seconds) + " s)");
        const double total_s = pcp::cli::seconds_since(t_start);
        pcp::cli::print_stage_table(
            log, {{"read", t_read, -1},
                  {"denoise (" + std::to_string(report.denoise_passes) + " passes)", report.seconds_denoise, -1},
                  {prior_stage(o, prior_path, report), report.seconds_prior, stage_memory->of("prior")},
                  {"query net (" + std::to_string(report.fit_steps) + " steps)", report.seconds_fit, stage_memory->of("query-net")},
                  {"SDF grid and sign repairs", report.seconds_grid, stage_memory->of("sdf-grid")},
                  {"marching cubes, surface fit", report.seconds_mesh, -1},
                  {"total (peak memory of the run)", total_s, pcp::cli::peak_rss_mib()}});
        s.str("");
        s << "| read " << fmt(t_read) << " s | denoise " << fmt(report.seconds_denoise) << " s (" << report.denoise_passes
          << " passes) | prior " << fmt(report.seconds_prior) << " s (loss " << fmt(report.prior_loss)
          << ") | query net " << fmt(report.seconds_fit) << " s (" << report.fit_steps << " steps, loss " << fmt(report.fit_loss)
          << ") | SDF grid " << fmt(report.seconds_grid) << " s (" << report.sdf_evaluations << " evaluations) | marching cubes "
          << fmt(report.seconds_mesh) << " s | total " << fmt(total_s) << " s | precision " << precision << " | peak memory "
          << fmt(pcp::cli::peak_rss_mib()) << " MiB";
        log.info(s.str());
        return 0;
    });
}
