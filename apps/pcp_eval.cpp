// pcp_eval PRED GT: compares a reconstructed mesh with ground truth using the paper's metrics
// (METHOD.md section 6) under the p2s / shapenet / scene protocols; prints a table, JSON, or
// tab-separated lines for scripts (--tsv). With --diagnose it prints the error budget of
// pcp::diagnose() instead (components, support by --input, the split of L2-CD).
#include "cli_common.hpp"

#include "pcp/core/error.hpp"
#include "pcp/eval/diagnose.hpp"
#include "pcp/eval/eval.hpp"
#include "pcp/core/files.hpp"
#include "pcp/io/io.hpp"

#include <algorithm>
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


/// A component's row fields, shared by the JSON and TSV printers.
std::vector<std::pair<std::string, double>> component_fields(const pcp::ComponentInfo& c) {
    return {{"faces", static_cast<double>(c.faces)}, {"vertices", static_cast<double>(c.vertices)},
            {"edges", static_cast<double>(c.edges)}, {"area", c.area}, {"euler", static_cast<double>(c.euler)},
            {"boundary_edges", static_cast<double>(c.boundary_edges)}, {"closed", c.closed ? 1.0 : 0.0},
            {"genus", static_cast<double>(c.genus)}, {"unsupported_fraction", c.unsupported_fraction},
            {"floating", c.floating ? 1.0 : 0.0}};
}

/// The scalar entries of a diagnosis, in print order (L2 pieces also x 100, as pcp_eval's L2-CD x 100).
std::vector<std::pair<std::string, double>> diagnosis_fields(const pcp::Diagnosis& d) {
    return {{"samples", static_cast<double>(d.samples)},
            {"frame_scale", d.frame_scale},
            {"has_input", d.has_input ? 1.0 : 0.0},
            {"spacing", d.spacing},
            {"support_radius", d.support_radius},
            {"near_threshold", d.near_threshold},
            {"pred_components", static_cast<double>(d.pred_components.size())},
            {"gt_components", static_cast<double>(d.gt_components.size())},
            {"pred_area", d.pred_area},
            {"gt_area", d.gt_area},
            {"unsupported_area_fraction", d.unsupported_area_fraction},
            {"floating_components", static_cast<double>(d.floating_components)},
            {"floating_area", d.floating_area},
            {"floating_area_fraction", d.floating_area_fraction},
            {"chamfer_l2_x100", 100 * d.chamfer_l2},
            {"accuracy_l2_x100", 100 * d.accuracy_l2},
            {"accuracy_away_l2_x100", 100 * d.accuracy_away_l2},
            {"accuracy_main_l2_x100", 100 * d.accuracy_main_l2},
            {"away_sample_fraction", d.away_sample_fraction},
            {"offset", d.offset},
            {"roughness", d.roughness},
            {"mean_abs_distance", d.mean_abs_distance},
            {"offset_signed_by_closed_gt", d.offset_signed_by_closed_gt ? 1.0 : 0.0},
            {"completeness_l2_x100", 100 * d.completeness_l2},
            {"completeness_missing_l2_x100", 100 * d.completeness_missing_l2},
            {"completeness_rest_l2_x100", 100 * d.completeness_rest_l2},
            {"missing_area_fraction", d.missing_area_fraction}};
}

void print_diagnosis_json(std::ostream& out, const pcp::Diagnosis& d, const std::string& pred_path, const std::string& gt_path,
                          const std::string& input_path, const std::string& protocol) {
    out.precision(9);
    out << "{\"pred\": \"" << pred_path << "\", \"gt\": \"" << gt_path << "\", \"input\": ";
    if (input_path.empty()) out << "null";
    else out << "\"" << input_path << "\"";
    out << ", \"protocol\": \"" << protocol << "\"";
    for (const auto& [key, value] : diagnosis_fields(d)) out << ", \"" << key << "\": " << value;
    for (const auto& [name, list] : {std::pair<const char*, const std::vector<pcp::ComponentInfo>*>{"pred_component_list", &d.pred_components},
                                     {"gt_component_list", &d.gt_components}}) {
        out << ", \"" << name << "\": [";
        for (std::size_t i = 0; i < list->size(); ++i) {
            out << (i ? ", " : "") << "{";
            bool first = true;
            for (const auto& [key, value] : component_fields((*list)[i])) {
                out << (first ? "" : ", ") << "\"" << key << "\": " << value;
                first = false;
            }
            out << "}";
        }
        out << "]";
    }
    out << "}" << std::endl;
}

