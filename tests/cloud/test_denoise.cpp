// Tests for pcp/denoise.hpp: a noisy plane gets flatter, a clean sphere stays on its surface, a far
// offset frame gives the same result as the origin, the two sides of a thin plate stay apart,
// zero passes are the identity, bad options.
#include "pcp/cloud/denoise.hpp"
#include "pcp/core/error.hpp"
#include "pcp/core/rng.hpp"
#include "pcp/cloud/shapes.hpp"

#include <catch2/catch.hpp>

namespace {

pcp::Points noisy_plane(Eigen::Index n, double noise, std::uint64_t seed) {
    pcp::Rng rng(seed, 0);
    pcp::Points p(n, 3);
    for (Eigen::Index i = 0; i < n; ++i) p.row(i) << rng.uniform() - 0.5, rng.uniform() - 0.5, noise * rng.normal();
    return p;
}

double rms_z(const pcp::Points& p) { return std::sqrt(p.col(2).squaredNorm() / double(p.rows())); }

}  // namespace

TEST_CASE("denoise: a noisy plane gets flatter with every pass", "[denoise]") {
    const pcp::Points input = noisy_plane(4000, 0.01, 1);
    pcp::DenoiseOptions o;
    o.passes = 1;
    const pcp::Points once = pcp::denoise_points(input, o);
    o.passes = 3;
    const pcp::Points thrice = pcp::denoise_points(input, o);
    INFO("rms z: input " << rms_z(input) << ", 1 pass " << rms_z(once) << ", 3 passes " << rms_z(thrice));
    CHECK(rms_z(once) < 0.5 * rms_z(input));
    CHECK(rms_z(thrice) < rms_z(once));
    // Each point moves along its fitted plane's normal, which is close to z: sideways moves stay
    // well below the noise (measured rms 0.002 with noise 0.01).
    const double sideways = std::sqrt((once.leftCols<2>() - input.leftCols<2>()).squaredNorm() / double(input.rows()));
    INFO("rms sideways move " << sideways);
    CHECK(sideways < 0.005);
}

TEST_CASE("denoise: a clean sphere stays on its surface, a far frame gives the same result", "[denoise]") {
    const pcp::Points sphere = pcp::sample_sphere(5000, 0.4, Eigen::Vector3d::Zero(), 2).points;
    pcp::DenoiseOptions o;
    o.passes = 2;
    const pcp::Points out = pcp::denoise_points(sphere, o);
    const double worst = (out.rowwise().norm().array() - 0.4).abs().maxCoeff();
    INFO("largest distance from the sphere after 2 passes: " << worst);
    // The plane of 20 neighbours cuts the curved cap by about its sagitta (neighbourhood radius
    // ~0.05 here, so ~0.003): measured 0.0055 at worst after 2 passes.
    CHECK(worst < 0.008);
    const Eigen::RowVector3d offset(1e6, -2e6, 5e5);
    const pcp::Points far = pcp::denoise_points(sphere.rowwise() + offset, o);
    CHECK(((far.rowwise() - offset) - out).cwiseAbs().maxCoeff() < 1e-6);
}

