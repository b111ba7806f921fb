// Tests of the paper's stage-2 ablations (pcp::QueryAblation in pcp/reconstruct.hpp) through
// QueryNetFitter: the names, a toy fit per mode on a torus with a small sphere-trained self-prior
// (loss and |SDF| on the cloud must fall), resume equality for the modes with extra state (F
// trained with Q, the free code), the fingerprint's mode, and reconstruct() without a self-prior
// in the no-prior mode. The gradients of every mode are checked in test_nn_gradients.cpp.
#include "pcp/core/error.hpp"
#include "pcp/train/prior.hpp"
#include "pcp/reconstruct.hpp"
#include "pcp/cloud/shapes.hpp"

#include <catch2/catch.hpp>

#include <omp.h>

#include <cmath>
#include <filesystem>
#include <string>

namespace {

using pcp::QueryAblation;

const QueryAblation kModes[] = {QueryAblation::None,     QueryAblation::NoShift,      QueryAblation::Direct,
                                QueryAblation::FreeCode, QueryAblation::PointNetCode, QueryAblation::NoPrior,
                                QueryAblation::TunePrior};

// A small self-prior on a sphere (32 wide, 4 deep, C = 16, 2^3 regions): trained once.
const pcp::LocalPrior& toy_prior() {
    static const pcp::LocalPrior prior = [] {
        pcp::PriorTrainOptions o = pcp::PriorTrainOptions::preset("fast");
        o.network.width = 32;
        o.network.depth = 4;
        o.network.condition = 16;
        o.network.pointnet_width = 32;
        o.network.pointnet_hidden = 32;
        o.regions.grid = 2;
        o.sampling.queries_per_point = 10;
        o.queries_per_step = 200;
        o.epochs = 30;
        o.schedule.warmup_steps = 10;
        o.schedule.progress_every = 1 << 30;
        o.schedule.seed = 3;
        return pcp::train_prior({pcp::TrainingCloud{"sphere", pcp::sample_sphere(1500, 0.4, Eigen::Vector3d::Zero(), 1).points}}, o);
    }();
    return prior;
}

pcp::QueryFitOptions toy_fit(QueryAblation mode, std::int64_t steps) {
    pcp::QueryFitOptions o;
    o.ablation = mode;
    o.width = 32;
    o.depth = 4;
    o.queries_per_step = 200;
    o.steps = steps;
    o.schedule.learning_rate = 1e-3;
    o.sampling.queries_per_point = 10;
    o.schedule.progress_every = 1 << 30;
    o.schedule.seed = 5;
    return o;
}

const pcp::PreparedCloud& torus() {
    static const pcp::PreparedCloud cloud(pcp::sample_torus(1500, 0.3, 0.12, 2).points, "torus", 1);
    return cloud;
}

double mean_abs_sdf(const pcp::QueryNetFitter& fitter) {
    Eigen::VectorXf v(fitter.cloud().size());
    fitter.sdf(fitter.cloud().unit(), v);
    return static_cast<double>(v.cwiseAbs().mean());
}

struct ThreadsGuard {
    int saved = omp_get_max_threads();
    explicit ThreadsGuard(int n) { omp_set_num_threads(n); }
    ~ThreadsGuard() { omp_set_num_threads(saved); }
};

}  // namespace

TEST_CASE("ablation: names round-trip, unknown names are refused with the list", "[ablation]") {
    for (QueryAblation m : kModes) CHECK(pcp::parse_query_ablation(pcp::to_string(m)) == m);
    CHECK(pcp::to_string(QueryAblation::PointNetCode) == "pointnet-code");
    CHECK_THROWS_WITH(pcp::parse_query_ablation("no-dq"), Catch::Contains("unknown ablation 'no-dq'") && Catch::Contains("tune-prior"));
}

TEST_CASE("ablation: every mode fits a torus through a sphere prior (loss and |SDF| fall)", "[ablation][heavy]") {
    const ThreadsGuard threads(2);
    const int steps = 400;
    for (QueryAblation mode : kModes) {
        pcp::QueryNetFitter fitter(torus(), toy_prior(), toy_fit(mode, steps));
        const double sdf0 = mean_abs_sdf(fitter);
        double first = 0, last = 0;
        for (int s = 0; s < steps; ++s) {
            const double L = fitter.step();
            if (s < 20) first += L / 20;
            if (s >= steps - 20) last += L / 20;
        }
        const double sdf1 = mean_abs_sdf(fitter);
        WARN(pcp::to_string(mode) << ": loss first 20 " << first << ", last 20 " << last << " (x" << last / first
                                  << "); mean |SDF| on the cloud " << sdf0 << " -> " << sdf1);
        // Measured (400 steps, 2 threads): the loss falls to x0.23-0.33 of its start in every mode
        // but pointnet-code, which starts low (the frozen encoder already describes each region of
        // the torus) and falls to x0.66; last-20 losses 0.033-0.056; mean |SDF| on the cloud falls
        // to x0.02-0.05 (pointnet-code x0.24).
        const bool encoder_code = mode == QueryAblation::PointNetCode;
        CHECK(last < (encoder_code ? 0.8 : 0.45) * first);
        CHECK(last < 0.07);
        CHECK(sdf1 < (encoder_code ? 0.35 : 0.1) * sdf0);
    }
}

