// Tests for pcp/prior.hpp (stage 1) at toy size: every grid size and normalisation runs,
// save -> load is exact, an interrupted run resumes to identical weights, bad input is named.
#include "pcp/core/error.hpp"
#include "pcp/nn/networks.hpp"
#include "pcp/train/prior.hpp"
#include "pcp/cloud/shapes.hpp"

#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>

#include <omp.h>

namespace fs = std::filesystem;

namespace {

pcp::PriorTrainOptions tiny_options() {
    pcp::PriorTrainOptions o;
    o.network.width = 16;
    o.network.depth = 2;
    o.network.condition = 8;
    o.network.pointnet_width = 16;
    o.network.pointnet_hidden = 16;
    o.sampling.queries_per_point = 8;
    o.queries_per_step = 200;
    o.regions.grid = 2;
    o.max_steps = 30;
    o.schedule.learning_rate = 1e-3;
    o.schedule.progress_every = 5;
    return o;
}

std::vector<pcp::TrainingCloud> tiny_clouds() {
    return {{"sphere", pcp::sample_sphere(1500, 0.4, Eigen::Vector3d::Zero(), 1).points},
            {"torus", pcp::sample_torus(1500, 0.35, 0.12, 2).points}};
}

fs::path tmp_dir(const std::string& name) {
    const fs::path dir = fs::path(PCP_TEST_TMP_DIR) / "prior" / name;
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}

/// Runs `body` with one OpenMP/Eigen thread (bit-exact reductions), restoring the count after.
template <class F>
void single_threaded(F&& body) {
    const int saved = omp_get_max_threads();
    omp_set_num_threads(1);
    Eigen::setNbThreads(1);
    body();
    omp_set_num_threads(saved);
    Eigen::setNbThreads(saved);
}

}  // namespace

TEST_CASE("prior: grid sizes 1, 4, 6, 8 and the four normalisations train", "[prior]") {
    const std::vector<pcp::TrainingCloud> clouds = {{"torus", pcp::sample_torus(6000, 0.35, 0.12, 3).points}};
    for (int grid : {1, 4, 6, 8})
        for (const char* norm : {"none", "center", "scale", "both"}) {
            pcp::PriorTrainOptions o = tiny_options();
            o.regions.grid = grid;
            o.regions.normalization = pcp::parse_region_normalization(norm);
            o.max_steps = 3;
            pcp::PriorTrainer trainer(clouds, o);
            INFO("grid " << grid << ", normalisation " << norm << ", regions " << trainer.num_regions());
            CHECK(trainer.num_regions() >= 1);
            if (grid == 1) CHECK(trainer.num_regions() == 1);
            REQUIRE(trainer.run());
            CHECK(trainer.steps_done() == 3);
            CHECK(std::isfinite(trainer.recent_loss()));
        }
}

TEST_CASE("prior: save -> load gives identical SDF values and keeps the settings", "[prior]") {
    const fs::path dir = tmp_dir("save_load");
    pcp::PriorTrainOptions o = tiny_options();
    o.regions.normalization = pcp::RegionNormalization::Center;
    o.sampling.spreads = {0.5f, 1.0f};
    const pcp::LocalPrior prior = pcp::train_prior(tiny_clouds(), o);
    const std::string path = (dir / "p.pcpm").string();
    pcp::save_prior(path, prior);
    const pcp::LocalPrior back = pcp::load_prior(path);
    const pcp::PointsF q = pcp::sample_sphere(300, 0.3, Eigen::Vector3d::Zero(), 9).points.cast<float>();
    const pcp::PointsF ctx = pcp::sample_sphere(200, 0.4, Eigen::Vector3d::Zero(), 10).points.cast<float>();
    const Eigen::VectorXf a = prior.sdf(q, ctx), b = back.sdf(q, ctx);
    CHECK(a == b);
    CHECK(back.regions.normalization == pcp::RegionNormalization::Center);
    CHECK(back.regions.grid == 2);
    CHECK(back.sampling.spreads == std::vector<float>{0.5f, 1.0f});
    CHECK(back.network.width == 16);
    CHECK(back.provenance.inputs == std::vector<std::string>{"sphere", "torus"});
    CHECK(back.provenance.steps == 30);
    CHECK(back.provenance.final_loss == prior.provenance.final_loss);
    CHECK(!back.provenance.settings.empty());
}

