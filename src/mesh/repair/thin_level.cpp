// The thin level (see include/pcp/mesh/repair/thin_level.hpp).
#include "pcp/mesh/repair/thin_level.hpp"

#include "mesh/grid/grid_samples.hpp"
#include "pcp/core/error.hpp"
#include "pcp/mesh/sign/field_normals.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace pcp {

ThinLevel::ThinLevel(const KdTree& cloud, float offset, float near_radius) : cloud_(cloud), offset_(offset), near_(near_radius) {
    PCP_CHECK(std::isfinite(offset) && offset >= 0, "thin level: offset must be >= 0, got " << offset);
    PCP_CHECK(std::isfinite(near_radius) && near_radius >= 0, "thin level: near_radius must be >= 0, got " << near_radius);
}

float ThinLevel::level_at(const Eigen::Vector3f& p, const std::vector<float>* levels) const {
    if (offset_ <= 0) return 0.0f;
    float d = 0;
    const std::int32_t k = cloud_.nearest_point(p, &d);
    const float at = levels && !levels->empty() ? (*levels)[static_cast<std::size_t>(k)] : offset_;
    if (d <= near_) return at;
    return d >= 2 * near_ ? 0.0f : at * (2.0f - d / near_);
}

float ThinLevel::operator()(const Eigen::Vector3f& p) const { return level_at(p, &levels_); }

bool ThinLevel::raised_at(const Eigen::Vector3f& p) const {
    if (near_raised_.empty()) return false;
    return near_raised_[static_cast<std::size_t>(cloud_.nearest_point(p))] != 0;
}

void ThinLevel::shift_samples(SdfGrid& grid, float reach, const std::vector<float>& levels) const {
    // The samples near the zero set, shifted by the change of the level at their position (every
    // stored copy of a sample alike: the shift depends on the position only).
    // Only the lattice points within the level's reach (twice near_radius) of a raised point can
    // change: those are marked first, point by point, so that a few raised points cost little.
    const PointsF& pts = cloud_.points();
    const Eigen::Index n = pts.rows();
    const float band = 2 * reach;
    const int n1 = grid.spec.resolution + 1;
    std::vector<bool> touched(static_cast<std::size_t>(std::int64_t(n1) * n1 * n1), false);
    const Eigen::Vector3d cell = grid.spec.spacing();
    const double radius = 2.0 * near_;
    for (Eigen::Index i = 0; i < n; ++i) {
        if (!(levels[static_cast<std::size_t>(i)] > offset_)) continue;
        const Eigen::Vector3d p = pts.row(i).transpose().cast<double>();
        int lo[3], hi[3];
        for (int a = 0; a < 3; ++a) {
            lo[a] = std::max(0, static_cast<int>(std::floor((p(a) - radius - grid.spec.box.min(a)) / cell(a))));
            hi[a] = std::min(n1 - 1, static_cast<int>(std::ceil((p(a) + radius - grid.spec.box.min(a)) / cell(a))));
        }
        for (int z = lo[2]; z <= hi[2]; ++z)
            for (int y = lo[1]; y <= hi[1]; ++y)
                for (int x = lo[0]; x <= hi[0]; ++x) touched[static_cast<std::size_t>((std::int64_t(z) * n1 + y) * n1 + x)] = true;
    }
    detail::for_each_stored_sample(grid, [&](float& v, std::int64_t g) {
        if (!touched[static_cast<std::size_t>(g)] || std::abs(v) > band) return;
        const Eigen::Vector3f q = grid.spec.sample_position(g % n1, (g / n1) % n1, g / (std::int64_t(n1) * n1)).cast<float>();
        v -= level_at(q, &levels) - level_at(q, nullptr);
    });
}

void ThinLevel::shift_like_raise(SdfGrid& grid) const {
    if (levels_.empty()) return;
    shift_samples(grid, reach_, levels_);
}

