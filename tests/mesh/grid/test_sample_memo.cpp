// Tests for the pipeline's sample memo (src/mesh/grid/sample_memo.hpp): a coarse grid's values at its
// samples, reused by a grid twice as fine at the samples the two share, give the fine grid every
// value it gets on its own; a point is matched only when it is exactly a sample.
#include "mesh/grid/sample_memo.hpp"
#include "pcp/mesh/grid/sdf_grid.hpp"

#include <catch2/catch.hpp>

#include <atomic>
#include <cmath>
#include <limits>

namespace {

pcp::GridSpec spec_of(int resolution) {
    pcp::GridSpec s;
    s.resolution = resolution;
    s.box.min = Eigen::Vector3d(-0.61, -0.43, -0.52);
    s.box.max = Eigen::Vector3d(0.57, 0.49, 0.55);  // not cubic, not round
    return s;
}

// A field with detail at every scale (the far-cell interpolation leaves some samples unevaluated),
// counting its calls.
struct CountingField {
    std::atomic<std::int64_t> points{0};
    pcp::SdfBatchFn fn() {
        return [this](const Eigen::Ref<const pcp::PointsF>& q, Eigen::Ref<Eigen::VectorXf> v) {
            points += q.rows();
            for (Eigen::Index r = 0; r < q.rows(); ++r) {
                const Eigen::Vector3f p = q.row(r).transpose();
                v(r) = p.norm() - 0.35f + 0.03f * std::sin(17.0f * p.x()) * std::cos(11.0f * p.y() + 3.0f * p.z());
            }
        };
    }
};

pcp::SdfGridOptions dense() {
    pcp::SdfGridOptions o;
    o.band = pcp::NarrowBand::Dense;
    o.far_factor = 2.0;  // the pipeline's settings
    o.far_levels = 3;
    o.batch_size = 97;  // batches mix shared and unshared samples
    return o;
}

}  // namespace

TEST_CASE("sample memo: a grid twice as fine takes the coarse grid's values and gets the grid it gets alone", "[mesh]") {
    const pcp::GridSpec coarse = spec_of(24), fine = spec_of(48);
    CountingField plain_field, memo_field;
    const pcp::SdfGrid alone = pcp::evaluate_sdf_grid(plain_field.fn(), fine, dense());

    pcp::detail::SampleMemo memo(coarse);
    const pcp::SdfGrid coarse_grid = pcp::evaluate_sdf_grid(memo.recording(memo_field.fn()), coarse, dense());
    const std::int64_t coarse_points = memo_field.points.load();
    REQUIRE(coarse_points == coarse_grid.stats.evaluations);
    const pcp::SdfGrid reused = pcp::evaluate_sdf_grid(memo.reusing(memo_field.fn()), fine, dense());
    const std::int64_t fine_points = memo_field.points.load() - coarse_points;

    // Every fine sample the same, bit for bit, evaluated or interpolated.
    REQUIRE(reused.stats.evaluations == alone.stats.evaluations);
    std::int64_t differ = 0;
    for (int k = 0; k <= fine.resolution; ++k)
        for (int j = 0; j <= fine.resolution; ++j)
            for (int i = 0; i <= fine.resolution; ++i) {
                const float a = alone.value(i, j, k), b = reused.value(i, j, k);
                if (!(a == b || (std::isnan(a) && std::isnan(b)))) ++differ;
            }
    CHECK(differ == 0);
    // The shared samples were not evaluated again: at most one per coarse evaluation, and many.
    CHECK(memo.reused() > alone.stats.evaluations / 10);
    CHECK(memo.reused() <= coarse_points);
    CHECK(fine_points == alone.stats.evaluations - memo.reused());
}

TEST_CASE("sample memo: only a point that is exactly a lattice sample is matched", "[mesh]") {
    const pcp::GridSpec s = spec_of(16);
    const pcp::detail::SampleMemo memo(s);
    const int n1 = s.resolution + 1;
    for (const Eigen::Vector3i& g : {Eigen::Vector3i(0, 0, 0), Eigen::Vector3i(16, 16, 16), Eigen::Vector3i(3, 9, 14)}) {
        const Eigen::Vector3f p = s.sample_position(g.x(), g.y(), g.z()).cast<float>();
        CHECK(memo.index_of(p) == (std::int64_t(g.z()) * n1 + g.y()) * n1 + g.x());
        Eigen::Vector3f off = p;
        off.y() = std::nextafter(off.y(), 1.0f);  // one float away
        CHECK(memo.index_of(off) == -1);
    }
    CHECK(memo.index_of(Eigen::Vector3f(0.0f, 0.0f, 0.0f)) == -1);  // inside a cell
    CHECK(memo.index_of(Eigen::Vector3f(5.0f, 0.0f, 0.0f)) == -1);  // outside the box
    CHECK(memo.index_of(Eigen::Vector3f(std::numeric_limits<float>::quiet_NaN(), 0.0f, 0.0f)) == -1);
    // A sample of a grid twice as fine at an even index is the coarse sample; at an odd one it is none.
    const pcp::GridSpec fine = spec_of(32);
    CHECK(memo.index_of(fine.sample_position(6, 18, 28).cast<float>()) == (std::int64_t(14) * n1 + 9) * n1 + 3);
    CHECK(memo.index_of(fine.sample_position(7, 18, 28).cast<float>()) == -1);
}