TEST_CASE("prior: an interrupted run resumed from its checkpoint ends with identical weights", "[prior]") {
    const fs::path dir = tmp_dir("resume");
    single_threaded([&] {
        const pcp::PriorTrainOptions o = tiny_options();
        pcp::PriorTrainer whole(tiny_clouds(), o);
        REQUIRE(whole.run());

        pcp::PriorTrainOptions interrupted = o;
        interrupted.schedule.checkpoint_path = (dir / "run.ckpt").string();
        interrupted.schedule.checkpoint_every = 1000;  // only the checkpoint written when stopped
        interrupted.schedule.progress = [](const pcp::Progress& p) { return p.step < 15; };
        pcp::PriorTrainer first(tiny_clouds(), interrupted);
        REQUIRE_FALSE(first.run());
        REQUIRE(first.steps_done() == 15);
        const std::string ckpt = interrupted.schedule.checkpoint_path;
        REQUIRE(fs::exists(ckpt));

        pcp::PriorTrainer second(tiny_clouds(), o);
        second.resume(ckpt);
        CHECK(second.steps_done() == 15);
        REQUIRE(second.run());
        CHECK(second.prior().decoder().params == whole.prior().decoder().params);
        CHECK(second.prior().encoder().params == whole.prior().encoder().params);

        // The same through the schedule's resume flag: run() continues at step 15.
        pcp::PriorTrainOptions again = o;
        again.schedule.checkpoint_path = ckpt;
        again.schedule.resume = true;
        std::int64_t first_reported = -1;
        again.schedule.progress = [&](const pcp::Progress& p) {
            if (first_reported < 0) first_reported = p.step;
            return true;
        };
        pcp::PriorTrainer flagged(tiny_clouds(), again);
        REQUIRE(flagged.run());
        CHECK(first_reported == 15);
        CHECK(flagged.prior().decoder().params == whole.prior().decoder().params);
        // With the flag but no checkpoint file, the run starts at step 0.
        again.schedule.checkpoint_path = (dir / "absent.ckpt").string();
        first_reported = -1;
        pcp::PriorTrainer fresh(tiny_clouds(), again);
        REQUIRE(fresh.run());
        CHECK(first_reported == 0);

        // A checkpoint of other settings is refused.
        pcp::PriorTrainOptions other = o;
        other.schedule.learning_rate = 2e-3;
        pcp::PriorTrainer third(tiny_clouds(), other);
        CHECK_THROWS_WITH(third.resume(ckpt), Catch::Contains("other inputs or settings"));
    });
}

TEST_CASE("prior: bad inputs and bad prior files are named", "[prior]") {
    const fs::path dir = tmp_dir("bad");
    pcp::PriorTrainOptions o = tiny_options();
    pcp::Points flat(200, 3);
    flat.setRandom();
    flat.col(2).setConstant(1.0);
    CHECK_THROWS_WITH(pcp::PriorTrainer({{"flat.ply", flat}}, o), Catch::Contains("flat.ply") && Catch::Contains("plane"));
    o.regions.min_points = 5000;
    CHECK_THROWS_WITH(pcp::PriorTrainer(tiny_clouds(), o), Catch::Contains("at least 5000 points"));

    const std::string path = (dir / "p.pcpm").string();
    pcp::save_prior(path, pcp::train_prior(tiny_clouds(), tiny_options()));
    std::ifstream in(path, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::string truncated = (dir / "truncated.pcpm").string(), corrupt = (dir / "corrupt.pcpm").string(),
                      version = (dir / "version.pcpm").string(), missing = (dir / "missing.pcpm").string();
    std::ofstream(truncated, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
    std::string flipped = bytes;
    flipped[bytes.size() / 2] = static_cast<char>(flipped[bytes.size() / 2] ^ 0x40);
    std::ofstream(corrupt, std::ios::binary) << flipped;
    std::string other_version = bytes;
    other_version[8] = static_cast<char>(other_version[8] + 7);  // the format version follows the 8-byte magic
    std::ofstream(version, std::ios::binary) << other_version;
    CHECK_THROWS_WITH(pcp::load_prior(truncated), Catch::Contains("truncated.pcpm"));
    CHECK_THROWS_WITH(pcp::load_prior(corrupt), Catch::Contains("corrupt.pcpm"));
    CHECK_THROWS_WITH(pcp::load_prior(version), Catch::Contains("version.pcpm") && Catch::Contains("version"));
    CHECK_THROWS_WITH(pcp::load_prior(missing), Catch::Contains("missing.pcpm"));
    CHECK_NOTHROW(pcp::load_prior(path));
}

TEST_CASE("prior: each region's query pool holds at most the queries its steps draw", "[prior]") {
    pcp::PriorTrainOptions o = tiny_options();
    o.regions.grid = 1;  // one region per cloud: 1500 points x 8 queries = 12000 each
    o.max_steps = 200;   // 100 steps per region x 200 queries: more than the pool
    CHECK(pcp::PriorTrainer(tiny_clouds(), o).pool_size() == 2 * 12000);
    o.max_steps = 30;    // 15 steps per region x 200 = 3000 per region
    CHECK(pcp::PriorTrainer(tiny_clouds(), o).pool_size() == 2 * 3000);
    o.max_steps = 0;
    o.epochs = 4;        // 4 steps per region x 200
    CHECK(pcp::PriorTrainer(tiny_clouds(), o).pool_size() == 2 * 800);
}
