// PreparedCloud (see pcp/cloud/prepared_cloud.hpp).
#include "pcp/cloud/prepared_cloud.hpp"

#include "pcp/core/hash.hpp"

#include <utility>

namespace pcp {
namespace {
Normalization checked_unit_box(const Eigen::Ref<const Points>& points, const std::string& name, Eigen::Index min_points) {
    check_point_cloud(points, name, min_points);
    return fit_unit_box(points);
}
}  // namespace

PreparedCloud::PreparedCloud(const Eigen::Ref<const Points>& points, std::string name, Eigen::Index min_points)
    : name_(std::move(name)), norm_(checked_unit_box(points, name_, min_points)), tree_(norm_.to_unit(points)) {
    const auto bytes = static_cast<std::size_t>(points.size()) * sizeof(double);
    if (points.outerStride() == 3) {
        input_hash_ = fnv1a64(points.data(), bytes);
    } else {  // a strided view: hash the coordinates in row order
        const Points dense = points;
        input_hash_ = fnv1a64(dense.data(), bytes);
    }
}

}  // namespace pcp