// A plate about as thin as the neighbourhood: two noisy sheets 0.04 apart (noise 0.006, 6,000
// points each over a unit square: 20 neighbours reach about 0.023 sideways, so some come from the
// other sheet). The plane projection pulls both sheets toward the middle (measured 0.0048 after 3
// passes); the move to the mode of the point's own sheet less than half as much (0.0021), and its
// points end closer to their sheet (rms 0.0042 against 0.0063; input 0.0060). Where nearly every
// neighbourhood reaches across (3,000 points a sheet), the noise estimate takes in the thickness
// and the mode merges the sheets too (0.0107 against 0.0136): the limit of the rule.
TEST_CASE("denoise: the two sides of a thin plate stay apart (mode along the normal)", "[denoise]") {
    const double half = 0.02, noise = 0.006;
    pcp::Points plate = noisy_plane(12000, noise, 5);
    for (Eigen::Index i = 0; i < plate.rows(); ++i) plate(i, 2) += i % 2 ? half : -half;
    // Mean signed distance of the points from their own sheet, positive toward the middle, and
    // the rms distance.
    auto errors = [&](const pcp::Points& p) {
        double inward = 0, sq = 0;
        for (Eigen::Index i = 0; i < p.rows(); ++i) {
            const double side = i % 2 ? 1.0 : -1.0, d = p(i, 2) - side * half;
            inward += -side * d;
            sq += d * d;
        }
        return std::make_pair(inward / double(p.rows()), std::sqrt(sq / double(p.rows())));
    };
    pcp::DenoiseOptions o;
    o.passes = 3;
    o.mode_width = 0;
    const auto [plane_in, plane_rms] = errors(pcp::denoise_points(plate, o));
    o.mode_width = 2;
    const auto [mode_in, mode_rms] = errors(pcp::denoise_points(plate, o));
    const auto [raw_in, raw_rms] = errors(plate);
    INFO("toward the middle / rms: input " << raw_in << " / " << raw_rms << ", plane " << plane_in << " / " << plane_rms
                                           << ", mode " << mode_in << " / " << mode_rms);
    CHECK(plane_in > 0.2 * half);            // the plane's pull toward the middle
    CHECK(std::abs(mode_in) < 0.6 * plane_in);
    CHECK(mode_rms < 0.8 * plane_rms);
    CHECK(mode_rms < 0.8 * raw_rms);         // and still denoised
    o.mode_width = -1;
    CHECK_THROWS_WITH(pcp::denoise_points(plate, o), Catch::Contains("mode_width"));
}

TEST_CASE("denoise: zero passes are the identity, bad options are errors", "[denoise]") {
    const pcp::Points input = noisy_plane(100, 0.01, 3);
    pcp::DenoiseOptions o;
    CHECK(pcp::denoise_points(input, o) == input);
    o.passes = -1;
    CHECK_THROWS_AS(pcp::denoise_points(input, o), pcp::Error);
    o.passes = 1;
    o.neighbors = 2;
    CHECK_THROWS_AS(pcp::denoise_points(input, o), pcp::Error);
    o.neighbors = 257;
    CHECK_THROWS_AS(pcp::denoise_points(input, o), pcp::Error);
    o.neighbors = 20;
    CHECK_THROWS_WITH(pcp::denoise_points(input.topRows(10), o), Catch::Contains("fewer than the 20 neighbours"));
}

TEST_CASE("denoise: auto denoises a noisy cloud and leaves a clean one", "[denoise]") {
    const pcp::Points noisy = noisy_plane(3000, 0.02, 4);
    const pcp::Points clean = pcp::sample_sphere(3000, 0.4, Eigen::Vector3d::Zero(), 5).points;
    const double noisy_ratio = pcp::noise_ratio(noisy), clean_ratio = pcp::noise_ratio(clean);
    INFO("noise ratio: noisy plane " << noisy_ratio << ", clean sphere " << clean_ratio);
    CHECK(noisy_ratio > 0.25);
    CHECK(clean_ratio < 0.1);
    pcp::DenoiseOptions o;
    o.automatic = true;
    CHECK(pcp::denoise_passes(noisy, o) == 3);
    CHECK(pcp::denoise_passes(clean, o) == 0);
    CHECK(rms_z(pcp::denoise_points(noisy, o)) < 0.5 * rms_z(noisy));
    CHECK(pcp::denoise_points(clean, o) == clean);
    // Isotropic noise (a ball of points) has no plane: the ratio is below 1/sqrt(3) only because
    // 20 samples underestimate the smallest eigenvalue (measured 0.448).
    pcp::Rng rng(6, 0);
    pcp::Points ball(2000, 3);
    for (Eigen::Index i = 0; i < ball.rows(); ++i) ball.row(i) << rng.normal(), rng.normal(), rng.normal();
    const double ball_ratio = pcp::noise_ratio(ball);
    CHECK(ball_ratio > 0.4);
    CHECK(ball_ratio < 1 / std::sqrt(3.0));
}
