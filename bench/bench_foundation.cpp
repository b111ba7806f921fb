// bench_foundation [CLOUD] [THREADS]: times the point-cloud core on a real scan (default: the 95k-point
// gargoyle): KD-tree build, the 50-NN of every point, and drawing 1,000,000 queries with their
// nearest-point targets. Prints a Markdown table row per stage; median of 5 repetitions.
#include "pcp/io/io.hpp"
#include "pcp/cloud/kdtree.hpp"
#include "pcp/cloud/normalize.hpp"
#include "pcp/cloud/sampling.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include <omp.h>

namespace {
template <class F>
double median_seconds(F&& f, int reps = 5) {
    std::vector<double> t;
    for (int r = 0; r < reps; ++r) {
        const auto t0 = std::chrono::steady_clock::now();
        f();
        t.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    std::sort(t.begin(), t.end());
    return t[t.size() / 2];
}
}  // namespace

int main(int argc, char** argv) {
    const std::string path = argc > 1 ? argv[1] : std::string(PCP_DATA_DIR) + "/scans/gargoyle.ply";
    if (argc > 2) omp_set_num_threads(std::stoi(argv[2]));
    const pcp::PointCloud cloud = pcp::read_point_cloud(path);
    const pcp::PointsF unit = pcp::fit_unit_box(cloud.points).to_unit(cloud.points);
    const Eigen::Index n = unit.rows();
    pcp::SamplingOptions opts;
    opts.queries_per_point = static_cast<int>((1000000 + n - 1) / n);  // >= 1,000,000 queries in all

    double checksum = 0;
    const double t_build = median_seconds([&] { checksum += static_cast<double>(pcp::KdTree(unit).size()); });
    const pcp::KdTree tree(unit);
    pcp::NeighborIndices idx;
    pcp::NeighborDistances dist;
    const double t_knn = median_seconds([&] {
        tree.knn(unit, 51, idx, dist);  // the point itself + its 50 neighbours
        checksum += dist(0, 50);
    });
    Eigen::Index m = 0;
    const double t_sample = median_seconds([&] {
        const pcp::QuerySet q = pcp::sample_queries(tree, opts, 1);
        m = q.queries.rows();
        checksum += q.targets(0, 0);
    });
    std::printf("input: %s (%ld points), threads: %d, queries: %ld\n", path.c_str(), static_cast<long>(n),
                omp_get_max_threads(), static_cast<long>(m));
    std::printf("| stage | median s (5 runs) |\n|---|---|\n");
    std::printf("| KD-tree build | %.4f |\n| 50-NN of every point | %.4f |\n| sample %ld queries + targets (incl. sigma) | %.4f |\n",
                t_build, t_knn, static_cast<long>(m), t_sample);
    std::printf("| total | %.4f |\n", t_build + t_knn + t_sample);
    std::fprintf(stderr, "(checksum %g)\n", checksum);
    return 0;
}
