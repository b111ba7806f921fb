// Tests for the generated training shapes (pcp/train/training_shapes.hpp) and the built-in prior
// (pcp/train/builtin_prior.hpp): shapes are deterministic, their points lie on the surface and
// carry the asked noise; the built-in prior is the asset file, usable, and what reconstruct fits
// against when no prior is given.
#include "pcp/core/error.hpp"
#include "pcp/core/rng.hpp"
#include "pcp/nn/networks.hpp"
#include "pcp/reconstruct.hpp"
#include "pcp/cloud/shapes.hpp"
#include "pcp/train/builtin_prior.hpp"
#include "pcp/train/training_shapes.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <set>

TEST_CASE("training shapes are deterministic and lie on their surface", "[train][shapes][heavy]") {
    std::set<std::string> kinds;
    for (int i = 0; i < 12; ++i) {
        const pcp::TrainingShape shape = pcp::make_training_shape(i, 5);
        const pcp::TrainingShape again = pcp::make_training_shape(i, 5);
        REQUIRE(shape.name == again.name);
        kinds.insert(shape.name.substr(shape.name.find(' ') + 1));
        const pcp::Points a = pcp::sample_training_shape(shape, 2000, 0.0, 9, 96);
        const pcp::Points b = pcp::sample_training_shape(again, 2000, 0.0, 9, 96);
        REQUIRE(a == b);
        double worst = 0.0;
        for (Eigen::Index r = 0; r < a.rows(); ++r) {
            worst = std::max(worst, std::abs(shape.sdf(a.row(r).transpose())));
            REQUIRE((a.row(r).transpose().array() >= shape.box.min.array()).all());
            REQUIRE((a.row(r).transpose().array() <= shape.box.max.array()).all());
        }
        INFO(shape.name);
        CHECK(worst < 1e-4);  // Newton-projected onto the zero set
    }
    CHECK(kinds.size() >= 8);  // the family varies
    // Another seed, other shapes.
    CHECK(pcp::make_training_shape(0, 5).name != pcp::make_training_shape(0, 6).name);
}

TEST_CASE("training shapes carry the asked noise", "[train][shapes]") {
    const pcp::TrainingShape shape = pcp::make_training_shape(3, 1);
    const double noise = 0.004;
    const pcp::Points p = pcp::sample_training_shape(shape, 4000, noise, 2, 96);
    double sum2 = 0.0;
    for (Eigen::Index r = 0; r < p.rows(); ++r) sum2 += std::pow(shape.sdf(p.row(r).transpose()), 2);
    // The distance to the surface of an isotropic displacement: its normal component, std = noise.
    CHECK(std::sqrt(sum2 / static_cast<double>(p.rows())) == Approx(noise).epsilon(0.15));
}

TEST_CASE("generated training clouds follow the options", "[train][shapes]") {
    pcp::TrainingShapeOptions o;
    o.count = 4;
    o.points = {1000, 2000};
    o.noise = {0.0, 0.01};
    o.mesh_resolution = 64;
    const std::vector<pcp::TrainingCloud> clouds = pcp::generate_training_clouds(o);
    REQUIRE(clouds.size() == 4);
    CHECK(clouds[0].points.rows() == 1000);
    CHECK(clouds[1].points.rows() == 2000);
    CHECK(clouds[2].points.rows() == 1000);
    CHECK(clouds[2].name.find("noise 0.01") != std::string::npos);
    CHECK(clouds[0].name.find("noise 0)") != std::string::npos);
    o.count = 0;
    CHECK_THROWS_AS(pcp::generate_training_clouds(o), pcp::Error);
}

TEST_CASE("the built-in prior is the asset file and evaluates", "[train][builtin]") {
    const pcp::LocalPrior& prior = pcp::builtin_prior();
    CHECK(&prior == &pcp::builtin_prior());  // parsed once
    const pcp::LocalPrior file = pcp::load_prior(PCP_SOURCE_DIR "/assets/builtin_prior.pcpm");
    CHECK(prior.network.width == file.network.width);
    CHECK(prior.network.condition == file.network.condition);
    CHECK(prior.provenance.steps == file.provenance.steps);
    CHECK(prior.provenance.steps > 0);
    CHECK(prior.regions.grid == file.regions.grid);
    // Same weights: F on the same points and context.
    const pcp::PointsF context = pcp::sample_sphere(300, 0.4, Eigen::Vector3d::Zero(), 3).points.cast<float>();
    pcp::PointsF q(3, 3);
    q << 0.0f, 0.0f, 0.0f, 0.4f, 0.0f, 0.0f, 0.0f, 0.0f, 0.8f;
    const Eigen::VectorXf s = prior.sdf(q, context), t = file.sdf(q, context);
    REQUIRE(s.allFinite());
    CHECK(s == t);
    // A generic prior knows a sphere: inside negative, outside positive.
    CHECK(s(0) < 0.0f);
    CHECK(s(2) > 0.0f);
    // It was trained on the generated shapes.
    bool generated = false;
    for (const std::string& input : prior.provenance.inputs) generated = generated || input.find("shape_") == 0;
    CHECK(generated);
}

