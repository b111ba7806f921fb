// pcp_orient_open3d: the normal orientation a user gets from Open3D, for comparison with
// `pcp_reconstruct --normals` (bench/run_normals.sh); not part of the library. Normals by PCA on
// the NEIGHBOURS nearest points, oriented by orient_normals_consistent_tangent_plane(ORIENT_K) as in
// pcp_poisson_open3d. That orientation is consistent up to one global sign, which it does not choose;
// the output is what Open3D returns.
//
// usage: pcp_orient_open3d INPUT OUTPUT.ply [NEIGHBOURS=30] [ORIENT_K=15]
#include "pcp/core/error.hpp"
#include "pcp/io/io.hpp"

#include "open3d_normals.hpp"


#include <chrono>
#include <iostream>
#include <string>

int main(int argc, char** argv) {
    if (argc < 3 || argc > 5) {
        std::cerr << "usage: pcp_orient_open3d INPUT OUTPUT.ply [NEIGHBOURS=30] [ORIENT_K=15]\n";
        return 2;
    }
    const std::string input = argv[1], output = argv[2];
    try {
        const int k = argc > 3 ? std::stoi(argv[3]) : 30;
        const int orient_k = argc > 4 ? std::stoi(argv[4]) : 15;
        if (k < 3 || orient_k < 3) {
            std::cerr << "pcp_orient_open3d: error: NEIGHBOURS and ORIENT_K must be >= 3\n";
            return 2;
        }
        PCP_CHECK(output != input, output << ": the output would overwrite the input");
        const auto t0 = std::chrono::steady_clock::now();
        const pcp::PointCloud cloud = pcp::read_point_cloud(input);
        const open3d::geometry::PointCloud pc = pcp_bench::open3d_oriented_cloud(cloud.points, k, orient_k, input);
        pcp::PointCloud out;
        out.points = cloud.points;
        for (int c = 0; c < 3; ++c) {
            Eigen::VectorXd v(cloud.points.rows());
            for (Eigen::Index i = 0; i < v.size(); ++i) v(i) = pc.normals_[static_cast<std::size_t>(i)](c);
            out.properties[c == 0 ? "nx" : c == 1 ? "ny" : "nz"] = v;
        }
        pcp::write_point_cloud(output, out);
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        std::cerr << "pcp_orient_open3d: " << input << ": " << cloud.points.rows() << " points oriented in " << seconds << " s\n";
        return 0;
    } catch (const std::exception& e) {
        std::cerr << "pcp_orient_open3d: error: " << e.what() << "\n";
        return 1;
    }
}
