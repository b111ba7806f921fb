// Stage 2 (query-network fitting with F frozen) and the meshing pipeline (see pcp/reconstruct.hpp).
// The fitter samples the global query pool once (seeded), then each step draws queries_per_step of
// them (seeded per step) and calls nn::Stage2Trainer::step. The SDF for meshing is F_g evaluated
// by nn::global_sdf_eval with one cache per OpenMP thread. The sign is decided on samples of the
// grid box's boundary, which lie outside the shape: if most are negative, the field is negated.
// The ablations (QueryAblation) choose the nn::Stage2Config; the pointnet-code one also keeps the
// per-region conditions and the cell -> region table here.
#include "pcp/reconstruct.hpp"

#include "train/step_loop.hpp"
#include "pcp/cloud/denoise.hpp"
#include "pcp/core/error.hpp"
#include "pcp/cloud/kdtree.hpp"
#include "pcp/nn/checkpoint.hpp"
#include "pcp/nn/gemm.hpp"
#include "pcp/mesh/marching_cubes.hpp"
#include "pcp/nn/networks.hpp"
#include "pcp/nn/steps.hpp"
#include "pcp/cloud/normalize.hpp"
#include "pcp/cloud/regions.hpp"
#include "pcp/core/rng.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <filesystem>
#include <map>
#include <numeric>
#include <sstream>

#include <omp.h>

namespace pcp {

using MatF = nn::Mat<float>;

namespace {
double seconds_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
constexpr int kEvalBatch = 4096;

struct AblationName {
    QueryAblation mode;
    const char* name;
};
constexpr AblationName kAblations[] = {
    {QueryAblation::None, "none"},           {QueryAblation::NoShift, "no-shift"},
    {QueryAblation::Direct, "direct"},       {QueryAblation::FreeCode, "free-code"},
    {QueryAblation::PointNetCode, "pointnet-code"}, {QueryAblation::NoPrior, "no-prior"},
    {QueryAblation::TunePrior, "tune-prior"},
};

nn::Stage2Config stage2_config(QueryAblation mode) {
    nn::Stage2Config c;
    switch (mode) {
        case QueryAblation::None: break;
        case QueryAblation::NoShift: c.point = nn::QueryPoint::Identity; break;
        case QueryAblation::Direct: c.point = nn::QueryPoint::Direct; break;
        case QueryAblation::FreeCode: c.condition = nn::QueryCondition::FreeCode; break;
        case QueryAblation::PointNetCode: c.condition = nn::QueryCondition::Given; break;
        case QueryAblation::NoPrior:
        case QueryAblation::TunePrior: c.train_decoder = true; break;
    }
    return c;
}

/// Space-separated hexadecimal floats (exact round trip) for checkpoint metadata.
std::string hex_floats(const nn::Vec<float>& v) {
    std::string s;
    char buf[48];
    for (Eigen::Index i = 0; i < v.size(); ++i) {
        std::snprintf(buf, sizeof buf, i ? " %a" : "%a", static_cast<double>(v(i)));
        s += buf;
    }
    return s;
}

/// The value of `key=` in metadata lines, parsed as `n` hexadecimal floats.
nn::Vec<float> metadata_floats(const std::string& meta, const std::string& key, Eigen::Index n, const std::string& path) {
    const std::string tag = "\n" + key + "=";
    const std::size_t at = meta.find(tag);
    PCP_CHECK(at != std::string::npos, path << ": the checkpoint has no '" << key << "' (written by another mode?)");
    const char* p = meta.c_str() + at + tag.size();
    nn::Vec<float> v(n);
    for (Eigen::Index i = 0; i < n; ++i) {
        char* end = nullptr;
        v(i) = static_cast<float>(std::strtod(p, &end));
        PCP_CHECK(end != p, path << ": corrupt '" << key << "' in the checkpoint (" << i << " of " << n << " values)");
        p = end;
    }
    return v;
}

}  // namespace

QueryAblation parse_query_ablation(const std::string& name) {
    for (const AblationName& a : kAblations)
        if (name == a.name) return a.mode;
    PCP_FAIL("unknown ablation '" << name << "' (use none, no-shift, direct, free-code, pointnet-code, no-prior or tune-prior)");
}

std::string to_string(QueryAblation ablation) {
    for (const AblationName& a : kAblations)
        if (ablation == a.mode) return a.name;
    return "?";
}

struct QueryNetFitter::Impl {
    QueryFitOptions options;
    std::string fingerprint;  ///< input + prior + settings: a checkpoint must match it
    Normalization norm;
    PointsF unit;
    MatF queries, targets;  ///< 3 x M pool
    std::unique_ptr<nn::Stage2Trainer<float>> trainer;
    MatF q, t, codes;       ///< batch buffers; codes stays 0 x 0 (one cloud, no shape code)
    std::deque<double> recent;
    mutable std::vector<std::unique_ptr<nn::GlobalSdfCache<float>>> caches;  ///< one per thread
    nn::Stage2Config config;
    // pointnet-code: the frozen encoder's condition of each region (C x R), the region of each
    // grid cell, and the grid (the cloud's box split like split_into_regions does).
    MatF region_cond;
    std::vector<int> cell_region;
    Eigen::Vector3f grid_lo = Eigen::Vector3f::Zero(), grid_extent = Eigen::Vector3f::Zero();
    int grid = 1;
    MatF cond;              ///< C x batch: the gathered conditions of a step

