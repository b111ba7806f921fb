// Grid split into local regions and per-region normalisation (centre / scale / both / none).
#include "pcp/cloud/regions.hpp"

#include "pcp/core/error.hpp"

#include <algorithm>
#include <map>

namespace pcp {

RegionNormalization parse_region_normalization(const std::string& name) {
    if (name == "none") return RegionNormalization::None;
    if (name == "center" || name == "centre") return RegionNormalization::Center;
    if (name == "scale") return RegionNormalization::Scale;
    if (name == "both") return RegionNormalization::Both;
    PCP_FAIL("unknown region normalisation '" << name << "' (use none, center, scale or both)");
}

std::string to_string(RegionNormalization normalization) {
    switch (normalization) {
        case RegionNormalization::None: return "none";
        case RegionNormalization::Center: return "center";
        case RegionNormalization::Scale: return "scale";
        case RegionNormalization::Both: return "both";
    }
    return "?";
}

PointsF Region::to_region(const Eigen::Ref<const PointsF>& unit) const {
    return (unit.rowwise() - center.transpose()) / scale;
}

PointsF Region::from_region(const Eigen::Ref<const PointsF>& local) const {
    return (local * scale).rowwise() + center.transpose();
}

std::vector<Region> split_into_regions(const Eigen::Ref<const PointsF>& unit_points,
                                       const RegionOptions& options) {
    PCP_CHECK(options.grid >= 1 && options.grid <= 64,
              "regions: grid must be in [1, 64], got " << options.grid);
    PCP_CHECK(options.min_points >= 1, "regions: min_points must be >= 1");
    const Eigen::Index n = unit_points.rows();
    PCP_CHECK(n > 0, "regions: no points");
    const Eigen::Vector3f lo = unit_points.colwise().minCoeff().transpose();
    const Eigen::Vector3f extent = unit_points.colwise().maxCoeff().transpose() - lo;
    const int g = options.grid;

    // Cell of each point, then bucket the point ids by cell.
    std::vector<int> cell_of(static_cast<std::size_t>(n));
    for (Eigen::Index i = 0; i < n; ++i) {
        int id = 0;
        for (int c = 2; c >= 0; --c) {
            int k = 0;
            if (extent(c) > 0.0f)
                k = static_cast<int>(std::floor((unit_points(i, c) - lo(c)) / extent(c) * static_cast<float>(g)));
            id = id * g + std::clamp(k, 0, g - 1);
        }
        cell_of[static_cast<std::size_t>(i)] = id;
    }
    std::map<int, std::vector<std::int32_t>> buckets;
    for (Eigen::Index i = 0; i < n; ++i) buckets[cell_of[static_cast<std::size_t>(i)]].push_back(static_cast<std::int32_t>(i));

    std::vector<Region> regions;
    for (const auto& [id, ids] : buckets) {
        if (static_cast<Eigen::Index>(ids.size()) < options.min_points) continue;
        Region r;
        r.cell = Eigen::Vector3i(id % g, (id / g) % g, id / (g * g));
        r.point_ids = Eigen::Map<const IndexVector>(ids.data(), static_cast<Eigen::Index>(ids.size()));
        Eigen::Vector3f bmin = Eigen::Vector3f::Constant(std::numeric_limits<float>::max());
        Eigen::Vector3f bmax = -bmin;
        for (std::int32_t pid : ids) {
            bmin = bmin.cwiseMin(unit_points.row(pid).transpose());
            bmax = bmax.cwiseMax(unit_points.row(pid).transpose());
        }
        const bool centre = options.normalization == RegionNormalization::Center ||
                            options.normalization == RegionNormalization::Both;
        const bool scale = options.normalization == RegionNormalization::Scale ||
                           options.normalization == RegionNormalization::Both;
        r.center = centre ? Eigen::Vector3f(0.5f * (bmin + bmax)) : Eigen::Vector3f::Zero();
        const float longest = (bmax - bmin).maxCoeff();
        r.scale = (scale && longest > 0.0f) ? longest : 1.0f;
        regions.push_back(std::move(r));
    }
    return regions;
}

PointsF region_points(const Eigen::Ref<const PointsF>& unit_points, const Region& region) {
    PointsF local(region.point_ids.size(), 3);
    for (Eigen::Index i = 0; i < region.point_ids.size(); ++i)
        local.row(i) = (unit_points.row(region.point_ids(i)) - region.center.transpose()) / region.scale;
    return local;
}

}  // namespace pcp
