// pcp_render INPUT... -o OUT.png: draws meshes and point clouds side by side (one column per input,
// one row per view, one shared camera frame) with the library's software rasteriser
// (pcp/render/render.hpp) and writes a PNG. Back faces are orange, points are coloured by depth.
#include "cli_common.hpp"

#include "pcp/core/error.hpp"
#include "pcp/core/files.hpp"
#include "pcp/io/io.hpp"
#include "pcp/render/render.hpp"

#include <cctype>
#include <cmath>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

namespace {

std::vector<std::string> split(const std::string& text, char sep) {
    std::vector<std::string> parts;
    std::stringstream in(text);
    std::string item;
    while (std::getline(in, item, sep)) parts.push_back(item);
    if (!text.empty() && text.back() == sep) parts.emplace_back();
    return parts;
}

double parse_angle(const std::string& text, const std::string& item) {
    try {
        std::size_t used = 0;
        const double v = std::stod(text, &used);
        if (used == text.size() && std::isfinite(v)) return v;
    } catch (const std::exception&) {
    }
    throw pcp::cli::UsageError("--views: '" + item + "' is not a view name, a count or AZIMUTH:ELEVATION in degrees");
}

/// --views: a count of the default views (1-3), or a comma list of names and AZ:EL pairs.
std::vector<pcp::View> parse_views(const std::string& text) {
    const std::vector<pcp::View> defaults = pcp::default_views();
    if (text.size() == 1 && text[0] >= '1' && text[0] <= '3')
        return {defaults.begin(), defaults.begin() + (text[0] - '0')};
    std::vector<pcp::View> views;
    for (const std::string& item : split(text, ',')) {
        if (item == "front") views.push_back({0, 0});
        else if (item == "quarter") views.push_back({45, 30});
        else if (item == "side") views.push_back({90, 0});
        else if (item == "back") views.push_back({180, 0});
        else if (item == "top") views.push_back({0, 90});
        else if (item == "bottom") views.push_back({0, -90});
        else {
            const std::size_t colon = item.find(':');
            if (colon == std::string::npos)
                throw pcp::cli::UsageError("--views: '" + item + "' is not a view name (front, quarter, side, back, top, bottom), "
                                           "a count 1-3 or AZIMUTH:ELEVATION in degrees");
            views.push_back({parse_angle(item.substr(0, colon), item), parse_angle(item.substr(colon + 1), item)});
        }
    }
    if (views.empty() || views.size() > 16) throw pcp::cli::UsageError("--views: need 1 to 16 views");
    return views;
}

/// True when a .ply file's header declares a non-empty face element (a mesh, not a cloud). An
/// unreadable file returns false, and the cloud reader then names the problem.
bool ply_has_faces(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::string line;
    for (int n = 0; n < 1000 && std::getline(in, line); ++n) {
        if (!line.empty() && line.back() == '\r') line.pop_back();
        if (line == "end_header") break;
        std::istringstream words(line);
        std::string keyword, name;
        long long count = 0;
        if (words >> keyword >> name >> count && keyword == "element" && name == "face") return count > 0;
    }
    return false;
}

/// Reads one input as a mesh or a cloud; errors name the file.
pcp::RenderItem read_input(const std::string& path) {
    const std::string ext = pcp::file_extension(path);
    pcp::RenderItem item;
    std::error_code ec;
    PCP_CHECK(std::filesystem::exists(path, ec), path << ": no such file");
    const bool mesh = ext == ".obj" || ext == ".off" || (ext == ".ply" && ply_has_faces(path));
    if (mesh) {
        item.mesh = pcp::read_mesh(path);
        // A mesh file without faces (vertices only) is drawn as its points.
        if (item.mesh.faces.rows() == 0) {
            item.points = item.mesh.vertices;
            item.mesh = pcp::Mesh{};
        }
    } else {
        item.points = pcp::read_point_cloud(path).points;
    }
    PCP_CHECK(item.mesh.faces.rows() > 0 || item.points.rows() > 0, path << ": nothing to draw (no faces and no points)");
    return item;
}

/// The default label of an input: its file name without the extension, lower case.
std::string default_label(const std::string& path) {
    std::string stem = std::filesystem::path(path).stem().string();
    for (char& c : stem) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return stem;
}

}  // namespace