    int region_of(const Eigen::Vector3f& p) const {
        int id = 0;
        for (int c = 2; c >= 0; --c) {
            int k = 0;
            if (grid_extent(c) > 0.0f) k = static_cast<int>(std::floor((p(c) - grid_lo(c)) / grid_extent(c) * static_cast<float>(grid)));
            id = id * grid + std::clamp(k, 0, grid - 1);
        }
        return cell_region[static_cast<std::size_t>(id)];
    }
    /// dst (C x n) = the conditions of the regions of the columns of pts (3 x n, unit box).
    void gather_conditions(const Eigen::Ref<const MatF>& pts, Eigen::Ref<MatF> dst) const {
        for (Eigen::Index i = 0; i < pts.cols(); ++i) dst.col(i) = region_cond.col(region_of(pts.col(i)));
    }
    void prepare_region_conditions(const LocalPrior& prior);
};

void QueryNetFitter::Impl::prepare_region_conditions(const LocalPrior& prior) {
    const std::vector<Region> regions = split_into_regions(unit, prior.regions);
    PCP_CHECK(!regions.empty(), "query fitting (pointnet-code): no region of the prior's " << prior.regions.grid
                                    << "^3 grid has " << prior.regions.min_points << " points");
    grid = prior.regions.grid;
    grid_lo = unit.colwise().minCoeff().transpose();
    grid_extent = unit.colwise().maxCoeff().transpose() - grid_lo;
    const nn::PointNet<float>& encoder = prior.encoder();
    region_cond.resize(encoder.shape.cond(), static_cast<Eigen::Index>(regions.size()));
    Eigen::Index most = 1;
    for (const Region& r : regions) most = std::max(most, r.point_ids.size());
    nn::PointNetCache<float> cache(encoder.shape, static_cast<int>(most), false);
    for (std::size_t r = 0; r < regions.size(); ++r) {
        const MatF pts = region_points(unit, regions[r]).transpose();
        nn::pointnet_forward<float>(encoder, pts, cache);
        region_cond.col(static_cast<Eigen::Index>(r)) = cache.f();
    }
    // Every cell -> the region whose cell is nearest (its own when it has one).
    cell_region.assign(static_cast<std::size_t>(grid) * grid * grid, 0);
    for (int id = 0; id < grid * grid * grid; ++id) {
        const Eigen::Vector3i cell(id % grid, (id / grid) % grid, id / (grid * grid));
        int best = 0;
        for (std::size_t r = 1; r < regions.size(); ++r)
            if ((regions[r].cell - cell).squaredNorm() < (regions[static_cast<std::size_t>(best)].cell - cell).squaredNorm())
                best = static_cast<int>(r);
        cell_region[static_cast<std::size_t>(id)] = best;
    }
}

QueryNetFitter::QueryNetFitter(const Eigen::Ref<const Points>& points, const LocalPrior& prior,
                               const QueryFitOptions& options)
    : impl_(std::make_unique<Impl>()) {
    Impl& m = *impl_;
    m.options = options;
    PCP_CHECK(options.queries_per_step >= 1, "query fitting: queries_per_step must be >= 1");
    PCP_CHECK(options.width >= 1 && options.depth >= 1, "query fitting: network sizes must be >= 1");
    check_point_cloud(points, "input cloud", min_points_for(options.sampling));
    m.norm = fit_unit_box(points);
    m.unit = m.norm.to_unit(points);
    {
        const KdTree tree(m.unit);
        const QuerySet set = sample_queries(tree, options.sampling, options.seed);
        m.queries = set.queries.transpose();
        m.targets = set.targets.transpose();
    }
    m.config = stage2_config(options.ablation);
    const int C = prior.decoder().shape.in_b;
    nn::BranchMlp<float> query_net(nn::stage2_query_shape(m.config, C, options.width, options.depth));
    nn::Rng rng(options.seed, 202);
    // Rows 0..2 are the shift only when Q predicts one (not for no-shift, where they are f', nor
    // for direct, where q_l' itself is predicted: see QueryAblation).
    nn::init_query_net(query_net, rng, options.zero_shift_init && m.config.point == nn::QueryPoint::Shift);
    nn::BranchMlp<float> decoder = prior.decoder();
    if (options.ablation == QueryAblation::NoPrior) {
        nn::Rng frng(options.seed, 203);
        nn::init_decoder_geometric(decoder, frng);
    }
    if (options.ablation == QueryAblation::PointNetCode) {
        m.prepare_region_conditions(prior);
        m.cond.resize(C, options.queries_per_step);
    }
    nn::OptimOptions optim;
    optim.lr.lr = options.learning_rate;
    if (options.schedule == LrScheduleKind::Cosine) {
        optim.lr.kind = nn::LrSchedule::Kind::Cosine;
        optim.lr.total_steps = options.steps;
        optim.lr.final_lr = 0.02 * options.learning_rate;
    }
    optim.lr.warmup_steps = options.warmup_steps;
    optim.clip_norm = options.clip_norm;
    m.trainer = std::make_unique<nn::Stage2Trainer<float>>(query_net, decoder, options.queries_per_step, optim, m.config);
    if (options.ablation == QueryAblation::FreeCode) {  // DeepSDF's code initialisation, N(0, 1/C)
        nn::Rng crng(options.seed, 204);
        for (Eigen::Index i = 0; i < m.trainer->code.size(); ++i)
            m.trainer->code(i) = static_cast<float>(crng.normal(0.0, 1.0 / std::sqrt(static_cast<double>(C))));
    }
    {
        std::ostringstream fp;
        fp << "ablation=" << to_string(options.ablation) << " width=" << options.width << " depth=" << options.depth << " batch=" << options.queries_per_step
           << " steps=" << options.steps << " lr=" << options.learning_rate << " schedule=" << static_cast<int>(options.schedule)
           << " warmup=" << options.warmup_steps << " clip=" << options.clip_norm << " seed=" << options.seed
           << " qpp=" << options.sampling.queries_per_point << " spreads=";
        for (float x : options.sampling.spreads) fp << x << ",";
        fp << " uniform=" << options.sampling.uniform_fraction << "/"
           << options.sampling.uniform_margin << " points=" << points.rows() << std::hex
           << " data=" << nn::fnv1a64(m.unit.data(), static_cast<std::size_t>(m.unit.size()) * sizeof(float))
           << " prior=" << nn::fnv1a64(prior.decoder().params.data(), static_cast<std::size_t>(prior.decoder().params.size()) * sizeof(float));
        m.fingerprint = fp.str();
    }
    m.q.resize(3, options.queries_per_step);
    m.t.resize(3, options.queries_per_step);
}

QueryNetFitter::~QueryNetFitter() = default;

std::int64_t QueryNetFitter::steps_done() const { return impl_->trainer->steps; }
const Normalization& QueryNetFitter::normalization() const { return impl_->norm; }
const PointsF& QueryNetFitter::unit_points() const { return impl_->unit; }

double QueryNetFitter::recent_loss() const {
    if (impl_->recent.empty()) return 0.0;
    return std::accumulate(impl_->recent.begin(), impl_->recent.end(), 0.0) / static_cast<double>(impl_->recent.size());
}

double QueryNetFitter::step() {
    Impl& m = *impl_;
    const std::int64_t s = m.trainer->steps;
    Rng rng(m.options.seed ^ 0x5EED0003ull, static_cast<std::uint64_t>(s));
    const auto available = static_cast<std::uint64_t>(m.queries.cols());
    for (int i = 0; i < m.options.queries_per_step; ++i) {
        const auto j = static_cast<Eigen::Index>(rng.below(available));
        m.q.col(i) = m.queries.col(j);
        m.t.col(i) = m.targets.col(j);
    }
    double loss;
    if (m.config.condition == nn::QueryCondition::Given) {
        m.gather_conditions(m.q, m.cond);
        loss = m.trainer->step(m.q, m.t, m.codes, m.cond);
    } else {
        loss = m.trainer->step(m.q, m.t, m.codes);
    }
    PCP_CHECK(std::isfinite(loss), "query fitting: the loss became " << loss << " at step " << s
                                       << "; lower the learning rate or enable gradient clipping");
    m.recent.push_back(loss);
    if (m.recent.size() > 100) m.recent.pop_front();
    return loss;
}

bool QueryNetFitter::run() {
    const Impl& m = *impl_;
    return detail::run_step_loop(*this, {"query-net", m.options.steps, m.options.progress_every, m.options.checkpoint_every,
                                         m.options.checkpoint_path, m.options.progress});
}

void QueryNetFitter::sdf(const Eigen::Ref<const PointsF>& unit_points, Eigen::Ref<Eigen::VectorXf> values) const {
    const Impl& m = *impl_;
    PCP_CHECK(values.size() == unit_points.rows(), "query net sdf: size mismatch");
    const int threads = omp_get_max_threads();
    if (static_cast<int>(m.caches.size()) < threads) {
#pragma omp critical(pcp_sdf_caches)
        while (static_cast<int>(m.caches.size()) < threads)
            m.caches.push_back(std::make_unique<nn::GlobalSdfCache<float>>(m.trainer->query_net.shape,
                                                                             m.trainer->decoder.shape, kEvalBatch));
    }
    const Eigen::Index n = unit_points.rows();
    const Eigen::Index batches = (n + kEvalBatch - 1) / kEvalBatch;
    const MatF none;
    const nn::Stage2Trainer<float>& tr = *m.trainer;
    const Eigen::Map<const MatF> code(tr.code.data(), tr.code.size(), tr.code.size() ? 1 : 0);
    auto run_batch = [&](Eigen::Index b, nn::GlobalSdfCache<float>& cache) {
        const Eigen::Index start = b * kEvalBatch, len = std::min<Eigen::Index>(kEvalBatch, n - start);
        const MatF q = unit_points.middleRows(start, len).transpose();
        if (m.config.condition == nn::QueryCondition::Given) {
            if (cache.cond.cols() < kEvalBatch) cache.cond.resize(m.region_cond.rows(), kEvalBatch);
            m.gather_conditions(q, cache.cond.leftCols(len));
            values.segment(start, len) =
                nn::global_sdf_eval<float>(tr.query_net, tr.decoder, q, none, cache.cond.leftCols(len), m.config, cache).transpose();
        } else {
            values.segment(start, len) = nn::global_sdf_eval<float>(tr.query_net, tr.decoder, q, none, code, m.config, cache).transpose();
        }
    };
    if (omp_in_parallel() || batches == 1) {  // called from a parallel region: stay on this thread
        const int tid = omp_get_thread_num();
        for (Eigen::Index b = 0; b < batches; ++b) run_batch(b, *m.caches[static_cast<std::size_t>(tid)]);
    } else {
#pragma omp parallel for schedule(dynamic, 1)
        for (Eigen::Index b = 0; b < batches; ++b) run_batch(b, *m.caches[static_cast<std::size_t>(omp_get_thread_num())]);
    }
}

// ---- checkpoints ------------------------------------------------------------------------------

namespace {
constexpr const char* kFitCheckpointFormat = "pcp-query-net-checkpoint 1";
}  // namespace

void QueryNetFitter::checkpoint(const std::string& path) const {
    const Impl& m = *impl_;
    nn::NetFile<float> file;
    file.step = static_cast<std::uint64_t>(m.trainer->steps);
    file.metadata = std::string("format=") + kFitCheckpointFormat + "\nfingerprint=" + m.fingerprint + "\n";
    const nn::Stage2Trainer<float>& tr = *m.trainer;
    if (tr.code.size() > 0)
        file.metadata += "code=" + hex_floats(tr.code) + "\ncode_adam_m=" + hex_floats(tr.adam_code.m) +
                         "\ncode_adam_v=" + hex_floats(tr.adam_code.v) + "\ncode_adam_t=" + std::to_string(tr.adam_code.t) + "\n";
    file.nets.push_back(nn::make_record("query_net", tr.query_net, &tr.adam_query));
    if (tr.config.train_decoder) file.nets.push_back(nn::make_record("decoder", tr.decoder, &tr.adam_decoder));
    nn::save_net_file(path, file);
}

void QueryNetFitter::resume(const std::string& path) {
    Impl& m = *impl_;
    const nn::NetFile<float> file = nn::load_net_file<float>(path);
    PCP_CHECK(file.metadata.rfind(std::string("format=") + kFitCheckpointFormat + "\n", 0) == 0,
              path << ": not a query-network checkpoint of this version");
    PCP_CHECK(file.metadata.find("fingerprint=" + m.fingerprint + "\n") != std::string::npos,
              path << ": the checkpoint was written for another input, prior or settings; run without --resume to start again");
    const nn::NetRecord<float>& rec = file.get("query_net");
    PCP_CHECK(rec.has_adam, path << ": the checkpoint holds no optimiser state");
    m.trainer->query_net = nn::to_branch_mlp(rec);
    m.trainer->adam_query = rec.adam;
    if (m.config.train_decoder) {
        const nn::NetRecord<float>& drec = file.get("decoder");
        PCP_CHECK(drec.has_adam, path << ": the checkpoint holds no optimiser state for the decoder");
        m.trainer->decoder = nn::to_branch_mlp(drec);
        m.trainer->adam_decoder = drec.adam;
    }
    if (m.trainer->code.size() > 0) {
        const Eigen::Index C = m.trainer->code.size();
        m.trainer->code = metadata_floats(file.metadata, "code", C, path);
        m.trainer->adam_code.m = metadata_floats(file.metadata, "code_adam_m", C, path);
        m.trainer->adam_code.v = metadata_floats(file.metadata, "code_adam_v", C, path);
        const std::size_t at = file.metadata.find("\ncode_adam_t=");
        PCP_CHECK(at != std::string::npos, path << ": the checkpoint has no 'code_adam_t'");
        m.trainer->adam_code.t = std::strtoll(file.metadata.c_str() + at + 13, nullptr, 10);
    }
    m.trainer->steps = static_cast<std::int64_t>(file.step);
    m.recent.clear();
}

// ---- reconstruct ------------------------------------------------------------------------------

ReconstructOptions ReconstructOptions::preset(const std::string& name) {
    ReconstructOptions o;
    if (name == "paper") {
        o.self_prior = PriorTrainOptions::preset("paper");
        return o;
    }
    if (name == "default") {
        // The fast preset's self-prior and query-network schedule, with a query network twice as
        // wide, twice the steps and the paper's 128 cells. Measured against fast (L2-CD x 100 / NC):
        // abc_00010098 0.055 / 0.678 -> 0.045 / 0.699 (Poisson 0.051 / 0.634), abc_00016513 0.045 /
        // 0.795 -> 0.050 / 0.858, at about 3 x the time; the earlier default (self-prior width 256,
        // 40 epochs; 6000 steps) took 19 min on the bunny for 0.091 against fast's 0.108
        // (docs/BENCHMARKS.md).
        o = preset("fast");
        o.fit.width = 256;
        o.fit.steps = 3000;
        o.resolution = 128;
        return o;
    }
    if (name == "fast") {
        o.self_prior = PriorTrainOptions::preset("fast");
        o.fit.width = 128;
        o.fit.depth = 6;
        o.fit.queries_per_step = 2000;
        o.fit.steps = 1500;
        o.fit.learning_rate = 1e-3;
        o.fit.schedule = LrScheduleKind::Cosine;
        o.fit.warmup_steps = 100;
        // 10 % uniform queries (not in the paper): L2-CD x 100 on the bunny 0.449 -> 0.108,
        // abc_00010074 0.068 -> 0.032 (docs/BENCHMARKS.md).
        o.fit.sampling.uniform_fraction = 0.1f;
        // Denoise noisy clouds (pcp::noise_ratio > 0.25; not in the paper): 3 passes, L2-CD x 100 /
        // NC on abc_00010039 0.067 / 0.589 -> 0.035 / 0.642, abc_00010045 0.41 / 0.66 -> 0.054 /
        // 0.75, noisy bunny 0.028 / 0.75 -> 0.013 / 0.90 (docs/BENCHMARKS.md).
        o.denoise.automatic = true;
        o.resolution = 96;
        return o;
    }
    PCP_FAIL("unknown reconstruction preset '" << name << "' (use paper, default or fast)");
}

bool is_closed_and_oriented(const Mesh& mesh) {
    if (mesh.faces.rows() == 0) return false;
    std::map<std::pair<std::int32_t, std::int32_t>, int> directed;
    for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f)
        for (int e = 0; e < 3; ++e) {
            const std::int32_t a = mesh.faces(f, e), b = mesh.faces(f, (e + 1) % 3);
            if (++directed[{a, b}] > 1) return false;
        }
    for (const auto& [edge, count] : directed)
        if (!directed.count({edge.second, edge.first})) return false;
    return true;
}

