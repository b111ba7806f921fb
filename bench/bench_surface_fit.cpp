// Applies the surface fit (pcp/mesh/surface/surface_fit.hpp) to a mesh already made from a cloud, so that
// its settings can be measured on stored benchmark meshes without refitting the networks.
// Usage: bench_surface_fit MESH CLOUD OUT [ITERATIONS NEIGHBORS(auto|K) BANDWIDTH RELAX DENOISE(auto|0) MIN_SUPPORTED SHRINK(1|0)]
// (NEIGHBORS auto: pcp::reconstruct's rule, NoisyCloudOptions::fit_neighbors for a cloud it denoises.)
#include "pcp/cloud/denoise.hpp"
#include "pcp/cloud/prepared_cloud.hpp"
#include "pcp/core/error.hpp"
#include "pcp/io/io.hpp"
#include "pcp/mesh/surface/surface_fit.hpp"
#include "pcp/reconstruct.hpp"

#include <chrono>
#include <cstdio>
#include <string>

int main(int argc, char** argv) {
    try {
        if (argc < 4) {
            std::fprintf(stderr, "usage: %s MESH CLOUD OUT [ITERATIONS NEIGHBORS BANDWIDTH RELAX DENOISE MIN_SUPPORTED]\n", argv[0]);
            return 2;
        }
        pcp::SurfaceFitOptions o;
        if (argc > 4) o.iterations = std::stoi(argv[4]);
        const bool rule = argc <= 5 || std::string(argv[5]) == "auto";  // the pipeline's: NoisyCloudOptions::fit_neighbors for a denoised cloud
        if (!rule) o.neighbors = std::stoi(argv[5]);
        if (argc > 6) o.bandwidth = std::stod(argv[6]);
        if (argc > 7) o.relax = std::stod(argv[7]);
        const bool denoise = argc > 8 ? std::string(argv[8]) == "auto" : true;
        if (argc > 9) o.min_supported = std::stod(argv[9]);
        if (argc > 10) o.shrink = std::stoi(argv[10]) != 0;
        const pcp::Mesh mesh = pcp::read_mesh(argv[1]);
        pcp::Points points = pcp::read_point_cloud(argv[2]).points;
        if (denoise) {
            pcp::DenoiseOptions d;
            d.automatic = true;
            d.passes = pcp::denoise_passes(points, d);
            d.automatic = false;
            if (d.passes > 0) points = pcp::denoise_points(points, d);
            if (d.passes > 0 && rule) o.neighbors = pcp::NoisyCloudOptions().fit_neighbors;
        }
        const auto t0 = std::chrono::steady_clock::now();
        const pcp::PreparedCloud cloud(points, argv[2], 10);
        pcp::Mesh unit;
        unit.vertices = cloud.normalization().to_unit_double(mesh.vertices);
        unit.faces = mesh.faces;
        pcp::SurfaceFitStats st;
        const pcp::Mesh fitted = pcp::fit_surface_to_points(unit, cloud.tree(), o, &st);
        const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        pcp::write_mesh(argv[3], cloud.normalization().from_unit(fitted));
        std::printf("components %lld removed %lld (faces %lld) supported_vertices %lld mean_shift %.3g scale %.3g time %.2f s\n",
                    static_cast<long long>(st.components), static_cast<long long>(st.removed_components),
                    static_cast<long long>(st.removed_faces), static_cast<long long>(st.supported_vertices), st.mean_shift,
                    st.scale, secs);
        return 0;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "bench_surface_fit: %s\n", e.what());
        return 1;
    }
}