int main(int argc, char** argv) {
    return pcp::cli::run_main("pcp_render", [&] {
        const pcp::RenderOptions defaults;
        cxxopts::Options options("pcp_render",
                                 "Draw meshes (.ply with faces, .obj, .off) and point clouds (.ply, .xyz, .txt, .pts, .npy) side "
                                 "by side into one PNG: one column per input, one row per view, one shared camera frame. "
                                 "Faces are shaded by their normal; back faces (normal away from the camera) are orange; "
                                 "points are coloured by depth (dark = near).");
        options.positional_help("INPUT... -o OUT.png");
        options.add_options()
            ("inputs", "Meshes and point clouds, one column each", cxxopts::value<std::vector<std::string>>())
            ("o,output", "Output picture (.png); never one of the inputs", cxxopts::value<std::string>()->default_value(""))
            ("size", "Pixels per panel side, in [16, 4096]", cxxopts::value<int>()->default_value(std::to_string(defaults.view_size)))
            ("views", "A count of the fixed views 1-3 (front, quarter = 45 deg around and 30 deg above, side), or a comma list "
                      "of front, quarter, side, back, top, bottom and AZIMUTH:ELEVATION in degrees (world up = +y)",
             cxxopts::value<std::string>()->default_value("3"))
            ("labels", "Comma-separated column labels, one per input (default: the file names without extension)",
             cxxopts::value<std::string>()->default_value(""))
            ("point-size", "Point splat side in pixels, in [1, 16]",
             cxxopts::value<int>()->default_value(std::to_string(defaults.point_size)))
            ("no-back-faces", "Shade back faces like front faces")
            ("section", "Cut away what lies nearer to the camera than a plane at this depth from the scene's centre, as a "
                        "fraction of its half-diagonal in [-1, 1] (0: through the centre), to show inner sheets",
             cxxopts::value<double>())
            ("no-labels", "Draw no labels in the picture");
        options.parse_positional({"inputs"});
        pcp::cli::add_common_options(options);
        cxxopts::ParseResult args;
        pcp::cli::CommonFlags common;
        if (!pcp::cli::parse_command_line(options, argc, argv, args, common)) return 0;
        const pcp::cli::Log log{&common};
        if (!args.count("inputs")) throw pcp::cli::UsageError("need at least one INPUT");
        const std::vector<std::string> inputs = args["inputs"].as<std::vector<std::string>>();
        if (inputs.size() > 64) throw pcp::cli::UsageError("at most 64 inputs fit in one picture");
        const std::string output = args["output"].as<std::string>();
        if (output.empty()) throw pcp::cli::UsageError("need -o OUT.png");
        if (pcp::file_extension(output) != ".png") throw pcp::cli::UsageError("-o must name a .png file (got '" + output + "')");

        pcp::RenderOptions opts;
        opts.view_size = args["size"].as<int>();
        if (opts.view_size < 16 || opts.view_size > 4096) throw pcp::cli::UsageError("--size must be in [16, 4096]");
        opts.point_size = args["point-size"].as<int>();
        if (opts.point_size < 1 || opts.point_size > 16) throw pcp::cli::UsageError("--point-size must be in [1, 16]");
        opts.views = parse_views(args["views"].as<std::string>());
        opts.back_faces_distinct = !args.count("no-back-faces");
        if (args.count("section")) {
            opts.section = args["section"].as<double>();
            if (!(opts.section >= -1 && opts.section <= 1)) throw pcp::cli::UsageError("--section must be in [-1, 1]");
        }
        opts.labels = !args.count("no-labels");
        std::vector<std::string> labels;
        const std::string label_text = args["labels"].as<std::string>();
        if (!label_text.empty()) {
            labels = split(label_text, ',');
            if (labels.size() != inputs.size())
                throw pcp::cli::UsageError("--labels has " + std::to_string(labels.size()) + " labels for " +
                                           std::to_string(inputs.size()) + " inputs");
        } else {
            for (const std::string& in : inputs) labels.push_back(default_label(in));
        }

        // Before any work: the output must be writable and must not be one of the inputs.
        pcp::check_output_path(output, inputs);

        const auto start = std::chrono::steady_clock::now();
        std::vector<pcp::RenderItem> items;
        for (std::size_t i = 0; i < inputs.size(); ++i) {
            items.push_back(read_input(inputs[i]));
            items.back().label = labels[i];
        }
        const double read_seconds = pcp::cli::seconds_since(start);
        const auto render_start = std::chrono::steady_clock::now();
        const pcp::Image image = pcp::render(items, opts);
        const double render_seconds = pcp::cli::seconds_since(render_start);
        pcp::write_png(output, image);

        std::cout << "pcp_render: wrote " << output << " (" << image.width << " x " << image.height << ", " << items.size()
                  << " column(s) x " << opts.views.size() << " view(s))\n";
        for (std::size_t i = 0; i < items.size(); ++i) {
            std::cout << "  column " << i + 1 << ": " << labels[i] << " = " << inputs[i] << " (";
            if (items[i].mesh.faces.rows() > 0) std::cout << items[i].mesh.faces.rows() << " faces";
            else std::cout << items[i].points.rows() << " points";
            std::cout << ")\n";
        }
        for (std::size_t v = 0; v < opts.views.size(); ++v)
            std::cout << "  row " << v + 1 << ": azimuth " << opts.views[v].azimuth_deg << ", elevation "
                      << opts.views[v].elevation_deg << "\n";
        char timing[128];
        std::snprintf(timing, sizeof timing, "pcp_render: read %.2f s, render %.3f s", read_seconds, render_seconds);
        log.info(timing);
        return 0;
    });
}
