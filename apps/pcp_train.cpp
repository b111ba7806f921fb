// pcp_train INPUTS... -o PRIOR: learns the local context prior from a set of point clouds (stage 1
// of METHOD.md). Inputs are point-cloud files, directories, or a --list file. The training loop
// lands with the prior-training stage; until then this loads and splits every cloud into regions
// and reports them (--dry-run), and refuses to pretend to train.
#include "cli_common.hpp"

#include "pcp/error.hpp"
#include "pcp/files.hpp"
#include "pcp/normalize.hpp"
#include "pcp/regions.hpp"
#include "pcp/sampling.hpp"

#include <sstream>

int main(int argc, char** argv) {
    return pcp::cli::run_main("pcp_train", [&] {
        const pcp::RegionOptions region_defaults;
        const pcp::SamplingOptions sampling_defaults;
        cxxopts::Options options("pcp_train", "Learn a local context prior from point clouds.");
        options.positional_help("INPUT...");
        options.add_options()
            ("inputs", "Point-cloud files or directories", cxxopts::value<std::vector<std::string>>())
            ("list", "A file listing inputs, one per line", cxxopts::value<std::string>()->default_value(""))
            ("o,output", "The prior file to write", cxxopts::value<std::string>()->default_value(""))
            ("dry-run", "Load and split the inputs, report, and stop");
        options.add_options("Regions")
            ("grid", "Cells per axis of the region grid (1 = no split)",
             cxxopts::value<int>()->default_value(std::to_string(region_defaults.grid)))
            ("normalization", "Per-region normalisation: none, center, scale, both",
             cxxopts::value<std::string>()->default_value(pcp::to_string(region_defaults.normalization)))
            ("min-region-points", "Regions with fewer points are skipped",
             cxxopts::value<long>()->default_value(std::to_string(region_defaults.min_points)));
        options.parse_positional({"inputs"});
        pcp::cli::add_common_options(options);
        cxxopts::ParseResult args;
        pcp::cli::CommonFlags common;
        if (!pcp::cli::parse_command_line(options, argc, argv, args, common)) return 0;
        const pcp::cli::Log log{&common};

        pcp::RegionOptions regions;
        regions.grid = args["grid"].as<int>();
        regions.min_points = args["min-region-points"].as<long>();
        try {
            regions.normalization = pcp::parse_region_normalization(args["normalization"].as<std::string>());
        } catch (const pcp::Error& e) {
            throw pcp::cli::UsageError(e.what());
        }
        if (regions.grid < 1 || regions.grid > 64) throw pcp::cli::UsageError("--grid must be in [1, 64]");
        if (regions.min_points < pcp::min_points_for(sampling_defaults))
            throw pcp::cli::UsageError("--min-region-points must be >= " + std::to_string(pcp::min_points_for(sampling_defaults)));

        const std::vector<std::string> positional =
            args.count("inputs") ? args["inputs"].as<std::vector<std::string>>() : std::vector<std::string>{};
        const std::vector<std::string> inputs = pcp::cli::collect_inputs(positional, args["list"].as<std::string>());
        if (inputs.empty()) throw pcp::cli::UsageError("no inputs (give files, directories or --list)");
        const std::string output = args["output"].as<std::string>();
        const bool dry_run = args.count("dry-run") > 0;
        if (!dry_run) {
            if (output.empty()) throw pcp::cli::UsageError("-o/--output is required");
            pcp::check_output_path(output, inputs);
        }

        long total_regions = 0;
        for (const std::string& path : inputs) {
            const pcp::PointCloud cloud = pcp::cli::load_checked_cloud(path, pcp::min_points_for(sampling_defaults));
            const pcp::Normalization norm = pcp::fit_unit_box(cloud.points);
            const std::vector<pcp::Region> found = pcp::split_into_regions(norm.to_unit(cloud.points), regions);
            std::ostringstream line;
            line << path << ": " << cloud.points.rows() << " points, " << found.size() << " regions with >= "
                 << regions.min_points << " points on a " << regions.grid << "^3 grid";
            log.info(line.str());
            total_regions += static_cast<long>(found.size());
        }
        PCP_CHECK(total_regions > 0, "no region of any input has at least " << regions.min_points
                                         << " points: use a coarser --grid or denser clouds");
        if (dry_run) return 0;
        PCP_FAIL("prior training is not implemented in this version yet (use --dry-run to check inputs)");
    });
}
