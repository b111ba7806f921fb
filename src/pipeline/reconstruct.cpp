// The reconstruction pipeline (see pcp/reconstruct.hpp): denoise (optional) -> one PreparedCloud
// -> prior (given, resumed beside the checkpoint, or trained on the cloud) -> query-network fit ->
// visibility labels -> the mesh stage (src/pipeline/mesh_stage.hpp: the field's sign, the grid,
// the grid passes, marching cubes, the surface passes) -> mesh in the input frame.
#include "pcp/reconstruct.hpp"

#include "mesh_stage.hpp"
#include "pcp/cloud/prepared_cloud.hpp"
#include "pcp/cloud/regions.hpp"
#include "pcp/core/error.hpp"
#include "pcp/core/rng.hpp"
#include "pcp/settings.hpp"
#include "pcp/train/builtin_prior.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <memory>
#include <vector>

namespace pcp {

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// `count` of the rows of `points`, drawn uniformly without replacement (seeded), in input order.
Points random_subset(const Eigen::Ref<const Points>& points, Eigen::Index count, std::uint64_t seed) {
    const Eigen::Index n = points.rows();
    std::vector<Eigen::Index> index(static_cast<std::size_t>(n));
    for (Eigen::Index i = 0; i < n; ++i) index[static_cast<std::size_t>(i)] = i;
    Rng rng(seed, 0x5B5A3F1E00000000ull);
    for (Eigen::Index i = 0; i < count; ++i) {  // a partial Fisher-Yates shuffle
        const auto j = static_cast<Eigen::Index>(static_cast<std::uint64_t>(i) + rng.below(static_cast<std::uint64_t>(n - i)));
        std::swap(index[static_cast<std::size_t>(i)], index[static_cast<std::size_t>(j)]);
    }
    std::sort(index.begin(), index.begin() + count);
    Points out(count, 3);
    for (Eigen::Index i = 0; i < count; ++i) out.row(i) = points.row(index[static_cast<std::size_t>(i)]);
    return out;
}

/// The prior to fit against: `given`, else F's sizes only (no-prior ablation), else the built-in
/// prior, else (with checkpoints on and --resume) the self-prior kept beside the query-net
/// checkpoint, else a self-prior trained on the cloud. Null when the training was cancelled.
const LocalPrior* obtain_prior(const LocalPrior* given, const std::vector<const PreparedCloud*>& clouds,
                               const ReconstructOptions& options, const std::string& prior_ckpt, LocalPrior& self_prior,
                               ReconstructReport& r, bool noisy) {
    if (given) return given;
    const bool builtin = (options.prior_source == PriorSource::Builtin || (options.prior_source == PriorSource::Auto && !noisy)) &&
                         options.fit.ablation != QueryAblation::NoPrior;
    r.builtin_prior = builtin;
    // Frozen when asked, or when no region of the input has enough points to tune on (small
    // clouds: the built-in prior's 6^3 regions).
    const auto tunable = [&] {
        for (const PreparedCloud* c : clouds)
            if (!split_into_regions(c->unit(), builtin_prior().regions).empty()) return true;
        return false;
    };
    if (builtin && (options.prior_tune_steps <= 0 || !tunable())) return &builtin_prior();
    if (options.fit.schedule.resume && !prior_ckpt.empty() && std::filesystem::exists(prior_ckpt)) {
        self_prior = load_prior(prior_ckpt);
        return &self_prior;
    }
    if (options.fit.ablation == QueryAblation::NoPrior) {
        self_prior = LocalPrior(options.self_prior.network, options.self_prior.schedule.seed);
        return &self_prior;
    }
    PriorTrainOptions po = options.self_prior;
    if (builtin) {  // fine-tune the built-in prior (not owned: the alias of an empty pointer)
        po.start = std::shared_ptr<const LocalPrior>(std::shared_ptr<const LocalPrior>(), &builtin_prior());
        po.max_steps = options.prior_tune_steps;
    }
    po.schedule.progress = detail::chain(po.schedule.progress, options.progress);
    // With checkpoints on, the self-prior's training is checkpointed too (OUT.ckpt.prior-training,
    // at the query fit's cadence and when stopped), so that --resume continues it rather than
    // starting again; the finished prior then replaces it as OUT.ckpt.prior.
    const std::string training_ckpt = prior_ckpt.empty() ? "" : prior_ckpt + "-training";
    if (!training_ckpt.empty()) {
        po.schedule.checkpoint_path = training_ckpt;
        po.schedule.checkpoint_every = options.fit.schedule.checkpoint_every;
        po.schedule.resume = options.fit.schedule.resume;
    }
    // One cloud: the prepared cloud as it is; several: each normalised by the trainer (already in
    // its unit box, so unchanged), one prior for all of them.
    std::vector<TrainingCloud> several;
    if (clouds.size() > 1)
        for (const PreparedCloud* c : clouds) several.push_back(TrainingCloud{c->name(), c->unit().cast<double>()});
    PriorTrainer trainer = clouds.size() > 1 ? PriorTrainer(several, po) : PriorTrainer(*clouds.front(), po);
    if (!trainer.run()) return nullptr;
    self_prior = trainer.prior();
    r.prior_loss = trainer.recent_loss();
    if (!prior_ckpt.empty()) {
        save_prior(prior_ckpt, self_prior);
        std::error_code ignored;
        std::filesystem::remove(training_ckpt, ignored);
    }
    return &self_prior;
}

}  // namespace

