// pcp_demo2d: the paper's plane demonstration -- a prior learned on a circle, a query network
// trained for a square on it -- written as PNG pictures with the run's measurements.
#include "cli_common.hpp"

#include "pcp/core/error.hpp"
#include "pcp/demo/demo2d.hpp"

#include <cstdio>
#include <filesystem>
#include <iostream>
#include <string>

int main(int argc, char** argv) {
    return pcp::cli::run_main("pcp_demo2d", [&] {
        const pcp::demo::Demo2dOptions d;
        cxxopts::Options options(
            "pcp_demo2d",
            "The paper's 2D demonstration: a local SDF prior F learned on a circle, then a query network Q trained "
            "for a square on that frozen prior. Writes figure.png (four panels) and each panel on its own: the prior, "
            "the square's queries coloured by angle, their predicted queries q_l' in the circle's frame with the same "
            "colours, and the zero set of F_g against the square. Prints how close the zero set is to the square and "
            "the predicted queries of the square's points to the circle.");
        options.add_options()
            ("o,output-dir", "Directory for the pictures (created if missing)", cxxopts::value<std::string>()->default_value(""))
            ("size", "Pixels per panel side, in [64, 4096]", cxxopts::value<int>()->default_value("480"))
            ("prior-steps", "Training steps of the prior on the circle", cxxopts::value<int>()->default_value(std::to_string(d.prior_steps)))
            ("fit-steps", "Training steps of the query network on the square", cxxopts::value<int>()->default_value(std::to_string(d.fit_steps)))
            ("predict-condition", "Q predicts the condition f' too (the full method); by default F keeps the circle's "
                                  "condition, as in the paper's figure");
        pcp::cli::add_common_options(options);
        cxxopts::ParseResult args;
        pcp::cli::CommonFlags common;
        if (!pcp::cli::parse_command_line(options, argc, argv, args, common)) return 0;
        const pcp::cli::Log log{&common};
        const std::string dir = args["output-dir"].as<std::string>();
        if (dir.empty()) throw pcp::cli::UsageError("need -o DIR");
        const int size = args["size"].as<int>();
        if (size < 64 || size > 4096) throw pcp::cli::UsageError("--size must be in [64, 4096]");

        pcp::demo::Demo2dOptions o;
        o.prior_steps = args["prior-steps"].as<int>();
        o.fit_steps = args["fit-steps"].as<int>();
        if (o.prior_steps < 1 || o.fit_steps < 1) throw pcp::cli::UsageError("--prior-steps and --fit-steps must be positive");
        o.predict_condition = args.count("predict-condition") > 0;
        o.seed = common.seed;

        // The directory first: a run that cannot write its pictures should not train.
        std::error_code ec;
        std::filesystem::create_directories(dir, ec);
        if (ec || !std::filesystem::is_directory(dir))
            throw pcp::Error(dir + ": cannot create the output directory" + (ec ? " (" + ec.message() + ")" : std::string()));

        pcp::cli::print_parameter_table(log, {{"output directory", dir},
                                              {"circle radius / square half side",
                                               std::to_string(o.circle_radius) + " / " + std::to_string(o.square_half_side)},
                                              {"steps (prior, query net)", std::to_string(o.prior_steps) + ", " + std::to_string(o.fit_steps)},
                                              {"condition of F", o.predict_condition ? "predicted by Q (the method)" : "the circle's f"},
                                              {"seed", std::to_string(o.seed)}});
        const pcp::demo::Demo2dResult r = pcp::demo::run_demo2d(o, pcp::cli::make_progress_printer(log, 500));
        pcp::cli::end_progress_line();
        if (r.cancelled) throw pcp::cli::Cancelled("interrupted; no pictures written");
        const auto written = pcp::demo::write_demo2d_pictures(r, o, dir, size);

        char line[512];
        std::snprintf(line, sizeof line,
                      "pcp_demo2d: prior %.1f s (loss %.5f), query net %.1f s (loss %.5f)\n"
                      "  zero set of F_g to the square: mean %.4f, max %.4f; largest gap along the square %.4f "
                      "(domain [-1, 1]^2, grid cell %.4f; sign repair flipped %d regions away from the square)\n"
                      "  predicted queries of the square's points, | |q_l'| - r |: median %.4f, 90th percentile %.4f "
                      "(r = %.2f)\n",
                      r.prior_seconds, r.prior_loss, r.fit_seconds, r.fit_loss, r.zero_set_mean_distance,
                      r.zero_set_max_distance, r.square_max_gap, 2.0 / o.grid, r.sign_repaired_regions, r.predicted_radius_median,
                      r.predicted_radius_p90, o.circle_radius);
        std::cout << line;
        for (const std::string& w : written) std::cout << "  wrote " << w << "\n";
        return 0;
    });
}
