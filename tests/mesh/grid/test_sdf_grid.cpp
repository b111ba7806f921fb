// Tests for pcp/sdf_grid.hpp: the lattice and stored samples, both narrow-band modes against the
// dense reference (identical meshes), the growth pass, agreement of shared samples when the SDF
// is not bit-reproducible across batches, batching and progress, a dense grid whose far blocks are
// interpolated from their corners (same signs, same mesh), and the errors for bad options.
#include "mc_test_util.hpp"
#include "pcp/core/error.hpp"
#include "pcp/mesh/grid/marching_cubes.hpp"
#include "pcp/mesh/grid/sdf_grid.hpp"

#include <catch2/catch.hpp>

#include <atomic>
#include <cmath>
#include <limits>
#include <mutex>
#include <stdexcept>

using namespace pcp_test;

namespace {

pcp::SdfGridOptions with_band(pcp::NarrowBand band, int block_cells = 8) {
    pcp::SdfGridOptions opts;
    opts.band = band;
    opts.block_cells = block_cells;
    return opts;
}

pcp::PointsF rows_where(const pcp::Points& v, const std::function<bool(const Eigen::Vector3d&)>& keep, int step) {
    std::vector<Eigen::Index> picked;
    for (Eigen::Index i = 0; i < v.rows(); i += step)
        if (keep(v.row(i).transpose())) picked.push_back(i);
    pcp::PointsF out(Eigen::Index(picked.size()), 3);
    for (std::size_t n = 0; n < picked.size(); ++n) out.row(Eigen::Index(n)) = v.row(picked[n]).cast<float>();
    return out;
}

void require_same_mesh(const pcp::Mesh& a, const pcp::Mesh& b) {
    REQUIRE(a.vertices.rows() == b.vertices.rows());
    CHECK(a.vertices == b.vertices);  // ordered by grid edge: identical, not just close
    CHECK(canonical_faces(a.faces) == canonical_faces(b.faces));
}

}  // namespace

TEST_CASE("sdf_grid: the lattice spans the box and make_grid_spec adds the margin", "[sdf_grid]") {
    pcp::Aabb bbox;
    bbox.min = Eigen::Vector3d(-0.5, -0.25, 0.0);
    bbox.max = Eigen::Vector3d(0.5, 0.25, 0.1);
    const pcp::GridSpec spec = pcp::make_grid_spec(bbox, 20);
    CHECK(spec.resolution == 20);
    CHECK(spec.box.min.isApprox(Eigen::Vector3d(-0.55, -0.3, -0.05)));
    CHECK(spec.box.max.isApprox(Eigen::Vector3d(0.55, 0.3, 0.15)));
    CHECK(spec.sample_position(0, 0, 0).isApprox(spec.box.min));
    CHECK(spec.sample_position(20, 20, 20).isApprox(spec.box.max));
    CHECK(spec.spacing().isApprox(Eigen::Vector3d(1.1, 0.6, 0.2) / 20));
}

TEST_CASE("sdf_grid: a dense grid stores every sample once per block, truncated blocks included", "[sdf_grid]") {
    const ScalarSdf f = sphere_sdf({0.05, 0, 0}, 0.3);
    const pcp::GridSpec spec = cube_grid(13);  // blocks of 4: 4 per axis, the last one 1 cell wide
    const pcp::SdfGrid grid = pcp::evaluate_sdf_grid(batch(f), spec, with_band(pcp::NarrowBand::Dense, 4));
    CHECK(grid.blocks_per_axis == 4);
    CHECK(grid.num_blocks() == 64);
    CHECK(grid.stats.evaluations == 14 * 14 * 14);  // every sample exactly once, shared ones included
    CHECK(grid.stats.coarse_evaluations == 0);
    for (int k = 0; k <= 13; ++k)
        for (int j = 0; j <= 13; ++j)
            for (int i = 0; i <= 13; ++i) {
                // The SDF at the float point it sees. Through a PointsF in memory: g++ 12.2 -O2 was
                // seen to drop a register-only double -> float -> double round trip here.
                const Eigen::Vector3d p = spec.sample_position(i, j, k);
                pcp::PointsF one(1, 3);
                one << float(p.x()), float(p.y()), float(p.z());
                Eigen::VectorXf expected(1);
                batch(f)(one, expected);
                CHECK(grid.value(i, j, k) == expected[0]);
            }
    CHECK(std::isnan(grid.value(14, 0, 0)));
    CHECK(grid.find_block(3, 3, 3) >= 0);
    CHECK(grid.find_block(4, 0, 0) == -1);
}