TEST_CASE("ablation: resume restores the trained F and the free code (weights identical)", "[ablation]") {
    const ThreadsGuard threads(1);
    const std::string dir = std::string(PCP_TEST_TMP_DIR) + "/ablation";
    std::filesystem::create_directories(dir);
    for (QueryAblation mode : {QueryAblation::TunePrior, QueryAblation::NoPrior, QueryAblation::FreeCode}) {
        INFO("mode " << pcp::to_string(mode));
        const std::string ckpt = dir + "/" + pcp::to_string(mode) + ".ckpt";
        pcp::QueryNetFitter straight(torus(), toy_prior(), toy_fit(mode, 40));
        for (int s = 0; s < 40; ++s) straight.step();
        {
            pcp::QueryNetFitter first(torus(), toy_prior(), toy_fit(mode, 40));
            for (int s = 0; s < 20; ++s) first.step();
            first.checkpoint(ckpt);
        }
        pcp::QueryNetFitter resumed(torus(), toy_prior(), toy_fit(mode, 40));
        resumed.resume(ckpt);
        CHECK(resumed.steps_done() == 20);
        for (int s = 0; s < 20; ++s) resumed.step();
        Eigen::VectorXf a(torus().size()), b(torus().size());
        straight.sdf(straight.cloud().unit(), a);
        resumed.sdf(resumed.cloud().unit(), b);
        CHECK((a - b).cwiseAbs().maxCoeff() == 0.0f);
        // Without the checkpoint the trained state differs (the check above can fail).
        pcp::QueryNetFitter fresh(torus(), toy_prior(), toy_fit(mode, 40));
        for (int s = 0; s < 20; ++s) fresh.step();
        fresh.sdf(fresh.cloud().unit(), b);
        CHECK((a - b).cwiseAbs().maxCoeff() > 0.0f);
        // The mode is part of the fingerprint.
        pcp::QueryNetFitter other(torus(), toy_prior(), toy_fit(QueryAblation::None, 40));
        CHECK_THROWS_WITH(other.resume(ckpt), Catch::Contains("other inputs or settings"));
    }
}

TEST_CASE("ablation: reconstruct() in the no-prior mode trains no self-prior", "[ablation][heavy]") {
    const ThreadsGuard threads(2);
    pcp::ReconstructOptions o = pcp::ReconstructOptions::preset("fast");
    o.self_prior.network.width = 32;
    o.self_prior.network.depth = 4;
    o.self_prior.network.condition = 16;
    o.fit = toy_fit(QueryAblation::NoPrior, 150);
    o.resolution = 24;
    pcp::ReconstructReport report;
    const pcp::Mesh mesh = pcp::reconstruct(pcp::sample_sphere(1500, 0.4, Eigen::Vector3d::Zero(), 4).points, nullptr, o, &report);
    CHECK(report.prior_loss == 0.0);  // no stage 1 ran
    CHECK(report.fit_steps == 150);
    CHECK(mesh.faces.rows() > 0);
}

TEST_CASE("query fit: the query pool holds at most the queries the steps draw", "[ablation]") {
    // 1500 points x 10 queries: a pool of 15000 while the steps draw more, of steps x 200 below.
    CHECK(pcp::QueryNetFitter(torus(), toy_prior(), toy_fit(QueryAblation::None, 100)).pool_size() == 15000);
    CHECK(pcp::QueryNetFitter(torus(), toy_prior(), toy_fit(QueryAblation::None, 40)).pool_size() == 8000);
    pcp::QueryFitOptions o = toy_fit(QueryAblation::None, 40);
    o.sampling.max_queries = 5000;  // a smaller cap of the caller's wins
    CHECK(pcp::QueryNetFitter(torus(), toy_prior(), o).pool_size() == 5000);
}

namespace {

const pcp::PreparedCloud& sphere() {
    static const pcp::PreparedCloud cloud(pcp::sample_sphere(1500, 0.4, Eigen::Vector3d(2, 0, 0), 4).points, "sphere", 1);
    return cloud;
}

Eigen::VectorXf field_at(const pcp::QueryNetFitter& fitter, int index, const pcp::PreparedCloud& at) {
    Eigen::VectorXf v(at.size());
    fitter.sdf(index, at.unit(), v);
    return v;
}

}  // namespace

