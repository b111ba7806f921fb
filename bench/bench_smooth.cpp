// bench_smooth MESH OUT bilateral NORMAL_ITER VERTEX_ITER SIGMA_R SPATIAL
// Applies the bilateral smoothing of pcp/mesh/surface/smooth.hpp to a mesh file (for measuring settings on
// stored benchmark meshes without fitting the networks again).
#include "pcp/core/error.hpp"
#include "pcp/io/io.hpp"
#include "pcp/mesh/surface/smooth.hpp"

#include <cstdlib>
#include <iostream>
#include <string>

int main(int argc, char** argv) {
    try {
        if (argc < 5) {
            std::cerr << "usage: bench_smooth MESH OUT bilateral NORMAL_ITER VERTEX_ITER SIGMA_R SPATIAL\n";
            return 2;
        }
        const pcp::Mesh mesh = pcp::read_mesh(argv[1]);
        const std::string method = argv[3];
        pcp::Mesh out;
        if (method == "bilateral" && argc >= 8) {
            pcp::BilateralOptions o;
            o.normal_iterations = std::atoi(argv[4]);
            o.vertex_iterations = std::atoi(argv[5]);
            o.sigma_r = std::atof(argv[6]);
            o.spatial = std::atof(argv[7]);
            out = pcp::bilateral_smooth(mesh, o);
        } else {
            std::cerr << "bench_smooth: unknown method or missing arguments\n";
            return 2;
        }
        pcp::write_mesh(argv[2], out);
        return 0;
    } catch (const std::exception& e) {
        std::cerr << "bench_smooth: error: " << e.what() << "\n";
        return 1;
    }
}
