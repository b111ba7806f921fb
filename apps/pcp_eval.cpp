// pcp_eval PRED GT: compares a reconstructed mesh with ground truth using the paper's metrics
// (METHOD.md section 6) under the p2s / shapenet / scene protocols; prints a table, JSON, or
// tab-separated lines for scripts (--tsv).
#include "cli_common.hpp"

#include "pcp/core/error.hpp"
#include "pcp/eval/eval.hpp"
#include "pcp/core/files.hpp"
#include "pcp/io/io.hpp"

#include <cmath>
#include <cstdio>
#include <optional>
#include <iostream>
#include <sstream>

namespace {

std::string join_thresholds(const std::vector<double>& values) {
    std::ostringstream out;
    for (std::size_t i = 0; i < values.size(); ++i) out << (i ? "," : "") << values[i];
    return out.str();
}

std::vector<double> parse_thresholds(const std::string& text) {
    std::vector<double> values;
    std::stringstream in(text);
    std::string item;
    while (std::getline(in, item, ',')) {
        try {
            std::size_t used = 0;
            const double v = std::stod(item, &used);
            if (used != item.size() || !(v > 0)) throw std::invalid_argument(item);
            values.push_back(v);
        } catch (const std::exception&) {
            throw pcp::cli::UsageError("--thresholds: '" + item + "' is not a positive number");
        }
    }
    return values;
}

/// Ground truth as a mesh, or as points with normals (point-only formats, or --gt-points).
struct GroundTruth {
    bool is_mesh = true;
    pcp::Mesh mesh;
    pcp::SurfaceSamples points;
};

GroundTruth read_ground_truth(const std::string& path, bool force_points) {
    GroundTruth gt;
    const std::string ext = pcp::file_extension(path);
    if (!force_points && (ext == ".ply" || ext == ".obj" || ext == ".off")) {
        gt.mesh = pcp::read_mesh(path);
        PCP_CHECK(gt.mesh.faces.rows() > 0, path << ": the ground-truth mesh has no faces (use --gt-points for a point cloud with normals)");
        return gt;
    }
    gt.is_mesh = false;
    const pcp::PointCloud cloud = pcp::read_point_cloud(path);
    for (const char* name : {"nx", "ny", "nz"})
        PCP_CHECK(cloud.properties.count(name), path << ": ground-truth points need normals (properties nx, ny, nz)");
    gt.points.points = cloud.points;
    gt.points.normals.resize(cloud.points.rows(), 3);
    gt.points.normals << cloud.properties.at("nx"), cloud.properties.at("ny"), cloud.properties.at("nz");
    gt.points.normals.rowwise().normalize();
    return gt;
}

void print_metrics_json(std::ostream& out, const pcp::Metrics& m) {
    out << "{\"chamfer_l1\": " << m.chamfer_l1 << ", \"chamfer_l2\": " << m.chamfer_l2
        << ", \"chamfer_l2_x100\": " << 100.0 * m.chamfer_l2 << ", \"normal_consistency\": " << m.normal_consistency
        << ", \"hausdorff\": " << m.hausdorff << ", \"fscores\": [";
    for (std::size_t i = 0; i < m.fscores.size(); ++i)
        out << (i ? ", " : "") << "{\"threshold\": " << m.fscores[i].threshold << ", \"precision\": " << m.fscores[i].precision
            << ", \"recall\": " << m.fscores[i].recall << ", \"fscore\": " << m.fscores[i].fscore << "}";
    out << "]}";
}

struct SdfReport {
    pcp::SignAgreement result;
    std::string convention;
};

/// Sign agreement of `pred` with the samples of `path`, binned at 0.5, 1, 2, 4 and 8 % of the
/// samples' bounding box's longest edge.
SdfReport sign_report(const pcp::Mesh& pred, const GroundTruth& gt, const std::string& path, const std::string& convention) {
    const pcp::PointCloud samples = pcp::read_point_cloud(path);
    PCP_CHECK(samples.properties.count("sdf"), path << ": no property 'sdf' (signed-distance samples need one)");
    PCP_CHECK(samples.points.rows() > 0, path << ": no samples");
    const Eigen::VectorXd& sdf = samples.properties.at("sdf");
    PCP_CHECK(sdf.allFinite(), path << ": the property 'sdf' has values that are not finite");
    SdfReport report;
    pcp::SdfConvention c;
    if (convention == "negative-inside") {
        c = pcp::SdfConvention::NegativeInside;
    } else if (convention == "positive-inside") {
        c = pcp::SdfConvention::PositiveInside;
    } else {
        if (!gt.is_mesh) throw pcp::cli::UsageError("--sdf-convention auto needs a ground-truth mesh; name the convention");
        double reference = 0;
        c = pcp::detect_sdf_convention(gt.mesh, samples.points, sdf, &reference);
        PCP_CHECK(reference >= 0.9, path << ": the ground-truth mesh agrees with neither sign convention of these samples (best "
                                         << reference << "); are they in its frame?");
    }
    report.convention = c == pcp::SdfConvention::NegativeInside ? "negative inside" : "positive inside";
    const double extent = (samples.points.colwise().maxCoeff() - samples.points.colwise().minCoeff()).maxCoeff();
    std::vector<double> edges;
    for (double f : {0.005, 0.01, 0.02, 0.04, 0.08}) edges.push_back(f * extent);
    if (!(extent > 0)) edges.clear();
    report.result = pcp::sign_agreement(pred, samples.points, sdf, c, edges);
    return report;
}

}  // namespace

