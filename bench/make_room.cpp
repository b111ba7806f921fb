// pcp_make_room -o DIR [--points N] [--noise M] [--seed S] (DIR is created if missing): the generated room of
// pcp/cloud/room.hpp -- its scan as DIR/room.ply and its exact visible surfaces as DIR/room_gt.ply
// (metres, y up) -- for the scene benchmarks (docs/BENCHMARKS.md, "Scenes"). A tool, not part of
// the library.
#include "pcp/cloud/room.hpp"
#include "pcp/core/error.hpp"
#include "pcp/io/io.hpp"

#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <string>

int main(int argc, char** argv) {
    try {
        pcp::RoomOptions o;
        std::string dir;
        for (int i = 1; i < argc; ++i) {
            const std::string a = argv[i];
            const auto value = [&]() -> std::string {
                if (i + 1 >= argc) throw pcp::Error(a + " needs a value");
                return argv[++i];
            };
            if (a == "-o") dir = value();
            else if (a == "--points") o.points = std::stol(value());
            else if (a == "--noise") o.noise = std::stod(value());
            else if (a == "--seed") o.seed = std::stoull(value());
            else {
                std::cerr << "usage: pcp_make_room -o DIR [--points N] [--noise METRES] [--seed S]\n";
                return 2;
            }
        }
        if (dir.empty()) {
            std::cerr << "usage: pcp_make_room -o DIR [--points N] [--noise METRES] [--seed S]\n";
            return 2;
        }
        std::error_code ec;
        std::filesystem::create_directories(dir, ec);
        if (ec || !std::filesystem::is_directory(dir)) throw pcp::Error(dir + ": cannot create the output directory");
        const pcp::Room room = pcp::make_room(o);
        pcp::write_point_cloud(dir + "/room.ply", room.cloud);
        pcp::write_mesh(dir + "/room_gt.ply", room.ground_truth);
        std::cout << "pcp_make_room: " << room.cloud.points.rows() << " points -> " << dir << "/room.ply, "
                  << room.ground_truth.faces.rows() << " ground-truth faces -> " << dir << "/room_gt.ply\n";
        return 0;
    } catch (const std::exception& e) {
        std::cerr << "pcp_make_room: error: " << e.what() << "\n";
        return 1;
    }
}