namespace {

/// One input as the fit sees it: optionally denoised (include/pcp/cloud/denoise.hpp), then
/// prepared (checked, unit box, KD-tree). The raw input is checked here only when it is denoised
/// first; PreparedCloud checks what it is given.
struct FitInput {
    Points denoised;
    std::unique_ptr<PreparedCloud> cloud;
};

FitInput prepare_input(const Eigen::Ref<const Points>& points, const std::string& name, const ReconstructOptions& options,
                       ReconstructReport& r) {
    r.fit_points = points.rows();
    const Eigen::Index min_points = min_points_for(options.fit.sampling);
    FitInput in;
    if (options.denoise.passes > 0 || options.denoise.automatic) {
        check_point_cloud(points, name, min_points);
        const auto t_denoise = std::chrono::steady_clock::now();
        DenoiseOptions d = options.denoise;
        d.passes = r.denoise_passes = denoise_passes(points, d);
        d.automatic = false;
        if (d.passes > 0) in.denoised = denoise_points(points, d);
        r.seconds_denoise = seconds_since(t_denoise);
    }
    in.cloud = std::make_unique<PreparedCloud>(r.denoise_passes > 0 ? Eigen::Ref<const Points>(in.denoised) : points,
                                               r.denoise_passes > 0 ? "denoised " + name : name, min_points);
    return in;
}

/// Inside / outside by visibility through the cloud (include/pcp/cloud/visibility.hpp), for the
/// passes that read them (ReconstructOptions::visibility); empty when none of them runs.
VisibilityLabels visibility_labels(const PreparedCloud& cloud, const ReconstructOptions& options, ReconstructReport& r) {
    VisibilityLabels labels;
    if (options.needs_visibility_labels()) {
        VisibilityOptions vo = options.visibility;
        vo.seed = options.fit.schedule.seed;
        labels = label_by_visibility(cloud.tree(), vo);
    }
    r.visibility = labels.stats;
    return labels;
}

Mesh reconstruct_fit(const Eigen::Ref<const Points>& points, const Eigen::Ref<const Points>& all_points, bool subsampled,
                     const LocalPrior* prior, const ReconstructOptions& options, ReconstructReport& r, Points* normals) {
    const FitInput in = prepare_input(points, "input cloud", options, r);
    const PreparedCloud& cloud = *in.cloud;

    auto t0 = std::chrono::steady_clock::now();
    LocalPrior self_prior;
    const std::string& ckpt = options.fit.schedule.checkpoint_path;
    const std::string prior_ckpt = ckpt.empty() ? "" : ckpt + ".prior";
    prior = obtain_prior(prior, {&cloud}, options, prior_ckpt, self_prior, r, r.denoise_passes > 0);
    r.seconds_prior = seconds_since(t0);
    if (!prior) {
        r.cancelled = true;
        return Mesh{};
    }

    t0 = std::chrono::steady_clock::now();
    QueryFitOptions fo = options.fit;
    fo.schedule.progress = detail::chain(fo.schedule.progress, options.progress);
    QueryNetFitter fitter(cloud, *prior, fo);
    if (!fitter.run()) {
        r.cancelled = true;
        return Mesh{};
    }
    if (options.keep_checkpoints && !ckpt.empty()) fitter.checkpoint(ckpt);
    r.fit_loss = fitter.recent_loss();
    r.fit_steps = fitter.steps_done();
    r.seconds_fit = seconds_since(t0);

    const VisibilityLabels labels = visibility_labels(cloud, options, r);
    Mesh mesh = detail::mesh_stage(fitter, 0, cloud, all_points, subsampled, labels, options, r, normals);
    std::error_code ignored;
    if (!prior_ckpt.empty() && !options.keep_checkpoints) std::filesystem::remove(prior_ckpt, ignored);
    return mesh;
}

/// Huge inputs: the fit sees a seeded uniform subsample (ReconstructOptions::max_fit_points); every
/// input point is checked first (the normals are given for all of them). Empty when the whole
/// cloud is fitted.
Points fit_subsample(const Eigen::Ref<const Points>& points, const std::string& name, const ReconstructOptions& options) {
    if (options.max_fit_points == 0 || points.rows() <= options.max_fit_points) return Points();
    check_point_cloud(points, name, min_points_for(options.fit.sampling));
    return random_subset(points, options.max_fit_points, options.fit.schedule.seed);
}

}  // namespace

