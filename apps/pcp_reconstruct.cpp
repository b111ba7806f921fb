// pcp_reconstruct [INPUT] -o OUT: point cloud -> mesh by PCP. Without INPUT it runs on the
// embedded default shape (a block with sharp edges, a through-hole and a thin fin, sampled with
// noise). Options: a preset (default, fast, paper, scene), then the settings of pcp/settings.hpp,
// the common ones listed by --help as --NAME VALUE, every one also as --NAME VALUE or
// --set NAME=VALUE (--list-settings prints them all with their defaults and ranges). Progress,
// checkpoints of the query-network stage (OUT.ckpt, every checkpoint-every steps and on
// SIGINT/SIGTERM), --resume, and a report of every stage and pass. Several inputs (files,
// directories, --list) with --output-dir DIR: one query network for all of them, each query
// conditioned on its cloud's one-hot code (pcp::reconstruct_many), one mesh per input.
#include "reconstruct_cli.hpp"

#include "pcp/cloud/shapes.hpp"
#include "pcp/core/error.hpp"
#include "pcp/core/files.hpp"
#include "pcp/io/io.hpp"
#include "pcp/reconstruct.hpp"
#include "pcp/settings.hpp"
#include "pcp/train/prior.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

namespace {

using pcp::cli::check_fit_memory;
using pcp::cli::fmt;
using pcp::cli::prior_description;
using pcp::cli::prior_stage;

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
    check_fit_memory(std::to_string(inputs.size()) + " inputs: fitting " + std::to_string(static_cast<long>(fitted_points)) + " points",
                     fitted_points, total_points, o, "fit fewer inputs at once, or fewer points with --max-points");
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
        const pcp::ReconstructOptions d;  // the default preset: the defaults --help shows
        cxxopts::Options options("pcp_reconstruct",
                                 "Reconstruct a mesh from an unoriented point cloud (.ply .xyz .txt .pts .npy) with PCP.\n"
                                 "Without INPUT, runs on the embedded default shape. Option defaults are those of --preset default;\n"
                                 "every setting of --list-settings is also taken as --NAME VALUE or --set NAME=VALUE.");
        options.positional_help("[INPUT...]");
        options.add_options()
            ("input", "Point cloud file; several (files or directories of them) with --output-dir: one query network for "
                      "all, a one-hot code per cloud (the paper's multi-cloud fit)", cxxopts::value<std::vector<std::string>>())
            ("o,output", "Output mesh (.ply .obj .off)", cxxopts::value<std::string>()->default_value("pcp_mesh.ply"))
            ("output-dir", "With several inputs: write DIR/<input name>.ply for each (DIR/<its directory>_<name>.ply when "
                           "names repeat; created if missing)", cxxopts::value<std::string>()->default_value(""))
            ("list", "A file naming input clouds, one per line ('#' comments; relative to the file); implies several "
                     "inputs (--output-dir)", cxxopts::value<std::string>()->default_value(""))
            ("normals", "Also write the input points with their oriented normals (nx ny nz, outward; .ply .xyz .npy)",
             cxxopts::value<std::string>()->default_value(""))
            ("prior", "A prior trained by pcp_train (default: see --prior-source)", cxxopts::value<std::string>()->default_value(""))
            ("self-prior", "The same as --prior-source self")
            ("preset", "default | fast | paper | scene (the settings below override it)", cxxopts::value<std::string>()->default_value("default"))
            ("scene", "The same as --preset scene: a room or other open surfaces, faces kept only where the data supports them")
            ("set", "NAME=VALUE: any setting of --list-settings (repeatable)", cxxopts::value<std::vector<std::string>>())
            ("list-settings", "Print every setting with its value in the preset, its range and what it does, and exit")
            ("ascii", "Write an ascii .ply")
            ("resume", "Continue the query-network stage from OUT.ckpt")
            ("keep-checkpoint", "Keep OUT.ckpt and OUT.ckpt.prior, so that a run with --resume re-meshes without training again")
            ("builtin-points", "Points sampled on the embedded default shape", cxxopts::value<long>()->default_value("20000"))
            ("builtin-noise", "Noise of the embedded default shape (shape units; the shape is about 1 long)",
             cxxopts::value<double>()->default_value("0.002"));
        for (const pcp::Setting& s : pcp::reconstruct_settings())
            if (s.listed)
                options.add_options(s.group)(s.name, s.help + " (" + s.range + ")", cxxopts::value<std::string>()->default_value(s.get(d)));
        options.parse_positional({"input"});
        pcp::cli::add_common_options(options);
        pcp::cli::add_precision_option(options, "Query network (stage 2)");
        const std::vector<std::string> rewritten = pcp::cli::settings_as_set(argc, argv);
        std::vector<char*> args_v;
        for (const std::string& a : rewritten) args_v.push_back(const_cast<char*>(a.c_str()));
        cxxopts::ParseResult args;
        pcp::cli::CommonFlags common;
        if (!pcp::cli::parse_command_line(options, static_cast<int>(args_v.size()), args_v.data(), args, common)) return 0;
        const std::string precision = pcp::cli::apply_precision(args);
        const pcp::cli::Log log{&common};
        pcp::ReconstructOptions o = pcp::cli::options_from(args);
        if (args.count("list-settings")) {
            pcp::cli::list_settings(o);
            return 0;
        }
        if (args["builtin-points"].as<long>() < pcp::min_points_for(o.fit.sampling))
            throw pcp::cli::UsageError("--builtin-points must be >= " + std::to_string(pcp::min_points_for(o.fit.sampling)));
        o.keep_checkpoints = args.count("keep-checkpoint") > 0;
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
        const auto all_points = static_cast<double>(cloud.points.rows());
        const double fit_points = o.max_fit_points > 0 ? std::min(all_points, static_cast<double>(o.max_fit_points)) : all_points;
        check_fit_memory(input + ": fitting " + std::to_string(static_cast<long>(fit_points)) + " points", fit_points, all_points, o,
                         "fit fewer with --max-points");
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
        log.info("wrote " + output + ": " + std::to_string(mesh.vertices.rows()) + " vertices, " + std::to_string(mesh.faces.rows()) +
                 " faces, " + (report.closed ? "closed" : "NOT closed") + (report.sign_flipped ? " (sign flipped to face outward)" : ""));
        pcp::cli::report_passes(log, report);
        std::ostringstream s;
        const double total_s = pcp::cli::seconds_since(t_start);
        pcp::cli::print_stage_table(
            log, {{"read", t_read, -1},
                  {"denoise (" + std::to_string(report.denoise_passes) + " passes)", report.seconds_denoise, -1},
                  {prior_stage(o, prior_path, report), report.seconds_prior, stage_memory->of("prior")},
                  {"query net (" + std::to_string(report.fit_steps) + " steps)", report.seconds_fit, stage_memory->of("query-net")},
                  {"SDF grid and sign repairs", report.seconds_grid, stage_memory->of("sdf-grid")},
                  {"marching cubes, surface fit", report.seconds_mesh, -1},
                  {"total (peak memory of the run)", total_s, pcp::cli::peak_rss_mib()}});
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
