// pcp_poisson_baseline: what a user would run instead of PCP, for side-by-side benchmarks. Not part
// of the library. Reads an unoriented point cloud, estimates normals by jet fitting, orients them
// with a minimum spanning tree (CGAL's mst_orient_normals), and runs CGAL's Poisson surface
// reconstruction (Kazhdan et al. 2006; CGAL 5.5 has no screened variant). Writes the mesh in the
// input's frame.
#include "pcp/core/error.hpp"
#include "pcp/io/io.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/compute_average_spacing.h>
#include <CGAL/jet_estimate_normals.h>
#include <CGAL/mst_orient_normals.h>
#include <CGAL/poisson_surface_reconstruction.h>
#include <CGAL/property_map.h>

#include <chrono>
#include <iostream>
#include <string>
#include <utility>
#include <vector>

namespace {
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using Vector = Kernel::Vector_3;
using PointWithNormal = std::pair<Point, Vector>;
using SurfaceMesh = CGAL::Surface_mesh<Point>;
}  // namespace

int main(int argc, char** argv) {
    if (argc < 3) {
        std::cerr << "usage: pcp_poisson_baseline INPUT OUTPUT [NEIGHBOURS=18]\n";
        return 2;
    }
    const std::string input = argv[1], output = argv[2];
    const int k = argc > 3 ? std::stoi(argv[3]) : 18;
    try {
        const auto t0 = std::chrono::steady_clock::now();
        const pcp::PointCloud cloud = pcp::read_point_cloud(input);
        std::vector<PointWithNormal> points;
        points.reserve(static_cast<std::size_t>(cloud.points.rows()));
        for (Eigen::Index i = 0; i < cloud.points.rows(); ++i)
            points.emplace_back(Point(cloud.points(i, 0), cloud.points(i, 1), cloud.points(i, 2)), Vector(0, 0, 0));
        const auto params = CGAL::parameters::point_map(CGAL::First_of_pair_property_map<PointWithNormal>())
                                .normal_map(CGAL::Second_of_pair_property_map<PointWithNormal>());
        CGAL::jet_estimate_normals<CGAL::Parallel_if_available_tag>(points, k, params);
        const auto unoriented = CGAL::mst_orient_normals(points, k, params);
        points.erase(unoriented, points.end());
        const double spacing = CGAL::compute_average_spacing<CGAL::Parallel_if_available_tag>(
            points, 6, CGAL::parameters::point_map(CGAL::First_of_pair_property_map<PointWithNormal>()));
        SurfaceMesh mesh;
        const bool ok = CGAL::poisson_surface_reconstruction_delaunay(
            points.begin(), points.end(), CGAL::First_of_pair_property_map<PointWithNormal>(),
            CGAL::Second_of_pair_property_map<PointWithNormal>(), mesh, spacing);
        PCP_CHECK(ok && mesh.number_of_faces() > 0, input << ": CGAL Poisson reconstruction failed");
        pcp::Mesh out;
        out.vertices.resize(static_cast<Eigen::Index>(mesh.number_of_vertices()), 3);
        std::vector<std::int32_t> index(mesh.num_vertices() + mesh.number_of_removed_vertices(), -1);
        Eigen::Index nv = 0;
        for (auto v : mesh.vertices()) {
            const Point& p = mesh.point(v);
            out.vertices.row(nv) << p.x(), p.y(), p.z();
            index[static_cast<std::size_t>(v.idx())] = static_cast<std::int32_t>(nv++);
        }
        std::vector<Eigen::RowVector3i> faces;
        for (auto f : mesh.faces()) {
            std::vector<std::int32_t> ids;
            for (auto v : CGAL::vertices_around_face(mesh.halfedge(f), mesh)) ids.push_back(index[static_cast<std::size_t>(v.idx())]);
            for (std::size_t j = 1; j + 1 < ids.size(); ++j) faces.emplace_back(ids[0], ids[j], ids[j + 1]);
        }
        out.faces.resize(static_cast<Eigen::Index>(faces.size()), 3);
        for (std::size_t i = 0; i < faces.size(); ++i) out.faces.row(static_cast<Eigen::Index>(i)) = faces[i];
        pcp::write_mesh(output, out);
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        std::cerr << "pcp_poisson_baseline: " << input << ": " << cloud.points.rows() << " points ("
                  << cloud.points.rows() - static_cast<Eigen::Index>(points.size()) << " left unoriented and dropped) -> "
                  << out.vertices.rows() << " vertices, " << out.faces.rows() << " faces in " << seconds << " s\n";
        return 0;
    } catch (const std::exception& e) {
        std::cerr << "pcp_poisson_baseline: error: " << e.what() << "\n";
        return 1;
    }
}
