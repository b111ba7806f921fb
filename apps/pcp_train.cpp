// pcp_train INPUTS... -o PRIOR: learns the local context prior from a set of point clouds (stage 1
// of METHOD.md). Inputs are point-cloud files, directories, or a --list file. Progress goes to
// stderr; checkpoints are written every --checkpoint-every steps and on SIGINT/SIGTERM, and
// --resume continues an interrupted run exactly.
#include "cli_common.hpp"

#include "pcp/core/error.hpp"
#include "pcp/core/files.hpp"
#include "pcp/cloud/normalize.hpp"
#include "pcp/io/io.hpp"
#include "pcp/train/prior.hpp"
#include "pcp/train/training_shapes.hpp"
#include "pcp/cloud/regions.hpp"
#include "pcp/cloud/sampling.hpp"

#include <cstdio>
#include <filesystem>
#include <sstream>

namespace {
std::string fmt(double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.6g", v);
    return buf;
}
}  // namespace

int main(int argc, char** argv) {
    return pcp::cli::run_main("pcp_train", [&] {
        const pcp::PriorTrainOptions d = pcp::PriorTrainOptions::preset("default");
        cxxopts::Options options("pcp_train", "Learn a local context prior from point clouds (stage 1 of PCP).\n"
                                              "Option defaults are those of --preset default; a preset sets them all.");
        options.positional_help("INPUT...");
        options.add_options()
            ("inputs", "Point-cloud files or directories", cxxopts::value<std::vector<std::string>>())
            ("list", "A file listing inputs, one per line", cxxopts::value<std::string>()->default_value(""))
            ("shapes", "Also train on this many generated shapes (CSG of boxes, cylinders, cones, tori, plates, shells, "
                       "with holes, blends and cuts; 10k-40k points, some noisy): how the built-in prior is made",
             cxxopts::value<int>()->default_value("0"))
            ("shapes-seed", "Seed of the generated shapes", cxxopts::value<long>()->default_value("1"))
            ("save-shapes", "Write the generated shapes' clouds into this directory (PLY) and stop",
             cxxopts::value<std::string>()->default_value(""))
            ("o,output", "The prior file to write", cxxopts::value<std::string>()->default_value(""))
            ("preset", "paper | default | fast (explicit options below override it)", cxxopts::value<std::string>()->default_value("default"))
            ("dry-run", "Load and split the inputs, report, and stop")
            ("resume", "Continue from the checkpoint (OUTPUT.ckpt) of an interrupted run")
            ("checkpoint-every", "Steps between checkpoints", cxxopts::value<long>()->default_value(std::to_string(d.schedule.checkpoint_every)))
            ("progress-every", "Steps between progress lines", cxxopts::value<long>()->default_value(std::to_string(d.schedule.progress_every)));
        options.add_options("Regions and queries")
            ("grid", "Cells per axis of the region grid (1 = no split)", cxxopts::value<int>()->default_value(std::to_string(d.regions.grid)))
            ("normalization", "Per-region normalisation: none, center, scale, both",
             cxxopts::value<std::string>()->default_value(pcp::to_string(d.regions.normalization)))
            ("min-region-points", "Regions with fewer points are skipped", cxxopts::value<long>()->default_value(std::to_string(d.regions.min_points)))
            ("queries-per-point", "Queries drawn around each point", cxxopts::value<int>()->default_value(std::to_string(d.sampling.queries_per_point)))
            ("queries-per-step", "Queries of one region per step", cxxopts::value<int>()->default_value(std::to_string(d.queries_per_step)));
        pcp::cli::add_sampling_options(options, "Regions and queries", d.sampling);
        options.add_options("Networks and optimisation")
            ("width", "Decoder width H", cxxopts::value<int>()->default_value(std::to_string(d.network.width)))
            ("depth", "Decoder hidden layers L", cxxopts::value<int>()->default_value(std::to_string(d.network.depth)))
            ("condition", "Condition size C", cxxopts::value<int>()->default_value(std::to_string(d.network.condition)))
            ("epochs", "Passes over all regions", cxxopts::value<int>()->default_value(std::to_string(d.epochs)))
            ("steps", "Stop after this many steps instead (0 = epochs x regions)", cxxopts::value<long>()->default_value(std::to_string(d.max_steps)))
            ("lr", "Learning rate", cxxopts::value<double>()->default_value(fmt(d.schedule.learning_rate)))
            ("schedule", "constant | cosine", cxxopts::value<std::string>()->default_value(pcp::to_string(d.schedule.lr_schedule)))
            ("warmup", "Warm-up steps", cxxopts::value<long>()->default_value(std::to_string(d.schedule.warmup_steps)))
            ("clip", "Gradient-norm clipping (0 = off)", cxxopts::value<double>()->default_value(fmt(d.schedule.clip_norm)));
        pcp::cli::add_precision_option(options, "Networks and optimisation");
        options.parse_positional({"inputs"});
        pcp::cli::add_common_options(options);
        cxxopts::ParseResult args;
        pcp::cli::CommonFlags common;
        if (!pcp::cli::parse_command_line(options, argc, argv, args, common)) return 0;
        const std::string precision = pcp::cli::apply_precision(args);
        const pcp::cli::Log log{&common};

        pcp::PriorTrainOptions o;
        try {
            o = pcp::PriorTrainOptions::preset(args["preset"].as<std::string>());
            auto set = [&](const char* name, auto& field) {
                using T = std::decay_t<decltype(field)>;
                if (args.count(name)) field = static_cast<T>(args[name].as<std::conditional_t<std::is_floating_point_v<T>, double,
                                                             std::conditional_t<(sizeof(T) > 4), long, int>>>());
            };
            set("grid", o.regions.grid);
            set("min-region-points", o.regions.min_points);
            set("queries-per-point", o.sampling.queries_per_point);
            set("queries-per-step", o.queries_per_step);
            set("width", o.network.width);
            set("depth", o.network.depth);
            set("condition", o.network.condition);
            set("epochs", o.epochs);
            set("steps", o.max_steps);
            set("lr", o.schedule.learning_rate);
            set("warmup", o.schedule.warmup_steps);
            set("clip", o.schedule.clip_norm);
            set("checkpoint-every", o.schedule.checkpoint_every);
            set("progress-every", o.schedule.progress_every);
            pcp::cli::apply_sampling_flags(args, o.sampling);
            if (args.count("normalization")) o.regions.normalization = pcp::parse_region_normalization(args["normalization"].as<std::string>());
            if (args.count("schedule")) o.schedule.lr_schedule = pcp::parse_lr_schedule(args["schedule"].as<std::string>());
        } catch (const pcp::Error& e) {
            throw pcp::cli::UsageError(e.what());
        }
        if (o.regions.grid < 1 || o.regions.grid > 64) throw pcp::cli::UsageError("--grid must be in [1, 64]");
        if (o.regions.min_points < pcp::min_points_for(o.sampling))
            throw pcp::cli::UsageError("--min-region-points must be >= " + std::to_string(pcp::min_points_for(o.sampling)));
        if (o.queries_per_step < 1 || o.sampling.queries_per_point < 1 || o.network.width < 1 || o.network.depth < 1 ||
            o.network.condition < 1 || o.epochs < 0 || o.max_steps < 0 || !(o.schedule.learning_rate > 0) ||
            o.schedule.checkpoint_every < 0 || o.schedule.progress_every < 1)
            throw pcp::cli::UsageError("sizes, steps and rates must be positive");
        o.schedule.seed = common.seed;

        const std::vector<std::string> positional =
            args.count("inputs") ? args["inputs"].as<std::vector<std::string>>() : std::vector<std::string>{};
        const std::vector<std::string> inputs = positional.empty() && args["list"].as<std::string>().empty()
                                                    ? std::vector<std::string>{}
                                                    : pcp::cli::collect_inputs(positional, args["list"].as<std::string>());
        const int num_shapes = args["shapes"].as<int>();
        if (num_shapes < 0 || num_shapes > 100000) throw pcp::cli::UsageError("--shapes must be in [0, 100000]");
        const std::string save_shapes = args["save-shapes"].as<std::string>();
        if (!save_shapes.empty() && num_shapes == 0) throw pcp::cli::UsageError("--save-shapes needs --shapes N");
        if (inputs.empty() && num_shapes == 0) throw pcp::cli::UsageError("no inputs (give files, directories, --list or --shapes)");
        const std::string output = args["output"].as<std::string>();
        const bool dry_run = args.count("dry-run") > 0;
        if (!dry_run && save_shapes.empty()) {  // checked before the shapes are generated
            if (output.empty()) throw pcp::cli::UsageError("-o/--output is required");
            pcp::check_output_path(output, inputs);
        }
        std::vector<pcp::TrainingCloud> generated;
        if (num_shapes > 0) {
            pcp::TrainingShapeOptions so;
            so.count = num_shapes;
            so.seed = static_cast<std::uint64_t>(args["shapes-seed"].as<long>());
            generated = pcp::generate_training_clouds(so);
        }
        if (!save_shapes.empty()) {
            std::filesystem::create_directories(save_shapes);
            for (std::size_t i = 0; i < generated.size(); ++i) {
                char name[32];
                std::snprintf(name, sizeof name, "shape_%03zu.ply", i);
                pcp::PointCloud cloud;
                cloud.points = generated[i].points;
                pcp::write_point_cloud((std::filesystem::path(save_shapes) / name).string(), cloud);
                log.info(generated[i].name);
            }
            log.info("wrote " + std::to_string(generated.size()) + " clouds into " + save_shapes);
            return 0;
        }

        const auto t_start = std::chrono::steady_clock::now();
        std::vector<pcp::TrainingCloud> clouds;
        for (const std::string& path : inputs) {
            pcp::TrainingCloud c{path, pcp::cli::load_checked_cloud(path, pcp::min_points_for(o.sampling)).points};
            if (dry_run) {
                const std::vector<pcp::Region> found = pcp::split_into_regions(pcp::fit_unit_box(c.points).to_unit(c.points), o.regions);
                log.info(path + ": " + std::to_string(c.points.rows()) + " points, " + std::to_string(found.size()) +
                         " regions with >= " + std::to_string(o.regions.min_points) + " points on a " +
                         std::to_string(o.regions.grid) + "^3 grid");
            }
            clouds.push_back(std::move(c));
        }
        for (pcp::TrainingCloud& c : generated) clouds.push_back(std::move(c));
        const double t_read = pcp::cli::seconds_since(t_start);

        const auto t_prep = std::chrono::steady_clock::now();
        o.schedule.checkpoint_path = dry_run ? "" : output + ".ckpt";
        o.schedule.progress = pcp::cli::make_progress_printer(log, o.schedule.progress_every);
        o.schedule.resume = args.count("resume") > 0;
        pcp::PriorTrainer trainer(clouds, o);
        const double t_setup = pcp::cli::seconds_since(t_prep);
        pcp::cli::print_parameter_table(log, {{"inputs", std::to_string(inputs.size()) + " cloud(s) + " + std::to_string(num_shapes) + " generated"},
                                              {"regions", std::to_string(trainer.num_regions())},
                                              {"steps", std::to_string(trainer.total_steps())},
                                              {"settings", trainer.prior().provenance.settings},
                                              {"precision", precision},
                                              {"output", dry_run ? "(dry run)" : output}});
        if (dry_run) return 0;
        if (o.schedule.resume)
            log.info(std::filesystem::exists(o.schedule.checkpoint_path) ? "resuming from " + o.schedule.checkpoint_path
                                                                         : "no checkpoint " + o.schedule.checkpoint_path + ": starting at step 0");
        const auto t_train = std::chrono::steady_clock::now();
        const bool finished = trainer.run();
        const double train_s = pcp::cli::seconds_since(t_train);
        if (!finished) throw pcp::cli::Cancelled("stopped at step " + std::to_string(trainer.steps_done()) + "; checkpoint " +
                                                 o.schedule.checkpoint_path + " (continue with --resume)");
        pcp::save_prior(output, trainer.prior());
        std::error_code ec;
        std::filesystem::remove(o.schedule.checkpoint_path, ec);
        log.info("wrote " + output + " | read " + fmt(t_read) + " s | regions + queries " + fmt(t_setup) + " s | training " +
                 fmt(train_s) + " s (" + precision + ") | final loss " + fmt(trainer.recent_loss()) + " | peak memory " +
                 fmt(pcp::cli::peak_rss_mib()) + " MiB");
        return 0;
    });
}