Mesh reconstruct(const Eigen::Ref<const Points>& points, const LocalPrior* prior, const ReconstructOptions& options,
                 ReconstructReport* report, Points* normals) {
    ReconstructReport local;
    ReconstructReport& r = report ? *report : local;
    r = ReconstructReport{};
    if (normals) normals->resize(0, 3);
    check_options(options);
    r.input_points = points.rows();
    const Points subsample = fit_subsample(points, "input cloud", options);
    const bool subsampled = subsample.rows() > 0;
    return reconstruct_fit(subsampled ? Eigen::Ref<const Points>(subsample) : points, points, subsampled, prior,
                           options, r, normals);
}

std::vector<Mesh> reconstruct_many(const std::vector<Points>& clouds, const LocalPrior* prior,
                                   const ReconstructOptions& options, std::vector<ReconstructReport>* reports) {
    PCP_CHECK(!clouds.empty(), "reconstruct_many: no cloud given");
    std::vector<ReconstructReport> local;
    std::vector<ReconstructReport>& rs = reports ? *reports : local;
    rs.assign(clouds.size(), ReconstructReport{});
    if (clouds.size() == 1) {
        std::vector<Mesh> one;
        one.push_back(reconstruct(clouds.front(), prior, options, &rs.front()));
        if (rs.front().cancelled) one.clear();
        return one;
    }
    check_options(options);
    PCP_CHECK(options.fit.ablation == QueryAblation::None,
              "reconstruct_many: several clouds are fitted with the method itself only (ablation none)");
    const int K = static_cast<int>(clouds.size());
    // Each cloud prepared on its own: subsample (max_fit_points), denoise, unit box, tree.
    std::vector<Points> subsamples(clouds.size());
    std::vector<FitInput> inputs;
    std::vector<const PreparedCloud*> prepared;
    for (int k = 0; k < K; ++k) {
        const Points& pts = clouds[static_cast<std::size_t>(k)];
        ReconstructReport& r = rs[static_cast<std::size_t>(k)];
        const std::string name = "cloud " + std::to_string(k + 1);
        r.input_points = pts.rows();
        subsamples[static_cast<std::size_t>(k)] = fit_subsample(pts, name, options);
        const Points& fit_pts = subsamples[static_cast<std::size_t>(k)].rows() > 0 ? subsamples[static_cast<std::size_t>(k)] : pts;
        inputs.push_back(prepare_input(fit_pts, name, options, r));
        prepared.push_back(inputs.back().cloud.get());
    }

    ReconstructReport shared;
    auto t0 = std::chrono::steady_clock::now();
    LocalPrior self_prior;
    const std::string& ckpt = options.fit.schedule.checkpoint_path;
    const std::string prior_ckpt = ckpt.empty() ? "" : ckpt + ".prior";
    bool any_noisy = false;
    for (const ReconstructReport& r : rs) any_noisy = any_noisy || r.denoise_passes > 0;
    prior = obtain_prior(prior, prepared, options, prior_ckpt, self_prior, shared, any_noisy);
    shared.seconds_prior = seconds_since(t0);
    const auto cancelled = [&]() {
        for (ReconstructReport& r : rs) r.cancelled = true;
        return std::vector<Mesh>{};
    };
    if (!prior) return cancelled();

    t0 = std::chrono::steady_clock::now();
    QueryFitOptions fo = options.fit;
    fo.schedule.progress = detail::chain(fo.schedule.progress, options.progress);
    QueryNetFitter fitter(prepared, *prior, fo);
    if (!fitter.run()) return cancelled();
    if (options.keep_checkpoints && !ckpt.empty()) fitter.checkpoint(ckpt);
    shared.fit_loss = fitter.recent_loss();
    shared.fit_steps = fitter.steps_done();
    shared.seconds_fit = seconds_since(t0);

    std::vector<Mesh> meshes;
    for (int k = 0; k < K; ++k) {
        ReconstructReport& r = rs[static_cast<std::size_t>(k)];
        r.prior_loss = shared.prior_loss;
        r.builtin_prior = shared.builtin_prior;
        r.seconds_prior = shared.seconds_prior;
        r.fit_loss = shared.fit_loss;
        r.fit_steps = shared.fit_steps;
        r.seconds_fit = shared.seconds_fit;
        const VisibilityLabels labels = visibility_labels(*prepared[static_cast<std::size_t>(k)], options, r);
        const bool subsampled = subsamples[static_cast<std::size_t>(k)].rows() > 0;
        try {
            meshes.push_back(detail::mesh_stage(fitter, k, *prepared[static_cast<std::size_t>(k)], clouds[static_cast<std::size_t>(k)],
                                        subsampled, labels, options, r, nullptr));
        } catch (const Error& e) {
            PCP_FAIL("cloud " << k + 1 << ": " << e.what());
        }
    }
    std::error_code ignored;
    if (!prior_ckpt.empty() && !options.keep_checkpoints) std::filesystem::remove(prior_ckpt, ignored);
    return meshes;
}

}  // namespace pcp