TEST_CASE("sdf_grid: both narrow bands give exactly the dense mesh", "[sdf_grid][heavy]") {
    const std::vector<std::pair<const char*, ScalarSdf>> shapes = {
        {"sphere", sphere_sdf({0.031, -0.017, 0.009}, 0.41)},
        {"torus", torus_sdf({0.02, 0.01, -0.015}, 0.33, 0.13)},
        {"box", box_sdf({0.01, -0.02, 0.015}, {0.3, 0.22, 0.17})},
    };
    for (const auto& [name, f] : shapes) {
        for (int resolution : {37, 64}) {
            INFO(name << " at resolution " << resolution);
            const pcp::GridSpec spec = cube_grid(resolution);
            const pcp::SdfGrid dense = pcp::evaluate_sdf_grid(batch(f), spec, with_band(pcp::NarrowBand::Dense));
            const pcp::Mesh reference = pcp::marching_cubes(dense);
            REQUIRE(reference.faces.rows() > 0);

            const pcp::SdfGrid coarse = pcp::evaluate_sdf_grid(batch(f), spec, with_band(pcp::NarrowBand::Coarse));
            require_same_mesh(pcp::marching_cubes(coarse), reference);
            CHECK(coarse.stats.grown_blocks == 0);  // a true distance needs no growth
            CHECK(coarse.num_blocks() < dense.num_blocks());

            const pcp::PointsF points = rows_where(reference.vertices, [](const Eigen::Vector3d&) { return true; }, 3);
            const pcp::SdfGrid near = pcp::evaluate_sdf_grid(batch(f), spec, with_band(pcp::NarrowBand::NearPoints), points);
            require_same_mesh(pcp::marching_cubes(near), reference);
            CHECK(near.num_blocks() < dense.num_blocks());
            if (resolution == 64) {  // the savings grow with resolution (bench_mc); already visible here
                CHECK(coarse.stats.evaluations < dense.stats.evaluations * 3 / 4);
                CHECK(near.stats.evaluations < dense.stats.evaluations / 2);
            }
        }
    }
}

namespace {
/// A sample of a grid with far cells interpolated (b) against the fully evaluated grid's (a): finite,
/// of the same sign, and where it differs (counted in differ) at least a half-diagonal from zero.
void require_far_value(float a, float b, double half_diagonal, std::int64_t& differ) {
    REQUIRE(std::isfinite(b));
    REQUIRE((a > 0) == (b > 0));
    if (a != b) {
        ++differ;
        REQUIRE(std::abs(b) > half_diagonal);
    }
}
}  // namespace

TEST_CASE("sdf_grid: a dense grid with far cells interpolated keeps every sign and the exact mesh", "[sdf_grid]") {
    // Blocks of 4 at 61 cells (the last block truncated to 1 cell): the far cells are filled from
    // their corners, every other sample is the SDF's own value. One level tests the blocks only;
    // two and three levels also their halves (2 cells) and quarters (1 cell).
    const std::vector<std::pair<const char*, ScalarSdf>> shapes = {
        {"sphere", sphere_sdf({0.031, -0.017, 0.009}, 0.31)},
        {"torus", torus_sdf({0.02, 0.01, -0.015}, 0.33, 0.13)},
    };
    for (const auto& [name, f] : shapes) {
        INFO(name);
        const pcp::GridSpec spec = cube_grid(61);
        const pcp::SdfGrid dense = pcp::evaluate_sdf_grid(batch(f), spec, with_band(pcp::NarrowBand::Dense, 4));
        const pcp::Mesh reference = pcp::marching_cubes(dense);
        std::int64_t previous = dense.stats.evaluations;
        for (int levels = 1; levels <= 3; ++levels) {
            INFO("levels " << levels);
            pcp::SdfGridOptions opts = with_band(pcp::NarrowBand::Dense, 4);
            opts.far_factor = 2.0;
            opts.far_levels = levels;
            const pcp::SdfGrid far = pcp::evaluate_sdf_grid(batch(f), spec, opts);
            CHECK(far.num_blocks() == dense.num_blocks());
            CHECK(far.stats.interpolated_blocks > far.num_blocks() / 3);
            CHECK(far.stats.coarse_evaluations == 17 * 17 * 17);  // the corners of 16 x 16 x 16 blocks
            // The blocks and their halves each save at least a quarter of the evaluations of the
            // level before; 1-cell cells have no samples but their corners, so they save nothing.
            if (levels < 3)
                CHECK(far.stats.evaluations < previous * 3 / 4);
            else
                CHECK(far.stats.evaluations == previous);
            CHECK(far.stats.evaluations + far.stats.interpolated_samples == dense.stats.evaluations);
            previous = far.stats.evaluations;
            // An interpolated sample lies at least (far_factor - 1) half-diagonals of its cell from
            // the zero set; the smallest cell that can be far at this level has 4 / 2^(levels - 1) cells.
            const double half_diagonal = 0.5 * std::sqrt(3.0) * (4 >> (levels - 1)) * spec.spacing().maxCoeff();
            std::int64_t differ = 0;
            for (int k = 0; k <= 61; ++k)
                for (int j = 0; j <= 61; ++j)
                    for (int i = 0; i <= 61; ++i) {
                        require_far_value(dense.value(i, j, k), far.value(i, j, k), half_diagonal, differ);
                    }
            CHECK(differ > 0);
            require_same_mesh(pcp::marching_cubes(far), reference);
        }
    }
    pcp::SdfGridOptions bad = with_band(pcp::NarrowBand::Dense, 4);
    bad.far_factor = -1;
    CHECK_THROWS_AS(pcp::evaluate_sdf_grid(batch(shapes[0].second), cube_grid(8), bad), pcp::Error);
    bad.far_factor = 2;
    bad.far_levels = 4;  // 4 cells cannot be halved three times
    CHECK_THROWS_AS(pcp::evaluate_sdf_grid(batch(shapes[0].second), cube_grid(8), bad), pcp::Error);
    bad.far_levels = 0;
    CHECK_THROWS_AS(pcp::evaluate_sdf_grid(batch(shapes[0].second), cube_grid(8), bad), pcp::Error);
}