/// Key/value lines: the scalars, then "pred_component.I.FIELD" / "gt_component.I.FIELD" (I by decreasing area).
void print_diagnosis_tsv(std::ostream& out, const pcp::Diagnosis& d, const std::string& protocol) {
    out.precision(9);
    out << "protocol\t" << protocol << "\n";
    for (const auto& [key, value] : diagnosis_fields(d)) out << key << "\t" << value << "\n";
    for (const auto& [name, list] : {std::pair<const char*, const std::vector<pcp::ComponentInfo>*>{"pred_component", &d.pred_components},
                                     {"gt_component", &d.gt_components}})
        for (std::size_t i = 0; i < list->size(); ++i)
            for (const auto& [key, value] : component_fields((*list)[i])) out << name << "." << i << "." << key << "\t" << value << "\n";
    out << std::flush;
}

std::string percent(double fraction) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.2f %%", 100 * fraction);
    return buf;
}

void print_components(std::ostream& out, const std::vector<pcp::ComponentInfo>& list, double total_area, bool has_input,
                      std::size_t max_rows) {
    out << "| # | faces | area | area % | V-E+F | boundary edges | genus |" << (has_input ? " unsupported % | floating |" : "")
        << "\n|---|---|---|---|---|---|---|" << (has_input ? "---|---|" : "") << "\n";
    for (std::size_t i = 0; i < list.size() && i < max_rows; ++i) {
        const pcp::ComponentInfo& c = list[i];
        char buf[256];
        std::snprintf(buf, sizeof buf, "| %zu | %lld | %.6g | %s | %lld | %lld | %s |", i, static_cast<long long>(c.faces), c.area,
                      percent(total_area > 0 ? c.area / total_area : 0).c_str(), static_cast<long long>(c.euler),
                      static_cast<long long>(c.boundary_edges), c.closed ? std::to_string(c.genus).c_str() : "- (open)");
        out << buf;
        if (has_input) out << " " << percent(c.unsupported_fraction) << " | " << (c.floating ? "yes" : "no") << " |";
        out << "\n";
    }
    if (list.size() > max_rows) {
        double rest = 0;
        for (std::size_t i = max_rows; i < list.size(); ++i) rest += list[i].area;
        out << "| ... " << list.size() - max_rows << " more, area " << rest << " (" << percent(total_area > 0 ? rest / total_area : 0)
            << ") |\n";
    }
}

