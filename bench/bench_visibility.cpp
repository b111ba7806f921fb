// bench_visibility INPUT INSIDE.ply OUTSIDE.ply [RESOLUTION MIN_DISTANCE [SDF_SAMPLES]]
// The visibility labels (pcp/cloud/visibility.hpp) of a cloud: the centres of the cells labelled
// inside and outside, written as clouds in the input's frame (to render beside the ground truth).
// With SDF_SAMPLES (a cloud with an "sdf" property; the ABC files are positive inside, whatever their README
// says: docs/NOTEBOOK.md, "Sign agreement"), also
// prints how many samples in labelled cells have the label's sign.
#include "pcp/cloud/prepared_cloud.hpp"
#include "pcp/cloud/visibility.hpp"
#include "pcp/core/error.hpp"
#include "pcp/io/io.hpp"

#include <cstdlib>
#include <iostream>
#include <string>

int main(int argc, char** argv) {
    try {
        if (argc < 4) {
            std::cerr << "usage: bench_visibility INPUT INSIDE.ply OUTSIDE.ply [RESOLUTION MIN_DISTANCE [SDF_SAMPLES]]\n";
            return 2;
        }
        const pcp::PointCloud input = pcp::read_point_cloud(argv[1]);
        const pcp::PreparedCloud cloud(input.points, argv[1], 2);
        pcp::VisibilityOptions o;
        if (argc >= 6) {
            o.resolution = std::atoi(argv[4]);
            o.min_distance = std::atof(argv[5]);
        }
        pcp::Aabb box;
        box.min = cloud.unit().colwise().minCoeff().transpose().cast<double>().array() - 0.05;
        box.max = cloud.unit().colwise().maxCoeff().transpose().cast<double>().array() + 0.05;
        const pcp::VisibilityLabels labels = pcp::label_by_visibility(cloud.tree(), box, o);
        for (int side : {-1, 1}) {
            const std::vector<std::int32_t>& cells = side < 0 ? labels.inside_cells : labels.outside_cells;
            pcp::Points unit(static_cast<Eigen::Index>(cells.size()), 3);
            const std::int64_t dx = labels.dims.x(), dxy = dx * labels.dims.y();
            for (std::size_t i = 0; i < cells.size(); ++i) {
                const std::int64_t c = cells[i];
                unit.row(static_cast<Eigen::Index>(i)) =
                    labels.center(int(c % dx), int((c / dx) % labels.dims.y()), int(c / dxy)).transpose();
            }
            pcp::PointCloud out;
            out.points = cloud.normalization().from_unit(unit);
            pcp::write_point_cloud(argv[side < 0 ? 2 : 3], out);
        }
        std::cout << "cells: " << labels.stats.inside << " inside, " << labels.stats.outside << " outside, "
                  << labels.stats.unknown << " unknown, " << labels.stats.near << " near the data; radius "
                  << labels.stats.radius << "; " << labels.stats.seconds << " s\n";
        if (argc >= 7) {
            const pcp::PointCloud samples = pcp::read_point_cloud(argv[6]);
            PCP_CHECK(samples.properties.count("sdf"), argv[6] << ": no sdf property");
            const Eigen::VectorXd& sdf = samples.properties.at("sdf");
            const pcp::Points unit = cloud.normalization().to_unit_double(samples.points);
            std::int64_t agree[2] = {0, 0}, total[2] = {0, 0};
            for (Eigen::Index i = 0; i < unit.rows(); ++i) {
                const int l = labels.label_at(unit.row(i).transpose());
                if (l == 0 || sdf(i) == 0) continue;
                const int k = l < 0 ? 0 : 1;
                ++total[k];
                if ((sdf(i) > 0) == (l < 0)) ++agree[k];
            }
            std::cout << "sdf samples in inside cells: " << agree[0] << " of " << total[0] << " inside; in outside cells: "
                      << agree[1] << " of " << total[1] << " outside\n";
        }
        return 0;
    } catch (const std::exception& e) {
        std::cerr << "bench_visibility: " << e.what() << "\n";
        return 1;
    }
}