TEST_CASE("query fit of several clouds: one is the single-cloud fit, two share Q through one-hot codes", "[ablation]") {
    const ThreadsGuard one_thread(1);  // bit-for-bit comparisons
    // One cloud given as a list: exactly the single-cloud fitter (no code branch, same pool).
    pcp::QueryNetFitter single(torus(), toy_prior(), toy_fit(QueryAblation::None, 20));
    pcp::QueryNetFitter listed(std::vector<const pcp::PreparedCloud*>{&torus()}, toy_prior(), toy_fit(QueryAblation::None, 20));
    CHECK(listed.num_clouds() == 1);
    CHECK(listed.pool_size() == single.pool_size());
    for (int s = 0; s < 20; ++s) CHECK(listed.step() == single.step());
    CHECK(field_at(listed, 0, torus()) == field_at(single, 0, torus()));

    // Two clouds: the pool holds each one's share of the draws (40 x 200 / 2 = 4000 each).
    const std::vector<const pcp::PreparedCloud*> both{&torus(), &sphere()};
    CHECK(pcp::QueryNetFitter(both, toy_prior(), toy_fit(QueryAblation::None, 40)).pool_size() == 8000);
    pcp::QueryNetFitter two(both, toy_prior(), toy_fit(QueryAblation::None, 300));
    REQUIRE(two.num_clouds() == 2);
    CHECK(&two.cloud(1) == &sphere());
    const double torus0 = field_at(two, 0, torus()).cwiseAbs().mean(), sphere0 = field_at(two, 1, sphere()).cwiseAbs().mean();
    REQUIRE(two.run());
    const double torus1 = field_at(two, 0, torus()).cwiseAbs().mean(), sphere1 = field_at(two, 1, sphere()).cwiseAbs().mean();
    INFO("mean |F_g| on its own cloud: torus " << torus0 << " -> " << torus1 << ", sphere " << sphere0 << " -> " << sphere1);
    CHECK(torus1 < 0.5 * torus0);
    CHECK(sphere1 < 0.5 * sphere0);
    // The code selects the shape: the sphere's field is far from zero on the torus, and back.
    const double cross_torus = field_at(two, 1, torus()).cwiseAbs().mean();
    const double cross_sphere = field_at(two, 0, sphere()).cwiseAbs().mean();
    INFO("cross: sphere's field on the torus " << cross_torus << ", torus's field on the sphere " << cross_sphere);
    CHECK(cross_torus > 3 * torus1);
    CHECK(cross_sphere > 3 * sphere1);

    // Resume: 20 steps, checkpoint, 20 more in a new fitter = 40 straight.
    const std::string ckpt = (std::filesystem::path(PCP_TEST_TMP_DIR) / "several_clouds.ckpt").string();
    pcp::QueryNetFitter straight(both, toy_prior(), toy_fit(QueryAblation::None, 40));
    for (int s = 0; s < 40; ++s) straight.step();
    pcp::QueryNetFitter first(both, toy_prior(), toy_fit(QueryAblation::None, 40));
    for (int s = 0; s < 20; ++s) first.step();
    first.checkpoint(ckpt);
    pcp::QueryNetFitter second(both, toy_prior(), toy_fit(QueryAblation::None, 40));
    second.resume(ckpt);
    while (second.steps_done() < 40) second.step();
    CHECK(field_at(second, 1, sphere()) == field_at(straight, 1, sphere()));
    // A checkpoint of the two clouds does not resume a fit of one of them.
    pcp::QueryNetFitter other(torus(), toy_prior(), toy_fit(QueryAblation::None, 40));
    CHECK_THROWS_AS(other.resume(ckpt), pcp::Error);
    std::filesystem::remove(ckpt);

    // Misuse is refused: no cloud index with two clouds, an index out of range, an ablation.
    Eigen::VectorXf v(torus().size());
    CHECK_THROWS_WITH(two.sdf(torus().unit(), v), Catch::Contains("say which one"));
    CHECK_THROWS_AS(two.sdf(2, torus().unit(), v), pcp::Error);
    CHECK_THROWS_WITH(pcp::QueryNetFitter(both, toy_prior(), toy_fit(QueryAblation::FreeCode, 10)),
                      Catch::Contains("ablation none"));
    CHECK_THROWS_AS(pcp::QueryNetFitter(std::vector<const pcp::PreparedCloud*>{}, toy_prior(), toy_fit(QueryAblation::None, 10)),
                    pcp::Error);
}