TEST_CASE("sdf_grid: a sparse band with far cells interpolated keeps every sign and the exact mesh", "[sdf_grid]") {
    // The coarse and the point band at 92 cells in blocks of 8 (the last one truncated), refined
    // down to 2-cell cells as the pipeline does: the same blocks as without the refinement, every
    // stored sample of the same sign, the interpolated ones far from the zero set, the same mesh,
    // fewer evaluations. The point band of three points leaves most of the torus to the growth
    // pass, whose blocks are refined too.
    const ScalarSdf f = torus_sdf({0.02, 0.01, -0.015}, 0.33, 0.13);
    const pcp::GridSpec spec = cube_grid(92);
    pcp::PointsF band_points(3, 3);
    band_points << 0.46f, 0.01f, -0.015f, 0.2f, 0.01f, 0.1f, 0.02f, 0.34f, 0.1f;
    for (const pcp::NarrowBand band : {pcp::NarrowBand::Coarse, pcp::NarrowBand::NearPoints}) {
        INFO("band " << int(band));
        pcp::SdfGridOptions opts = with_band(band, 8);
        const pcp::SdfGrid reference = band == pcp::NarrowBand::NearPoints ? pcp::evaluate_sdf_grid(batch(f), spec, opts, band_points)
                                                                           : pcp::evaluate_sdf_grid(batch(f), spec, opts);
        opts.far_factor = 2.0;
        opts.far_levels = 3;
        const pcp::SdfGrid far = band == pcp::NarrowBand::NearPoints ? pcp::evaluate_sdf_grid(batch(f), spec, opts, band_points)
                                                                     : pcp::evaluate_sdf_grid(batch(f), spec, opts);
        REQUIRE(far.block_keys == reference.block_keys);
        REQUIRE(far.num_blocks() < (12 * 12 * 12) / 2);  // a band, not the whole grid
        if (band == pcp::NarrowBand::NearPoints) CHECK(far.stats.grown_blocks > far.num_blocks() / 2);
        CHECK(far.stats.interpolated_samples > 0);
        // (measured: 298 k -> 128 k in the coarse band, 137 k -> 109 k in the point band, whose
        // grown blocks all hold the zero set)
        if (band == pcp::NarrowBand::Coarse)
            CHECK(far.stats.evaluations < reference.stats.evaluations / 2);
        else
            CHECK(far.stats.evaluations < reference.stats.evaluations * 9 / 10);
        const double half_diagonal = 0.5 * std::sqrt(3.0) * spec.spacing().maxCoeff();
        std::int64_t differ = 0;
        for (std::size_t n = 0; n < far.values.size(); ++n) {
            const float a = reference.values[n], b = far.values[n];
            // (a truncated block's samples past the grid's end are NaN in both)
            REQUIRE(std::isnan(a) == std::isnan(b));
            if (!std::isnan(a)) require_far_value(a, b, half_diagonal, differ);
        }
        CHECK(differ > 0);
        require_same_mesh(pcp::marching_cubes(far), pcp::marching_cubes(reference));
    }
}