namespace {

/// Samples on the faces of `box` (all outside the shape): used to tell outside from inside.
PointsF box_boundary_samples(const Aabb& box, int per_axis) {
    std::vector<Eigen::RowVector3f> s;
    for (int axis = 0; axis < 3; ++axis)
        for (int side = 0; side < 2; ++side)
            for (int i = 0; i < per_axis; ++i)
                for (int j = 0; j < per_axis; ++j) {
                    Eigen::Vector3d p;
                    const int a = (axis + 1) % 3, b = (axis + 2) % 3;
                    p(axis) = side ? box.max(axis) : box.min(axis);
                    p(a) = box.min(a) + (i + 0.5) / per_axis * box.extent()(a);
                    p(b) = box.min(b) + (j + 0.5) / per_axis * box.extent()(b);
                    s.emplace_back(p.cast<float>().transpose());
                }
    PointsF out(static_cast<Eigen::Index>(s.size()), 3);
    for (std::size_t i = 0; i < s.size(); ++i) out.row(static_cast<Eigen::Index>(i)) = s[i];
    return out;
}

ProgressCallback chain(const ProgressCallback& a, const ProgressCallback& b) {
    if (!a) return b;
    if (!b) return a;
    return [a, b](const Progress& p) { return a(p) && b(p); };
}

}  // namespace