void print_diagnosis_table(std::ostream& out, const pcp::Diagnosis& d, const std::string& pred_path, const std::string& gt_path,
                           const std::string& input_path, const std::string& protocol, std::uint64_t seed) {
    out << "pcp_eval --diagnose: " << pred_path << " vs " << gt_path << " (protocol " << protocol << ", " << d.samples
        << " samples, seed " << seed << "; lengths in the evaluation frame, x " << d.frame_scale << " of the files')\n";
    if (d.has_input)
        out << "input " << input_path << ": spacing " << d.spacing << " (median nearest-neighbour distance); support radius "
            << d.support_radius << ", near threshold " << d.near_threshold << "\n";
    else
        out << "no --input: nothing counts as unsupported; spacing " << d.spacing << " (of the GT samples), near threshold "
            << d.near_threshold << "\n";
    auto row = [&](const char* name, double l2, const std::string& note) {
        char buf[200];
        std::snprintf(buf, sizeof buf, "| %-30s | %12.6g | %7s | %s |", name, 100 * l2,
                      percent(d.chamfer_l2 > 0 ? l2 / d.chamfer_l2 : 0).c_str(), note.c_str());
        out << buf << "\n";
    };
    out << "\n| L2-CD budget                   |   L2-CD x100 |   share | note |\n|---|---|---|---|\n";
    row("total (= pcp_eval's L2-CD)", d.chamfer_l2, "");
    row("accuracy (pred -> GT)", d.accuracy_l2, "");
    row("  away from the data", d.accuracy_away_l2, percent(d.away_sample_fraction) + " of pred area (unsupported or floating)");
    row("  main surface", d.accuracy_main_l2, "");
    row("completeness (GT -> pred)", d.completeness_l2, "");
    row("  missing surface", d.completeness_missing_l2, percent(d.missing_area_fraction) + " of GT area");
    row("  rest", d.completeness_rest_l2, "");
    char buf[256];
    std::snprintf(buf, sizeof buf, "\nmain surface vs GT: offset %+.4g (+ = outside; sign by %s), roughness %.4g, mean |d| %.4g\n",
                  d.offset, d.offset_signed_by_closed_gt ? "the closed GT" : "the GT's face normals", d.roughness, d.mean_abs_distance);
    out << buf;
    out << "\npred: " << d.pred_components.size() << " components, area " << d.pred_area;
    if (d.has_input)
        out << "; unsupported area " << percent(d.unsupported_area_fraction) << "; " << d.floating_components
            << " floating, area " << d.floating_area << " (" << percent(d.floating_area_fraction) << ")";
    out << "\n";
    print_components(out, d.pred_components, d.pred_area, d.has_input, 8);
    out << "\ngt: " << d.gt_components.size() << " components, area " << d.gt_area << "\n";
    print_components(out, d.gt_components, d.gt_area, false, 4);
}

}  // namespace

