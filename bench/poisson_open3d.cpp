// pcp_poisson_open3d: the strongest baseline a user would run from an unoriented cloud, for
// side-by-side benchmarks; not part of the library. Open3D's screened Poisson, configured as its
// users do: normals by PCA on the 30 nearest neighbours, oriented by
// orient_normals_consistent_tangent_plane(15), Poisson at the given octree depth, then the
// vertices whose density is below the 1 % quantile removed (the usual trim of the surface Poisson
// invents far from the data). Writes the mesh in the input's frame.
//
// usage: pcp_poisson_open3d INPUT OUTPUT [DEPTH=9] [NEIGHBOURS=30] [ORIENT_K=15] [TRIM_QUANTILE=0.01]
#include "pcp/core/error.hpp"
#include "pcp/io/io.hpp"

#include "open3d_normals.hpp"

#include <open3d/geometry/TriangleMesh.h>

#include <algorithm>
#include <chrono>
#include <iostream>
#include <string>
#include <vector>

int main(int argc, char** argv) {
    if (argc < 3 || argc > 7) {
        std::cerr << "usage: pcp_poisson_open3d INPUT OUTPUT [DEPTH=9] [NEIGHBOURS=30] [ORIENT_K=15] [TRIM_QUANTILE=0.01]\n";
        return 2;
    }
    const std::string input = argv[1], output = argv[2];
    try {
        const int depth = argc > 3 ? std::stoi(argv[3]) : 9;
        const int k = argc > 4 ? std::stoi(argv[4]) : 30;
        const int orient_k = argc > 5 ? std::stoi(argv[5]) : 15;
        const double trim = argc > 6 ? std::stod(argv[6]) : 0.01;
        if (depth < 1 || depth > 14 || k < 3 || orient_k < 3 || !(trim >= 0 && trim < 1)) {
            std::cerr << "pcp_poisson_open3d: error: DEPTH in 1..14, NEIGHBOURS and ORIENT_K >= 3, TRIM_QUANTILE in [0, 1)\n";
            return 2;
        }
        PCP_CHECK(output != input, output << ": the output would overwrite the input");
        const auto t0 = std::chrono::steady_clock::now();
        const pcp::PointCloud cloud = pcp::read_point_cloud(input);
        const open3d::geometry::PointCloud pc = pcp_bench::open3d_oriented_cloud(cloud.points, k, orient_k, input);
        auto [mesh, density] = open3d::geometry::TriangleMesh::CreateFromPointCloudPoisson(pc, static_cast<std::size_t>(depth));
        PCP_CHECK(mesh && !mesh->triangles_.empty(), input << ": Open3D's Poisson reconstruction produced no surface");
        if (trim > 0 && !density.empty()) {
            std::vector<double> sorted = density;
            const std::size_t at = static_cast<std::size_t>(trim * static_cast<double>(sorted.size() - 1));
            std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(at), sorted.end());
            const double cut = sorted[at];
            std::vector<bool> remove(density.size());
            for (std::size_t i = 0; i < density.size(); ++i) remove[i] = density[i] < cut;
            mesh->RemoveVerticesByMask(remove);
        }
        pcp::Mesh out;
        out.vertices.resize(static_cast<Eigen::Index>(mesh->vertices_.size()), 3);
        for (std::size_t i = 0; i < mesh->vertices_.size(); ++i) out.vertices.row(static_cast<Eigen::Index>(i)) = mesh->vertices_[i].transpose();
        out.faces.resize(static_cast<Eigen::Index>(mesh->triangles_.size()), 3);
        for (std::size_t i = 0; i < mesh->triangles_.size(); ++i) out.faces.row(static_cast<Eigen::Index>(i)) = mesh->triangles_[i].transpose();
        PCP_CHECK(out.faces.rows() > 0, input << ": nothing left after the density trim");
        pcp::write_mesh(output, out);
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        std::cerr << "pcp_poisson_open3d: " << input << ": " << cloud.points.rows() << " points, depth " << depth << " -> "
                  << out.vertices.rows() << " vertices, " << out.faces.rows() << " faces in " << seconds << " s\n";
        return 0;
    } catch (const std::exception& e) {
        std::cerr << "pcp_poisson_open3d: error: " << e.what() << "\n";
        return 1;
    }
}