int main(int argc, char** argv) {
    return pcp::cli::run_main("pcp_eval", [&] {
        const pcp::EvalOptions defaults;
        cxxopts::Options options("pcp_eval", "Compare a reconstructed mesh PRED with ground truth GT (mesh, or points with normals).");
        options.positional_help("PRED GT");
        options.add_options()
            ("pred", "Reconstructed mesh (.ply .obj .off)", cxxopts::value<std::string>())
            ("gt", "Ground truth: a mesh, or points with normals", cxxopts::value<std::string>())
            ("protocol", "p2s (10k samples, GT bbox longest edge = 1), shapenet (100k samples), scene (metres, 100k)",
             cxxopts::value<std::string>()->default_value(pcp::to_string(defaults.protocol)))
            ("samples", "Surface samples per side (0 = the protocol's)", cxxopts::value<long>()->default_value(std::to_string(defaults.samples)))
            ("thresholds", "F-score thresholds, comma-separated (default: the protocol's)", cxxopts::value<std::string>()->default_value(""))
            ("gt-points", "Read GT as a point cloud with normals even if it is a .ply")
            ("sdf-samples", "Also report how often PRED puts these signed-distance samples (a point cloud with a property 'sdf', in GT's frame) on the right side, by |sdf|",
             cxxopts::value<std::string>()->default_value(""))
            ("sdf-convention", "auto (judged by GT's winding numbers; needs a GT mesh) | negative-inside | positive-inside",
             cxxopts::value<std::string>()->default_value("auto"))
            ("no-floor", "Skip the floor (GT against an independent sampling of itself)")
            ("json", "Print JSON instead of a table")
            ("tsv", "Print one tab-separated line per metric: name, value, floor (\"-\" without one)");
        options.parse_positional({"pred", "gt"});
        pcp::cli::add_common_options(options);
        cxxopts::ParseResult args;
        pcp::cli::CommonFlags common;
        if (!pcp::cli::parse_command_line(options, argc, argv, args, common)) return 0;
        if (!args.count("pred") || !args.count("gt")) throw pcp::cli::UsageError("need PRED and GT");
        if (args.count("json") && args.count("tsv")) throw pcp::cli::UsageError("--json and --tsv exclude each other");

        pcp::EvalOptions opts;
        try {
            opts.protocol = pcp::parse_eval_protocol(args["protocol"].as<std::string>());
        } catch (const pcp::Error& e) {
            throw pcp::cli::UsageError(e.what());
        }
        if (args["samples"].as<long>() < 0) throw pcp::cli::UsageError("--samples must be >= 0");
        opts.samples = args["samples"].as<long>();
        opts.fscore_thresholds = parse_thresholds(args["thresholds"].as<std::string>());
        opts.seed = common.seed;
        opts.with_floor = !args.count("no-floor");

        const std::string convention = args["sdf-convention"].as<std::string>();
        if (convention != "auto" && convention != "negative-inside" && convention != "positive-inside")
            throw pcp::cli::UsageError("--sdf-convention: '" + convention + "' is not auto, negative-inside or positive-inside");
        const std::string pred_path = args["pred"].as<std::string>(), gt_path = args["gt"].as<std::string>();
        const pcp::Mesh pred = pcp::read_mesh(pred_path);
        PCP_CHECK(pred.faces.rows() > 0, pred_path << ": the predicted mesh has no faces");
        const GroundTruth gt = read_ground_truth(gt_path, args.count("gt-points") > 0);
        const pcp::EvalResult r = gt.is_mesh ? pcp::evaluate(pred, gt.mesh, opts) : pcp::evaluate(pred, gt.points, opts);
        const std::string sdf_path = args["sdf-samples"].as<std::string>();
        const std::optional<SdfReport> sdf =
            sdf_path.empty() ? std::nullopt
                             : std::optional<SdfReport>(sign_report(pred, gt, sdf_path, convention));

        if (args.count("json")) {
            std::cout.precision(9);
            std::cout << "{\"pred\": \"" << pred_path << "\", \"gt\": \"" << gt_path << "\", \"protocol\": \""
                      << pcp::to_string(opts.protocol) << "\", \"samples\": " << r.samples << ", \"frame_scale\": "
                      << r.frame_scale << ", \"scene_error\": " << r.scene_error << ", \"metrics\": ";
            print_metrics_json(std::cout, r.metrics);
            if (opts.with_floor && gt.is_mesh) {
                std::cout << ", \"floor\": ";
                print_metrics_json(std::cout, r.floor);
            }
            if (sdf) {
                std::cout << ", \"sign_agreement\": {\"samples\": " << sdf->result.samples << ", \"fraction\": " << sdf->result.fraction()
                          << ", \"convention\": \"" << sdf->convention << "\", \"bins\": [";
                for (std::size_t b = 0; b < sdf->result.bins.size(); ++b) {
                    const auto& bin = sdf->result.bins[b];
                    std::cout << (b ? ", " : "") << "{\"lower\": " << bin.lower << ", \"upper\": ";
                    if (std::isinf(bin.upper)) std::cout << "null";
                    else std::cout << bin.upper;
                    std::cout << ", \"samples\": " << bin.samples << ", \"agree\": " << bin.agree << "}";
                }
                std::cout << "]}";
            }
            std::cout << "}" << std::endl;
            return 0;
        }
        const bool floor = opts.with_floor && gt.is_mesh;
        if (args.count("tsv")) {
            // For scripts (bench/run_benchmarks.sh): fixed names, no quoting, one line each.
            std::cout.precision(9);
            auto line = [&](const std::string& name, double value, bool has_floor, double floor_value) {
                std::cout << name << "\t" << value << "\t";
                if (has_floor) std::cout << floor_value;
                else std::cout << "-";
                std::cout << "\n";
            };
            std::cout << "protocol\t" << pcp::to_string(opts.protocol) << "\t-\n";
            line("samples", static_cast<double>(r.samples), false, 0);
            line("frame_scale", r.frame_scale, false, 0);
            line("chamfer_l1", r.metrics.chamfer_l1, floor, r.floor.chamfer_l1);
            line("chamfer_l2", r.metrics.chamfer_l2, floor, r.floor.chamfer_l2);
            line("chamfer_l2_x100", 100 * r.metrics.chamfer_l2, floor, 100 * r.floor.chamfer_l2);
            line("normal_consistency", r.metrics.normal_consistency, floor, r.floor.normal_consistency);
            line("hausdorff", r.metrics.hausdorff, floor, r.floor.hausdorff);
            for (std::size_t i = 0; i < r.metrics.fscores.size(); ++i)
                line("fscore@" + join_thresholds({r.metrics.fscores[i].threshold}), r.metrics.fscores[i].fscore, floor,
                     floor ? r.floor.fscores[i].fscore : 0.0);
            if (gt.is_mesh) line("scene_error", r.scene_error, false, 0);
            if (sdf) {
                line("sign_agreement", sdf->result.fraction(), false, 0);
                for (const auto& bin : sdf->result.bins)
                    line("sign_agreement|sdf|>=" + join_thresholds({bin.lower}), bin.fraction(),
                         false, 0);
            }
            std::cout << std::flush;
            return 0;
        }
        auto row = [&](const char* name, double value, double floor_value) {
            char buf[160];
            if (floor) std::snprintf(buf, sizeof buf, "| %-22s | %12.6g | %12.6g |", name, value, floor_value);
            else std::snprintf(buf, sizeof buf, "| %-22s | %12.6g |", name, value);
            std::cout << buf << "\n";
        };
        std::cout << "pcp_eval: " << pred_path << " vs " << gt_path << " (protocol " << pcp::to_string(opts.protocol)
                  << ", " << r.samples << " samples, seed " << opts.seed << ")\n";
        std::cout << (floor ? "| metric                 |        value |        floor |\n|---|---|---|\n"
                            : "| metric                 |        value |\n|---|---|\n");
        row("L1-CD", r.metrics.chamfer_l1, r.floor.chamfer_l1);
        row("L2-CD", r.metrics.chamfer_l2, r.floor.chamfer_l2);
        row("L2-CD x 100", 100 * r.metrics.chamfer_l2, 100 * r.floor.chamfer_l2);
        row("normal consistency", r.metrics.normal_consistency, r.floor.normal_consistency);
        row("Hausdorff", r.metrics.hausdorff, r.floor.hausdorff);
        for (std::size_t i = 0; i < r.metrics.fscores.size(); ++i) {
            const std::string name = "F-score @ " + join_thresholds({r.metrics.fscores[i].threshold});
            row(name.c_str(), r.metrics.fscores[i].fscore, floor ? r.floor.fscores[i].fscore : 0.0);
        }
        if (gt.is_mesh) row("scene error", r.scene_error, 0.0);
        if (sdf) {
            std::cout << "\nsign agreement with " << sdf_path << " (" << sdf->convention << "): " << sdf->result.agree << " of "
                      << sdf->result.samples << " = " << sdf->result.fraction() << "\n| abs(sdf) from | to | samples | agreement |\n|---|---|---|---|\n";
            for (const auto& bin : sdf->result.bins)
                std::cout << "| " << bin.lower << " | " << bin.upper << " | " << bin.samples << " | "
                          << bin.fraction() << " |\n";
        }
        return 0;
    });
}