TEST_CASE("reconstruct: the built-in prior frozen or tuned, a self-prior, and auto by the noise", "[train][builtin][heavy]") {
    // The default of the default and fast presets (presets.cpp says why); scenes and the paper's
    // sizes keep a self-prior.
    CHECK(pcp::ReconstructOptions::preset("default").prior_source == pcp::PriorSource::Builtin);
    CHECK(pcp::ReconstructOptions::preset("fast").prior_source == pcp::PriorSource::Builtin);
    CHECK(pcp::ReconstructOptions::preset("scene").prior_source == pcp::PriorSource::SelfPrior);
    CHECK(pcp::ReconstructOptions::preset("default").prior_tune_steps == 300);
    CHECK(pcp::ReconstructOptions::preset("paper").prior_source == pcp::PriorSource::SelfPrior);
    // The default denoises a noisy cloud to each point's own side; scenes were measured with the plane.
    CHECK(pcp::ReconstructOptions::preset("default").denoise.mode_width == 2.0);
    CHECK(pcp::ReconstructOptions::preset("scene").denoise.mode_width == 0.0);
    // Two passes of the own-side mode; scenes keep the plane's three, `fast` too.
    CHECK(pcp::ReconstructOptions::preset("default").denoise.auto_passes == 2);
    CHECK(pcp::ReconstructOptions::preset("scene").denoise.auto_passes == 3);
    CHECK(pcp::ReconstructOptions::preset("fast").denoise.auto_passes == 3);
    // Objects are fitted on at most 200,000 points, scenes on up to a million.
    CHECK(pcp::ReconstructOptions::preset("default").max_fit_points == 200000);
    CHECK(pcp::ReconstructOptions::preset("scene").max_fit_points == 1000000);
    // Noisy objects' meshes are recentred onto the noise's middle; rooms were measured without.
    CHECK(pcp::ReconstructOptions::preset("default").noisy.recentre);
    CHECK_FALSE(pcp::ReconstructOptions::preset("default").recentre.enabled);
    CHECK_FALSE(pcp::ReconstructOptions::preset("scene").noisy.recentre);

    const pcp::Points clean = pcp::sample_sphere(12000, 0.4, Eigen::Vector3d::Zero(), 4).points;
    pcp::ReconstructOptions o = pcp::ReconstructOptions::preset("fast");
    o.fit.steps = 150;
    o.fit.queries_per_step = 500;
    o.fit.width = 32;
    o.resolution = 32;
    o.self_prior.max_steps = 5;
    o.prior_tune_steps = 0;
    pcp::ReconstructReport frozen, tuned, self, noisy_auto;
    o.prior_source = pcp::PriorSource::Builtin;
    (void)pcp::reconstruct(clean, nullptr, o, &frozen);
    CHECK(frozen.builtin_prior);
    CHECK(frozen.prior_loss == 0.0);  // nothing trained
    o.prior_tune_steps = 5;
    (void)pcp::reconstruct(clean, nullptr, o, &tuned);
    CHECK(tuned.builtin_prior);
    CHECK(tuned.prior_loss > 0.0);  // the built-in prior was fine-tuned
    o.prior_source = pcp::PriorSource::SelfPrior;
    (void)pcp::reconstruct(clean, nullptr, o, &self);
    CHECK_FALSE(self.builtin_prior);
    CHECK(self.prior_loss > 0.0);  // a self-prior was trained

    // Auto: the clean sphere gets the built-in prior, the same sphere with noise a self-prior.
    o.prior_source = pcp::PriorSource::Auto;
    pcp::ReconstructReport clean_auto;
    (void)pcp::reconstruct(clean, nullptr, o, &clean_auto);
    CHECK(clean_auto.denoise_passes == 0);
    CHECK(clean_auto.builtin_prior);
    pcp::Points noisy = clean;
    pcp::Rng rng(7, 0);
    for (Eigen::Index i = 0; i < noisy.rows(); ++i)
        for (int k = 0; k < 3; ++k) noisy(i, k) += 0.01 * rng.normal();
    (void)pcp::reconstruct(noisy, nullptr, o, &noisy_auto);
    CHECK(noisy_auto.denoise_passes > 0);
    CHECK_FALSE(noisy_auto.builtin_prior);
}
