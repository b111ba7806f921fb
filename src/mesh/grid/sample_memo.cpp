// See sample_memo.hpp.
#include "mesh/grid/sample_memo.hpp"

#include "pcp/core/error.hpp"

#include <cmath>
#include <limits>
#include <vector>

namespace pcp::detail {

SampleMemo::SampleMemo(const GridSpec& lattice) : spec_(lattice), n1_(std::int64_t(lattice.resolution) + 1) {
    PCP_CHECK(lattice.resolution >= 1 && lattice.resolution <= 1024, "sample memo: resolution " << lattice.resolution << " must be in 1..1024");
    const auto n = static_cast<std::size_t>(n1_ * n1_ * n1_);
    values_ = std::make_unique<std::atomic<float>[]>(n);
    for (std::size_t i = 0; i < n; ++i) values_[i].store(std::numeric_limits<float>::quiet_NaN(), std::memory_order_relaxed);
}

std::int64_t SampleMemo::index_of(const Eigen::Vector3f& p) const {
    const Eigen::Vector3d extent = spec_.box.extent();
    std::int64_t g[3];
    for (int c = 0; c < 3; ++c) {
        if (!(extent(c) > 0.0)) return -1;
        const double u = (double(p(c)) - spec_.box.min(c)) / extent(c) * spec_.resolution;
        if (!(u > -0.5 && u < spec_.resolution + 0.5)) return -1;  // also NaN
        g[c] = std::llround(u);
    }
    if (spec_.sample_position(g[0], g[1], g[2]).cast<float>() != p) return -1;
    return (g[2] * n1_ + g[1]) * n1_ + g[0];
}

SdfBatchFn SampleMemo::recording(const SdfBatchFn& field) {
    return [this, field](const Eigen::Ref<const PointsF>& q, Eigen::Ref<Eigen::VectorXf> v) {
        field(q, v);
        for (Eigen::Index r = 0; r < q.rows(); ++r) {
            const std::int64_t n = index_of(q.row(r).transpose());
            if (n >= 0) values_[static_cast<std::size_t>(n)].store(v(r), std::memory_order_relaxed);
        }
    };
}

SdfBatchFn SampleMemo::reusing(const SdfBatchFn& field) {
    return [this, field](const Eigen::Ref<const PointsF>& q, Eigen::Ref<Eigen::VectorXf> v) {
        std::vector<Eigen::Index> missing;
        missing.reserve(static_cast<std::size_t>(q.rows()));
        for (Eigen::Index r = 0; r < q.rows(); ++r) {
            const std::int64_t n = index_of(q.row(r).transpose());
            const float known = n >= 0 ? values_[static_cast<std::size_t>(n)].load(std::memory_order_relaxed)
                                       : std::numeric_limits<float>::quiet_NaN();
            if (std::isnan(known))
                missing.push_back(r);
            else
                v(r) = known;
        }
        reused_.fetch_add(q.rows() - static_cast<std::int64_t>(missing.size()), std::memory_order_relaxed);
        if (missing.empty()) return;
        if (static_cast<Eigen::Index>(missing.size()) == q.rows()) {
            field(q, v);
            return;
        }
        PointsF rest(static_cast<Eigen::Index>(missing.size()), 3);
        for (std::size_t i = 0; i < missing.size(); ++i) rest.row(static_cast<Eigen::Index>(i)) = q.row(missing[i]);
        Eigen::VectorXf values(rest.rows());
        field(rest, values);
        for (std::size_t i = 0; i < missing.size(); ++i) v(missing[i]) = values(static_cast<Eigen::Index>(i));
    };
}

}  // namespace pcp::detail
