// Benchmark of the SDF grid machinery and marching cubes (include/pcp/mesh/grid/sdf_grid.hpp,
// include/pcp/mesh/grid/marching_cubes.hpp): wall time of evaluation and extraction, SDF evaluations
// against (R+1)^3, stored blocks and peak memory, for resolutions 128, 256, 512 and each band
// mode, on cost-free analytic SDFs (a sphere and a torus) so that the grid machinery itself is
// measured. Each configuration runs in a forked child so that its peak RSS is its own.
// Prints a Markdown table for docs/BENCHMARKS.md. Usage: bench_mc [max_resolution (default 512)]
#include "pcp/mesh/grid/marching_cubes.hpp"
#include "pcp/mesh/grid/sdf_grid.hpp"

#include <omp.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>

namespace {

constexpr double kPi = 3.14159265358979323846;

// Shapes in the unit box [-0.5, 0.5]^3; the grid adds the 0.05 margin of METHOD.md §5.
struct Shape {
    const char* name;
    float (*sdf)(float, float, float);
    void (*surface_point)(std::mt19937&, float*);
};

float sphere(float x, float y, float z) { return std::sqrt(x * x + y * y + z * z) - 0.4f; }
void sphere_point(std::mt19937& rng, float* p) {
    std::normal_distribution<float> g;
    float v[3] = {g(rng), g(rng), g(rng)};
    const float n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    for (int a = 0; a < 3; ++a) p[a] = 0.4f * v[a] / n;
}
float torus(float x, float y, float z) { return std::hypot(std::hypot(x, y) - 0.3f, z) - 0.12f; }
void torus_point(std::mt19937& rng, float* p) {
    std::uniform_real_distribution<float> u(0.0f, float(2.0 * kPi));
    const float a = u(rng), b = u(rng);
    p[0] = (0.3f + 0.12f * std::cos(b)) * std::cos(a);
    p[1] = (0.3f + 0.12f * std::cos(b)) * std::sin(a);
    p[2] = 0.12f * std::sin(b);
}

const Shape kShapes[] = {{"sphere", sphere, sphere_point}, {"torus", torus, torus_point}};

const char* band_name(pcp::NarrowBand b) {
    return b == pcp::NarrowBand::Dense ? "dense" : b == pcp::NarrowBand::Coarse ? "coarse" : "near-points";
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void run_one(const Shape& shape, int resolution, pcp::NarrowBand band) {
    pcp::Aabb unit;
    unit.min = Eigen::Vector3d::Constant(-0.5);
    unit.max = Eigen::Vector3d::Constant(0.5);
    const pcp::GridSpec spec = pcp::make_grid_spec(unit, resolution, 0.05);
    const auto sdf_fn = shape.sdf;
    const pcp::SdfBatchFn sdf = [sdf_fn](const Eigen::Ref<const pcp::PointsF>& p, Eigen::Ref<Eigen::VectorXf> v) {
        for (Eigen::Index i = 0; i < p.rows(); ++i) v[i] = sdf_fn(p(i, 0), p(i, 1), p(i, 2));
    };
    pcp::PointsF points(200000, 3);  // band points for NearPoints: a cloud on the surface
    std::mt19937 rng(7);
    for (Eigen::Index i = 0; i < points.rows(); ++i) shape.surface_point(rng, points.row(i).data());

    pcp::SdfGridOptions opts;
    opts.band = band;
    const auto t0 = std::chrono::steady_clock::now();
    const pcp::SdfGrid grid = pcp::evaluate_sdf_grid(sdf, spec, opts, points);
    const double t_eval = seconds_since(t0);
    const auto t1 = std::chrono::steady_clock::now();
    const pcp::Mesh mesh = pcp::marching_cubes(grid);
    const double t_mc = seconds_since(t1);

    rusage ru{};
    getrusage(RUSAGE_SELF, &ru);
    const double samples = std::pow(double(resolution + 1), 3);
    std::printf("| %s | %d | %s | %.3f | %.3f | %.1f M | %.3f | %d | %.0f | %.0f | %.2f M | %.2f M |\n", shape.name,
                resolution, band_name(band), t_eval, t_mc, grid.stats.evaluations / 1e6,
                grid.stats.evaluations / samples, grid.num_blocks(), grid.values.size() * 4.0 / (1 << 20),
                ru.ru_maxrss / 1024.0, mesh.vertices.rows() / 1e6, mesh.faces.rows() / 1e6);
    std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
    const int max_resolution = argc > 1 ? std::atoi(argv[1]) : 512;
    std::printf("threads: %d (OMP_NUM_THREADS or all cores); block_cells 8, coarse_factor 2, "
                "point_band_cells 3, grow on; SDF cost-free (analytic, float)\n\n",
                omp_get_max_threads());
    std::printf("| shape | R | band | eval s | MC s | SDF evals | evals / (R+1)^3 | blocks | stored MiB | "
                "peak RSS MiB | vertices | faces |\n");
    std::printf("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n");
    std::fflush(stdout);
    for (const Shape& shape : kShapes) {
        for (int resolution : {128, 256, 512}) {
            if (resolution > max_resolution) continue;
            for (pcp::NarrowBand band : {pcp::NarrowBand::Dense, pcp::NarrowBand::Coarse, pcp::NarrowBand::NearPoints}) {
                if (band == pcp::NarrowBand::Dense && resolution > 256) continue;  // ~0.8 GB of samples
                const pid_t pid = fork();
                if (pid == 0) {
                    try {
                        run_one(shape, resolution, band);
                    } catch (const std::exception& e) {
                        std::fprintf(stderr, "bench_mc: error: %s\n", e.what());
                        _exit(1);
                    }
                    _exit(0);
                }
                int status = 0;
                waitpid(pid, &status, 0);
                if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) return 1;
            }
        }
    }
    return 0;
}
