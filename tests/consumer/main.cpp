// Uses the installed libpcp through its public headers only (no nanoflann or CGAL on the include
// path of this project): builds a KD-tree, samples queries, writes and reads a cloud, renders it
// and encodes the picture as PNG (libpng, a private dependency, must reach the link line).
#include <pcp/pcp.hpp>

#include <cstdio>
#include <iostream>

int main() {
    try {
        const pcp::PointCloud cloud = pcp::sample_sphere(500, 1.0, Eigen::Vector3d(10, 0, 0), 1);
        const pcp::Normalization unit = pcp::fit_unit_box(cloud.points);
        const pcp::KdTree tree(unit.to_unit(cloud.points));
        const pcp::QuerySet queries = pcp::sample_queries(tree, pcp::SamplingOptions{}, 1);
        pcp::write_point_cloud("consumer_cloud.ply", cloud);
        const pcp::PointCloud back = pcp::read_point_cloud("consumer_cloud.ply");
        std::remove("consumer_cloud.ply");
        if (back.points != cloud.points || queries.queries.rows() != 500 * 40) return 1;
        pcp::RenderOptions view;
        view.view_size = 32;
        const pcp::Image picture = pcp::render({pcp::RenderItem{{}, cloud.points, "cloud"}}, view);
        if (pcp::encode_png(picture).size() < 60) return 1;
        PCP_CHECK(false, "consumer: expected failure");
    } catch (const pcp::Error& e) {
        std::cout << "libpcp " << PCP_VERSION_STRING << " linked; error channel works: " << e.what() << "\n";
        return 0;
    }
    return 1;
}