TEST_CASE("sdf_grid: growth follows the surface out of a band that misses part of it", "[sdf_grid]") {
    const ScalarSdf f = torus_sdf({0.02, 0.01, -0.015}, 0.33, 0.13);
    const pcp::GridSpec spec = cube_grid(40);
    const pcp::Mesh reference =
        pcp::marching_cubes(pcp::evaluate_sdf_grid(batch(f), spec, with_band(pcp::NarrowBand::Dense)));

    // Band points on one side of the torus only.
    const pcp::PointsF half = rows_where(reference.vertices, [](const Eigen::Vector3d& p) { return p.x() > 0.2; }, 1);
    REQUIRE(half.rows() > 10);
    pcp::SdfGridOptions opts = with_band(pcp::NarrowBand::NearPoints);
    opts.grow = false;
    const pcp::Mesh cut = pcp::marching_cubes(pcp::evaluate_sdf_grid(batch(f), spec, opts, half));
    CHECK(topology(cut).edges_not_in_two_faces > 0);  // without growth: an open piece
    opts.grow = true;
    const pcp::SdfGrid grown = pcp::evaluate_sdf_grid(batch(f), spec, opts, half);
    CHECK(grown.stats.grown_blocks > 0);
    CHECK(grown.stats.growth_rounds > 1);
    require_same_mesh(pcp::marching_cubes(grown), reference);

    // Coarse band with a far too small safety factor: growth restores the surface.
    pcp::SdfGridOptions thin = with_band(pcp::NarrowBand::Coarse);
    thin.coarse_factor = 0.5;
    thin.grow = false;
    CHECK(topology(pcp::marching_cubes(pcp::evaluate_sdf_grid(batch(f), spec, thin))).edges_not_in_two_faces > 0);
    thin.grow = true;
    require_same_mesh(pcp::marching_cubes(pcp::evaluate_sdf_grid(batch(f), spec, thin)), reference);
}

TEST_CASE("sdf_grid: shared samples agree when the SDF is not bit-reproducible across batches", "[sdf_grid]") {
    // The SDF adds an offset that depends on the batch it is evaluated in (as a GEMM's rounding
    // may): neighbouring blocks in different batches see different values for a shared sample.
    const ScalarSdf f = sphere_sdf({0.031, -0.017, 0.009}, 0.41);
    pcp::SdfBatchFn noisy = [f](const Eigen::Ref<const pcp::PointsF>& p, Eigen::Ref<Eigen::VectorXf> v) {
        const float offset = 2e-3f * (std::sin(1e3f * (p(0, 0) + 3.0f * p(0, 1) + 7.0f * p(0, 2))));
        for (Eigen::Index n = 0; n < p.rows(); ++n) v[n] = float(f(p.row(n).transpose().cast<double>())) + offset;
    };
    for (int resolution : {32, 45}) {
        pcp::SdfGridOptions opts = with_band(pcp::NarrowBand::Coarse, 4);
        opts.batch_size = 1;  // one block per batch
        const pcp::Mesh mesh = pcp::marching_cubes(pcp::evaluate_sdf_grid(noisy, cube_grid(resolution), opts));
        const MeshTopology t = topology(mesh);
        INFO("resolution " << resolution);
        CHECK(t.closed_manifold_oriented());
        CHECK(t.euler() == 2);
    }
}

TEST_CASE("sdf_grid: batches stay within batch_size, come from several threads, and report progress", "[sdf_grid]") {
    const ScalarSdf f = sphere_sdf({0, 0, 0}, 0.4);
    std::atomic<std::int64_t> evaluated{0}, largest{0};
    pcp::SdfBatchFn counting = [&](const Eigen::Ref<const pcp::PointsF>& p, Eigen::Ref<Eigen::VectorXf> v) {
        evaluated += p.rows();
        std::int64_t seen = largest.load();
        while (p.rows() > seen && !largest.compare_exchange_weak(seen, p.rows())) {
        }
        batch(f)(p, v);
    };
    pcp::SdfGridOptions opts = with_band(pcp::NarrowBand::Coarse, 8);
    opts.batch_size = 2000;  // 2 blocks of 9^3 samples
    std::int64_t calls = 0, last_step = -1;
    bool monotone = true;
    opts.progress = [&](const pcp::Progress& p) {
        ++calls;
        monotone = monotone && p.stage == "sdf-grid" && p.step > last_step && p.step <= p.total;
        last_step = p.step;
        return true;
    };
    const pcp::SdfGrid grid = pcp::evaluate_sdf_grid(counting, cube_grid(96), opts);
    CHECK(evaluated.load() == grid.stats.evaluations);
    CHECK(largest.load() <= 2000);
    CHECK(calls > 0);
    CHECK(monotone);

    opts.progress = [](const pcp::Progress&) { return false; };
    CHECK_THROWS_WITH(pcp::evaluate_sdf_grid(counting, cube_grid(96), opts), Catch::Contains("cancelled"));
}