Mesh reconstruct(const Eigen::Ref<const Points>& points, const LocalPrior* prior, const ReconstructOptions& options,
                 ReconstructReport* report) {
    ReconstructReport local;
    ReconstructReport& r = report ? *report : local;
    r = ReconstructReport{};
    check_point_cloud(points, "input cloud", min_points_for(options.fit.sampling));
    // Optional denoising (include/pcp/denoise.hpp); everything below works on `cloud`.
    Points denoised;
    if (options.denoise.passes > 0 || options.denoise.automatic) {
        const auto t_denoise = std::chrono::steady_clock::now();
        DenoiseOptions d = options.denoise;
        d.passes = r.denoise_passes = denoise_passes(points, d);
        d.automatic = false;
        if (d.passes > 0) {
            denoised = denoise_points(points, d);
            check_point_cloud(denoised, "denoised input cloud", min_points_for(options.fit.sampling));
        }
        r.seconds_denoise = seconds_since(t_denoise);
    }
    const Eigen::Ref<const Points> cloud = r.denoise_passes > 0 ? Eigen::Ref<const Points>(denoised) : points;

    auto t0 = std::chrono::steady_clock::now();
    LocalPrior self_prior;
    // With checkpoints on, a self-prior is kept beside the query-net checkpoint so that --resume
    // does not train it again.
    const std::string prior_ckpt = options.fit.checkpoint_path.empty() ? "" : options.fit.checkpoint_path + ".prior";
    if (!prior && options.fit.resume && !prior_ckpt.empty() && std::filesystem::exists(prior_ckpt)) {
        self_prior = load_prior(prior_ckpt);
        prior = &self_prior;
    }
    if (!prior && options.fit.ablation == QueryAblation::NoPrior) {  // F's sizes only: no training
        self_prior = LocalPrior(options.self_prior.network, options.self_prior.seed);
        prior = &self_prior;
    }
    if (!prior) {
        PriorTrainOptions po = options.self_prior;
        po.progress = chain(po.progress, options.progress);
        PriorTrainer trainer({TrainingCloud{"input cloud", Points(cloud)}}, po);
        if (!trainer.run()) {
            r.cancelled = true;
            return Mesh{};
        }
        self_prior = trainer.prior();
        prior = &self_prior;
        r.prior_loss = trainer.recent_loss();
        if (!prior_ckpt.empty()) save_prior(prior_ckpt, self_prior);
    }
    r.seconds_prior = seconds_since(t0);

    t0 = std::chrono::steady_clock::now();
    QueryFitOptions fo = options.fit;
    fo.progress = chain(fo.progress, options.progress);
    QueryNetFitter fitter(cloud, *prior, fo);
    if (fo.resume && !fo.checkpoint_path.empty() && std::filesystem::exists(fo.checkpoint_path)) fitter.resume(fo.checkpoint_path);
    if (!fitter.run()) {
        r.cancelled = true;
        return Mesh{};
    }
    r.fit_loss = fitter.recent_loss();
    r.fit_steps = fitter.steps_done();
    r.seconds_fit = seconds_since(t0);

    t0 = std::chrono::steady_clock::now();
    // The grid's precision (ReconstructOptions::fp32_grid), restored when this scope ends.
    struct GridPrecision {
        nn::Precision saved = nn::gemm_precision();
        explicit GridPrecision(bool fp32) {
            if (fp32) nn::set_gemm_precision(nn::Precision::Fp32);
        }
        ~GridPrecision() { nn::set_gemm_precision(saved); }
    } grid_precision(options.fp32_grid);
    const GridSpec spec = make_grid_spec(bounding_box(fitter.unit_points().cast<double>()), options.resolution, options.margin);
    // Outside is positive: decide on the grid box's boundary, which encloses the whole cloud.
    const PointsF boundary = box_boundary_samples(spec.box, 12);
    Eigen::VectorXf bvals(boundary.rows());
    fitter.sdf(boundary, bvals);
    r.sign_flipped = (bvals.array() < static_cast<float>(options.iso)).count() * 2 > bvals.size();
    const float sign = r.sign_flipped ? -1.0f : 1.0f;
    // The grid box is the cloud's box plus a margin, so its faces are outside the shape: the field
    // is clamped to be positive there, which closes any sheet that would leave the box.
    const Eigen::Array3f lo = spec.box.min.cast<float>().array(), hi = spec.box.max.cast<float>().array();
    const Eigen::Array3f tol = (spec.spacing() * 1e-3).cast<float>().array();
    const float outside = static_cast<float>(options.iso + 1e-3 * spec.spacing().minCoeff());
    const SdfBatchFn fitted = [&](const Eigen::Ref<const PointsF>& q, Eigen::Ref<Eigen::VectorXf> v) {
        fitter.sdf(q, v);
        if (sign < 0) v = -v;
        for (Eigen::Index i = 0; i < q.rows(); ++i) {
            const Eigen::Array3f p = q.row(i).transpose().array();
            if (((p - lo).abs() <= tol).any() || ((p - hi).abs() <= tol).any()) v(i) = std::max(v(i), outside);
        }
    };
    // Regions whose sign the data does not support are flipped (include/pcp/sign_repair.hpp); the
    // coarse grid is never finer than the fine one.
    SignRepairOptions so = options.sign_repair;
    so.resolution = std::min(so.resolution, options.resolution);
    const SignRepair repair(fitted, spec.box, fitter.unit_points(), options.iso, so);
    r.sign_repair = repair.stats();
    const SdfBatchFn field = [&](const Eigen::Ref<const PointsF>& q, Eigen::Ref<Eigen::VectorXf> v) {
        fitted(q, v);
        repair.apply(q, v);
    };
    SdfGridOptions go = options.grid;
    go.iso = options.iso;
    go.progress = chain(go.progress, options.progress);
    const SdfGrid grid = go.band == NarrowBand::NearPoints ? evaluate_sdf_grid(field, spec, go, fitter.unit_points())
                                                           : evaluate_sdf_grid(field, spec, go);
    r.sdf_evaluations = grid.stats.evaluations + repair.stats().evaluations;
    r.seconds_grid = seconds_since(t0);

    t0 = std::chrono::steady_clock::now();
    MarchingCubesOptions mo;
    mo.iso = options.iso;
    const Mesh unit_mesh = marching_cubes(grid, mo);
    PCP_CHECK(unit_mesh.faces.rows() > 0, "reconstruction produced an empty mesh: the fitted SDF has no zero crossing "
                                          "in the grid (train longer, or check the input)");
    Mesh mesh = fitter.normalization().from_unit(unit_mesh);
    r.closed = is_closed_and_oriented(mesh);
    r.seconds_mesh = seconds_since(t0);
    std::error_code ignored;
    if (!prior_ckpt.empty()) std::filesystem::remove(prior_ckpt, ignored);
    return mesh;
}

}  // namespace pcp