std::int64_t ThinLevel::raise_where_thin(SdfGrid& grid, float reach, int min_company, double min_share) {
    PCP_CHECK(std::isfinite(reach) && reach > 0, "thin level: reach must be > 0, got " << reach);
    PCP_CHECK(min_company >= 1 && min_company <= 8, "thin level: min_company must be in [1, 8], got " << min_company);
    PCP_CHECK(min_share >= 0 && min_share <= 1, "thin level: min_share must be in [0, 1], got " << min_share);
    if (offset_ <= 0) return 0;
    const Eigen::Index n = cloud_.size();
    const PointsF& pts = cloud_.points();
    const PointsF normals = pca_normals(cloud_, static_cast<int>(std::clamp<Eigen::Index>(n, 3, 16)));
    std::vector<float> own(static_cast<std::size_t>(n), offset_);
    std::int64_t raised = 0;
#pragma omp parallel for schedule(static) reduction(+ : raised)
    for (Eigen::Index i = 0; i < n; ++i) {
        const Eigen::Vector3f p = pts.row(i).transpose(), d = reach * normals.row(i).transpose();
        const float at = detail::stored_at(grid, p.cast<double>()), up = detail::stored_at(grid, (p + d).cast<double>()), down = detail::stored_at(grid, (p - d).cast<double>());
        // The point outside the extracted solid but not far out (the mesh would miss it), in a
        // valley of the field along its normal (larger on both sides: a sheet the level does not
        // reach, not the outer fringe of a noise band, where the field falls inward). NaN anywhere:
        // a sample not stored, far from the zero set.
        if (!(at >= 0 && at < reach) || !(up > at) || !(down > at)) continue;
        own[static_cast<std::size_t>(i)] = std::min(offset_ + std::max(up, down), std::max(offset_, reach));
        ++raised;
    }
    if (raised == 0) return 0;
    const int k = static_cast<int>(std::min<Eigen::Index>(8, n));
    NeighborIndices idx;
    NeighborDistances dist;
    cloud_.knn(pts, k, idx, dist);
    // A sheet's points come in patches; a point raised with fewer than min_company of its k nearest
    // (itself included) raised is a noisy scan's artefact, not a sheet.
    {
        std::vector<float> kept = own;
        std::int64_t left = 0;
        for (Eigen::Index i = 0; i < n; ++i) {
            if (own[static_cast<std::size_t>(i)] <= offset_) continue;
            int c = 0;
            for (int j = 0; j < k; ++j) c += own[static_cast<std::size_t>(idx(i, j))] > offset_;
            if (c < min_company) kept[static_cast<std::size_t>(i)] = offset_;
            else ++left;
        }
        own.swap(kept);
        raised = left;
        // Sheets sampled as one layer are a sizeable part of a surface; a few patches on a solid are
        // the field's, and raising them adds handles (the built-in shape: 16 points, genus 1 -> 4).
        if (raised == 0 || static_cast<double>(raised) < min_share * static_cast<double>(n)) return 0;
    }
    // Spread to the neighbours (the largest among its k nearest: the sheet's points that the solid
    // holds between its holes come out at the holes' level), then averaged over them.
    std::vector<float> spread(static_cast<std::size_t>(n)), levels(static_cast<std::size_t>(n));
    for (Eigen::Index i = 0; i < n; ++i) {
        float m = 0;
        for (int j = 0; j < k; ++j) m = std::max(m, own[static_cast<std::size_t>(idx(i, j))]);
        spread[static_cast<std::size_t>(i)] = m;
    }
    for (Eigen::Index i = 0; i < n; ++i) {
        double sum = 0;
        for (int j = 0; j < k; ++j) sum += spread[static_cast<std::size_t>(idx(i, j))];
        levels[static_cast<std::size_t>(i)] = std::max(offset_, static_cast<float>(sum / k));
    }
    shift_samples(grid, reach, levels);
    // The points whose level rose, and their neighbours (raised_at).
    near_raised_.assign(static_cast<std::size_t>(n), 0);
    for (Eigen::Index i = 0; i < n; ++i)
        if (levels[static_cast<std::size_t>(i)] > offset_)
            for (int j = 0; j < k; ++j) near_raised_[static_cast<std::size_t>(idx(i, j))] = 1;
    levels_ = std::move(levels);
    reach_ = reach;
    return raised;
}

}  // namespace pcp
