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
    const Demo2dOptions o;  // the defaults: the figure in docs/images/demo2d.png
    const Demo2dResult r = pcp::demo::run_demo2d(o);
    REQUIRE_FALSE(r.cancelled);
    INFO("zero set to square: mean " << r.zero_set_mean_distance << ", max " << r.zero_set_max_distance
                                     << "; gap along the square " << r.square_max_gap << "; | |q_l'| - r |: median "
                                     << r.predicted_radius_median << ", p90 " << r.predicted_radius_p90 << "; losses "
                                     << r.prior_loss << ", " << r.fit_loss);
    const double cell = 2 * o.extent / o.grid;
    // The zero set: nothing away from the square (no spurious component), and no gap along it.
    REQUIRE(!r.zero_set.empty());
    CHECK(r.zero_set_max_distance < 2 * cell);
    CHECK(r.zero_set_mean_distance < 0.25 * cell);
    CHECK(r.square_max_gap < 2 * cell);
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