TEST_CASE("sdf_grid: bad options and bad SDF values are clear errors", "[sdf_grid]") {
    const pcp::SdfBatchFn f = batch(sphere_sdf({0, 0, 0}, 0.4));
    pcp::GridSpec spec = cube_grid(16);

    spec.resolution = 1;
    CHECK_THROWS_WITH(pcp::evaluate_sdf_grid(f, spec), Catch::Contains("resolution 1"));
    spec.resolution = 0;
    CHECK_THROWS_AS(pcp::evaluate_sdf_grid(f, spec), pcp::Error);
    spec = cube_grid(16);
    spec.box.max.y() = spec.box.min.y();
    CHECK_THROWS_WITH(pcp::evaluate_sdf_grid(f, spec), Catch::Contains("box is empty"));
    spec = cube_grid(16);
    spec.box.min.x() = std::numeric_limits<double>::quiet_NaN();
    CHECK_THROWS_WITH(pcp::evaluate_sdf_grid(f, spec), Catch::Contains("not finite"));
    spec = cube_grid(16);

    CHECK_THROWS_WITH(pcp::evaluate_sdf_grid(pcp::SdfBatchFn{}, spec), Catch::Contains("no SDF function"));
    pcp::SdfGridOptions opts;
    opts.block_cells = 1;
    CHECK_THROWS_WITH(pcp::evaluate_sdf_grid(f, spec, opts), Catch::Contains("block_cells"));
    opts = {};
    opts.batch_size = 0;
    CHECK_THROWS_WITH(pcp::evaluate_sdf_grid(f, spec, opts), Catch::Contains("batch_size"));
    opts = {};
    opts.coarse_factor = 0.0;
    CHECK_THROWS_WITH(pcp::evaluate_sdf_grid(f, spec, opts), Catch::Contains("coarse_factor"));
    opts = {};
    opts.band = pcp::NarrowBand::NearPoints;
    CHECK_THROWS_WITH(pcp::evaluate_sdf_grid(f, spec, opts), Catch::Contains("needs band points"));
    CHECK_THROWS_WITH(pcp::evaluate_sdf_grid(f, spec, opts, pcp::PointsF(0, 3)), Catch::Contains("no band points"));

    // A NaN from the SDF names the point; an exception from the SDF reaches the caller.
    pcp::SdfBatchFn nan_inside = [](const Eigen::Ref<const pcp::PointsF>& p, Eigen::Ref<Eigen::VectorXf> v) {
        for (Eigen::Index n = 0; n < p.rows(); ++n)
            v[n] = p.row(n).norm() < 0.2f ? std::numeric_limits<float>::quiet_NaN() : p.row(n).norm() - 0.4f;
    };
    for (auto band : {pcp::NarrowBand::Dense, pcp::NarrowBand::Coarse}) {
        CHECK_THROWS_WITH(pcp::evaluate_sdf_grid(nan_inside, spec, with_band(band)),
                          Catch::Contains("returned nan at point") && Catch::Contains("finite"));
    }
    pcp::SdfBatchFn throwing = [](const Eigen::Ref<const pcp::PointsF>&, Eigen::Ref<Eigen::VectorXf>) {
        throw std::runtime_error("network not loaded");
    };
    CHECK_THROWS_WITH(pcp::evaluate_sdf_grid(throwing, spec), "network not loaded");

    pcp::Aabb empty;
    empty.min = Eigen::Vector3d::Ones();
    empty.max = Eigen::Vector3d::Zero();
    CHECK_THROWS_AS(pcp::make_grid_spec(empty, 16), pcp::Error);
    CHECK_THROWS_AS(pcp::make_grid_spec(pcp::Aabb{}, 16, -0.1), pcp::Error);
}