int main(int argc, char** argv) {
    return pcp::cli::run_main("pcp_eval", [&] {
        const pcp::EvalOptions defaults;
        cxxopts::Options options("pcp_eval", "Compare a reconstructed mesh PRED with ground truth GT (mesh, or points with normals).");
        options.positional_help("PRED GT  (PRED: a mesh; with --normals a point cloud with normals)");
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
            ("diagnose", "Print the error budget instead of the metrics: PRED's connected components (area, genus), "
             "its area away from --input, and L2-CD split into accuracy away from the data / on the main surface "
             "(with its offset and roughness) and completeness on missing surface / the rest; needs a GT mesh")
            ("input", "With --diagnose: the input cloud PRED was made from (same frame as GT)", cxxopts::value<std::string>()->default_value(""))
            ("support-k", "With --diagnose: a PRED sample is supported when an input point is within this many spacings "
             "(median nearest-neighbour distance of the input)", cxxopts::value<double>()->default_value(join_thresholds({pcp::DiagnoseOptions{}.support_k})))
            ("near-k", "With --diagnose: GT surface farther than this many spacings from PRED is missing",
             cxxopts::value<double>()->default_value(join_thresholds({pcp::DiagnoseOptions{}.near_k})))
            ("normals", "PRED is a point cloud with oriented normals (nx ny nz; e.g. pcp_reconstruct --normals): report how "
             "many point to the outside of the GT mesh and their angles to the nearest GT face's normal")
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
        const bool diagnose = args.count("diagnose") > 0;
        const std::string input_path = args["input"].as<std::string>();
        if (!diagnose && (!input_path.empty() || args["support-k"].count() || args["near-k"].count()))
            throw pcp::cli::UsageError("--input, --support-k and --near-k need --diagnose");
        if (diagnose && (args.count("gt-points") || !args["sdf-samples"].as<std::string>().empty()))
            throw pcp::cli::UsageError("--diagnose needs a GT mesh and excludes --gt-points and --sdf-samples");
        if (diagnose && !(args["support-k"].as<double>() > 0 && args["near-k"].as<double>() > 0))
            throw pcp::cli::UsageError("--support-k and --near-k must be > 0");
        if (args.count("normals")) {
            if (diagnose || args.count("gt-points") || !args["sdf-samples"].as<std::string>().empty())
                throw pcp::cli::UsageError("--normals excludes --diagnose, --gt-points and --sdf-samples");
            const pcp::PointCloud oriented = pcp::cli::load_checked_cloud(pred_path, 1);
            for (const char* name : {"nx", "ny", "nz"})
                PCP_CHECK(oriented.properties.count(name), pred_path << ": --normals needs points with normals (properties nx, ny, nz)");
            pcp::Points normals(oriented.points.rows(), 3);
            normals << oriented.properties.at("nx"), oriented.properties.at("ny"), oriented.properties.at("nz");
            const pcp::Mesh gt_mesh = pcp::read_mesh(gt_path);
            PCP_CHECK(gt_mesh.faces.rows() > 0, gt_path << ": --normals needs a ground-truth mesh with faces");
            pcp::NormalOrientation n;
            try {
                n = pcp::normal_orientation(oriented.points, normals, gt_mesh);
            } catch (const pcp::Error& e) {
                PCP_FAIL(pred_path << ": " << e.what());
            }
            const std::vector<std::pair<std::string, double>> fields = {
                {"points", static_cast<double>(n.points)}, {"correct_side", n.correct_side}, {"mean_angle_deg", n.mean_angle_deg},
                {"median_angle_deg", n.median_angle_deg}, {"mean_unoriented_deg", n.mean_unoriented_deg}};
            std::cout.precision(9);
            if (args.count("json")) {
                std::cout << "{\"pred\": \"" << pred_path << "\", \"gt\": \"" << gt_path << "\"";
                for (const auto& [key, value] : fields) std::cout << ", \"" << key << "\": " << value;
                std::cout << "}" << std::endl;
            } else if (args.count("tsv")) {
                for (const auto& [key, value] : fields) std::cout << key << "\t" << value << "\n";
                std::cout << std::flush;
            } else {
                std::cout << "pcp_eval --normals: " << pred_path << " vs " << gt_path << "\n| metric | value |\n|---|---|\n";
                for (const auto& [key, value] : fields) std::cout << "| " << key << " | " << value << " |\n";
                std::cout << std::flush;
            }
            return 0;
        }
        const pcp::Mesh pred = pcp::read_mesh(pred_path);
        PCP_CHECK(pred.faces.rows() > 0, pred_path << ": the predicted mesh has no faces");
        const GroundTruth gt = read_ground_truth(gt_path, args.count("gt-points") > 0);
        if (diagnose) {
            PCP_CHECK(gt.is_mesh, gt_path << ": --diagnose needs a ground-truth mesh (.ply .obj .off with faces)");
            pcp::Points input_points(0, 3);
            if (!input_path.empty()) input_points = pcp::cli::load_checked_cloud(input_path, 2).points;
            pcp::DiagnoseOptions dopts;
            dopts.protocol = opts.protocol;
            dopts.samples = opts.samples;
            dopts.seed = opts.seed;
            dopts.support_k = args["support-k"].as<double>();
            dopts.near_k = args["near-k"].as<double>();
            const Eigen::Ref<const pcp::Points> input_ref(input_points);
            const pcp::Diagnosis d = pcp::diagnose(pred, gt.mesh, input_path.empty() ? nullptr : &input_ref, dopts);
            const std::string protocol = pcp::to_string(opts.protocol);
            if (args.count("json")) print_diagnosis_json(std::cout, d, pred_path, gt_path, input_path, protocol);
            else if (args.count("tsv")) print_diagnosis_tsv(std::cout, d, protocol);
            else print_diagnosis_table(std::cout, d, pred_path, gt_path, input_path, protocol, opts.seed);
            return 0;
        }
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
        // The DeepLS table's unit (scene protocol: metres in, millimetres out).
        if (gt.is_mesh && opts.protocol == pcp::EvalProtocol::Scene) row("scene error (mm)", 1000.0 * r.scene_error, 0.0);
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
