// End-to-end stage 1: a prior trained for a few hundred steps on test-generated shapes lowers the
// loss, and on a held-out shape of the same kind pulls queries onto the surface.
#include "pcp/cloud/kdtree.hpp"
#include "pcp/cloud/normalize.hpp"
#include "pcp/train/prior.hpp"
#include "pcp/cloud/regions.hpp"
#include "pcp/cloud/sampling.hpp"
#include "pcp/cloud/shapes.hpp"

#include <catch2/catch.hpp>

TEST_CASE("e2e prior: training lowers the loss and pulls held-out queries to the surface", "[e2e][prior]") {
    pcp::PriorTrainOptions o = pcp::PriorTrainOptions::preset("fast");
    o.network.width = 128;
    o.network.depth = 4;
    o.network.condition = 32;
    o.network.pointnet_width = 64;
    o.network.pointnet_hidden = 64;
    o.regions.grid = 2;
    // Queries at 0.5, 1 and 2 sigma_p (the release alternates 0.5 and 1): with 0.5 alone the
    // measure below cannot reach 0.3 even for a perfect surface (the floor, measured: 0.39).
    o.sampling.spreads = {0.5f, 1.0f, 2.0f};
    o.max_steps = 6000;
    o.queries_per_step = 1000;
    o.schedule.learning_rate = 2e-3;
    o.schedule.warmup_steps = 20;
    const std::vector<pcp::TrainingCloud> clouds = {
        {"torus a", pcp::sample_torus(4000, 0.35, 0.12, 1).points},
        {"torus b", pcp::sample_torus(4000, 0.30, 0.15, 2).points},
        {"sphere", pcp::sample_sphere(4000, 0.45, Eigen::Vector3d::Zero(), 3).points}};
    pcp::PriorTrainer trainer(clouds, o);
    double first = 0;
    for (int i = 0; i < 20; ++i) first += trainer.step() / 20;
    REQUIRE(trainer.run());
    const double last = trainer.recent_loss();
    WARN("stage-1 loss: first 20 steps " << first << ", last steps " << last << " (factor " << first / last << ")");
    // Measured (2 threads, seed 1): factor 15.7 on three shapes; bound set with margin.
    CHECK(last < first / 6.0);

    // Held out: a torus of other radii, cut into regions like a training cloud, in region
    // coordinates; queries drawn with the prior's own sampling. Besides |p - t| (the issue's
    // measure: t is the nearest *sample*, so even a perfect surface leaves |p - t| > 0), the
    // analytic torus gives the floor (queries projected exactly onto the surface) and the true
    // distances to the surface before and after pulling.
    const double major = 0.32, minor = 0.10;
    const pcp::Points held = pcp::sample_torus(4000, major, minor, 4).points;
    const pcp::Normalization unit_frame = pcp::fit_unit_box(held);
    const pcp::PointsF unit = unit_frame.to_unit(held);
    const std::vector<pcp::Region> regions = pcp::split_into_regions(unit, o.regions);
    REQUIRE(!regions.empty());
    const pcp::LocalPrior prior = trainer.prior();
    // Exact projection onto the torus, in region coordinates.
    auto project = [&](const pcp::Region& region, const pcp::PointsF& local) {
        const pcp::Points x = unit_frame.from_unit(region.from_region(local).cast<double>());
        pcp::Points y(x.rows(), 3);
        for (Eigen::Index i = 0; i < x.rows(); ++i) {
            const Eigen::Vector3d q = x.row(i).transpose();
            const Eigen::Vector3d ring = major * Eigen::Vector3d(q.x(), q.y(), 0.0).normalized();
            y.row(i) = (ring + minor * (q - ring).normalized()).transpose();
        }
        return region.to_region(unit_frame.to_unit(y));
    };
    double raw = 0, pulled = 0, floor = 0, raw_surface = 0, pulled_surface = 0;
    Eigen::Index count = 0;
    for (const pcp::Region& region : regions) {
        const pcp::PointsF local = pcp::region_points(unit, region);
        const pcp::KdTree tree(local);
        const pcp::QuerySet set = pcp::sample_queries(tree, prior.sampling, 77);
        const pcp::PointsF p = prior.pull(set.queries, set.targets);
        const pcp::PointsF q_star = project(region, set.queries), p_star = project(region, p);
        raw += (set.queries - set.targets).rowwise().norm().sum();
        pulled += (p - set.targets).rowwise().norm().sum();
        floor += (q_star - set.targets).rowwise().norm().sum();
        raw_surface += (set.queries - q_star).rowwise().norm().sum();
        pulled_surface += (p - p_star).rowwise().norm().sum();
        count += set.queries.rows();
    }
    WARN("held-out torus (" << count << " queries): mean |p - t| / mean |q - t| = " << pulled / raw
         << " (floor with exact projection: " << floor / raw << "); distance to the true surface: "
         << raw_surface / static_cast<double>(count) << " -> " << pulled_surface / static_cast<double>(count)
         << " (ratio " << pulled_surface / raw_surface << ")");
    // Measured (2 threads, seed 1, 6000 steps): |p - t| ratio 0.268 (floor 0.383: the pulled
    // points sit closer to the samples than the exact projections do); true-surface distance
    // 0.163 -> 0.031 (ratio 0.187). Issue 4 asks for |p - t| <= 0.3 |q - t|. With 0.5 sigma_p
    // queries only and 2000 steps the ratio was 0.59 (floor 0.39); 4000 steps gave 0.289.
    CHECK(pulled <= 0.3 * raw);
    CHECK(pulled_surface <= 0.25 * raw_surface);
}
