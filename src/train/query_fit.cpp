// Stage 2: the query-network fitter (see pcp/train/query_fit.hpp). The fitter samples the global
// query pool once (seeded) around the prepared cloud, then each step draws queries_per_step of them
// (seeded per step) and calls nn::Stage2Trainer::step. The SDF for meshing is F_g evaluated by
// nn::global_sdf_eval with one cache per OpenMP thread. The ablations (QueryAblation) choose the
// nn::Stage2Config; the pointnet-code one also keeps the per-region conditions and the
// cell -> region table here. Optimiser, batch draw, loss window, checkpoint header and the step
// loop come from the training scaffold (train/scaffold.hpp).
#include "pcp/train/query_fit.hpp"

#include "pcp/cloud/regions.hpp"
#include "pcp/core/error.hpp"
#include "pcp/core/rng.hpp"
#include "pcp/nn/checkpoint.hpp"
#include "pcp/nn/networks.hpp"
#include "pcp/nn/steps.hpp"
#include "train/scaffold.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <omp.h>

namespace pcp {

using MatF = nn::Mat<float>;

namespace {
// Rows per network evaluation in sdf(): 512, the grid's batch (SdfGridOptions::batch_size), at which
// the activations stay in the core's cache (4096 was 25-30 % slower).
constexpr int kEvalBatch = 512;

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
    const PreparedCloud* cloud = nullptr;  ///< the first cloud
    // Several clouds (one-hot codes): the clouds, and where each one's queries start in the pool
    // (pool_start[k] .. pool_start[k + 1] - 1). One cloud: no codes, pool_start = {0, M}.
    std::vector<const PreparedCloud*> clouds;
    std::vector<Eigen::Index> pool_start;
    int num_codes = 0;      ///< K, Q's code inputs: 0 for one cloud
    detail::CheckpointId checkpoint_id{"pcp-query-net-checkpoint 1", "", "query-network"};  ///< fingerprint: input + prior + settings
    MatF queries, targets;  ///< 3 x M pool
    std::unique_ptr<nn::Stage2Trainer<float>> trainer;
    MatF q, t, codes;       ///< batch buffers; codes: K x batch one-hot, 0 x 0 for one cloud
    detail::LossWindow recent{100};
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
    void init(const std::vector<const PreparedCloud*>& clouds, const LocalPrior& prior, const QueryFitOptions& options);
};

void QueryNetFitter::Impl::prepare_region_conditions(const LocalPrior& prior) {
    const PointsF& unit = cloud->unit();
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

QueryNetFitter::QueryNetFitter(const PreparedCloud& cloud, const LocalPrior& prior, const QueryFitOptions& options)
    : impl_(std::make_unique<Impl>()) {
    impl_->init({&cloud}, prior, options);
}

QueryNetFitter::QueryNetFitter(const std::vector<const PreparedCloud*>& clouds, const LocalPrior& prior,
                               const QueryFitOptions& options)
    : impl_(std::make_unique<Impl>()) {
    impl_->init(clouds, prior, options);
}

void QueryNetFitter::Impl::init(const std::vector<const PreparedCloud*>& clouds_in, const LocalPrior& prior,
                                const QueryFitOptions& options_in) {
    Impl& m = *this;
    m.options = options_in;
    const QueryFitOptions& opts = m.options;
    PCP_CHECK(!clouds_in.empty(), "query fitting: no cloud given");
    for (const PreparedCloud* c : clouds_in) PCP_CHECK(c != nullptr, "query fitting: a null cloud");
    m.clouds = clouds_in;
    m.cloud = clouds_in.front();
    const PreparedCloud& first = *m.cloud;
    const int K = static_cast<int>(clouds_in.size());
    m.num_codes = K > 1 ? K : 0;
    const TrainingSchedule& sched = opts.schedule;
    PCP_CHECK(opts.queries_per_step >= 1, "query fitting: queries_per_step must be >= 1");
    PCP_CHECK(opts.batch_parts >= 0, "query fitting: batch_parts must be >= 0 (0 = one per thread)");
    PCP_CHECK(opts.width >= 1 && opts.depth >= 1, "query fitting: network sizes must be >= 1");
    PCP_CHECK(K == 1 || opts.ablation == QueryAblation::None,
              "query fitting of " << K << " clouds with one-hot codes: only the method itself (ablation none)");
    for (const PreparedCloud* c : clouds_in)
        PCP_CHECK(c->size() >= min_points_for(opts.sampling),
                  c->name() << ": " << c->size() << " points; the query spread needs at least " << min_points_for(opts.sampling));
    {
        // The pool holds at most the queries the fit draws (SamplingOptions::max_queries); with
        // several clouds each holds at most its equal share of them.
        const std::int64_t draws = std::max<std::int64_t>(opts.steps, 1) * opts.queries_per_step;
        std::vector<QuerySet> sets;
        Eigen::Index total = 0;
        m.pool_start.assign(1, 0);
        for (int k = 0; k < K; ++k) {
            const std::int64_t share = (draws + K - 1) / K;
            // Cloud 0 keeps the single-cloud seed, so that one cloud is exactly the single-cloud fit.
            const std::uint64_t seed = sched.seed + 0x9E3779B97F4A7C15ull * static_cast<std::uint64_t>(k);
            sets.push_back(sample_queries(clouds_in[static_cast<std::size_t>(k)]->tree(),
                                          capped_at_draws(opts.sampling, share), seed));
            total += sets.back().queries.rows();
            m.pool_start.push_back(total);
        }
        if (K == 1) {
            m.queries = sets[0].queries.transpose();
            m.targets = sets[0].targets.transpose();
        } else {
            m.queries.resize(3, total);
            m.targets.resize(3, total);
            for (int k = 0; k < K; ++k) {
                const Eigen::Index n = m.pool_start[static_cast<std::size_t>(k) + 1] - m.pool_start[static_cast<std::size_t>(k)];
                m.queries.middleCols(m.pool_start[static_cast<std::size_t>(k)], n) = sets[static_cast<std::size_t>(k)].queries.transpose();
                m.targets.middleCols(m.pool_start[static_cast<std::size_t>(k)], n) = sets[static_cast<std::size_t>(k)].targets.transpose();
            }
        }
    }
    m.config = stage2_config(opts.ablation);
    const int C = prior.decoder().shape.in_b;
    nn::BranchMlp<float> query_net(nn::stage2_query_shape(m.config, C, opts.width, opts.depth, m.num_codes));
    nn::Rng rng(sched.seed, 202);
    // Rows 0..2 are the shift only when Q predicts one (not for no-shift, where they are f', nor
    // for direct, where q_l' itself is predicted: see QueryAblation).
    nn::init_query_net(query_net, rng, opts.zero_shift_init && m.config.point == nn::QueryPoint::Shift);
    nn::BranchMlp<float> decoder = prior.decoder();
    if (opts.ablation == QueryAblation::NoPrior) {
        nn::Rng frng(sched.seed, 203);
        nn::init_decoder_geometric(decoder, frng);
    }
    if (opts.ablation == QueryAblation::PointNetCode) {
        m.prepare_region_conditions(prior);
        m.cond.resize(C, opts.queries_per_step);
    }
    m.trainer = std::make_unique<nn::Stage2Trainer<float>>(query_net, decoder, opts.queries_per_step,
                                                           detail::make_optim(sched, opts.steps), m.config);
    m.trainer->batch_parts = opts.batch_parts;
    if (opts.ablation == QueryAblation::FreeCode) {  // DeepSDF's code initialisation, N(0, 1/C)
        nn::Rng crng(sched.seed, 204);
        for (Eigen::Index i = 0; i < m.trainer->code.size(); ++i)
            m.trainer->code(i) = static_cast<float>(crng.normal(0.0, 1.0 / std::sqrt(static_cast<double>(C))));
    }
    {
        std::ostringstream fp;
        fp << "ablation=" << to_string(opts.ablation) << " width=" << opts.width << " depth=" << opts.depth << " batch=" << opts.queries_per_step
           << " steps=" << opts.steps << " lr=" << sched.learning_rate << " schedule=" << static_cast<int>(sched.lr_schedule)
           << " warmup=" << sched.warmup_steps << " clip=" << sched.clip_norm << " seed=" << sched.seed
           << " qpp=" << opts.sampling.queries_per_point << " spreads=";
        for (float x : opts.sampling.spreads) fp << x << ",";
        fp << " uniform=" << opts.sampling.uniform_fraction << "/"
           << opts.sampling.uniform_margin << " points=" << first.size();
        if (K > 1) {
            fp << " clouds=" << K << " points=";
            for (const PreparedCloud* c : clouds_in) fp << c->size() << ",";
        }
        fp << std::hex
           << " data=" << nn::fnv1a64(first.unit().data(), static_cast<std::size_t>(first.unit().size()) * sizeof(float));
        for (int k = 1; k < K; ++k) {
            const PointsF& u = clouds_in[static_cast<std::size_t>(k)]->unit();
            fp << "," << nn::fnv1a64(u.data(), static_cast<std::size_t>(u.size()) * sizeof(float));
        }
        fp
           << " prior=" << nn::fnv1a64(prior.decoder().params.data(), static_cast<std::size_t>(prior.decoder().params.size()) * sizeof(float));
        m.checkpoint_id.fingerprint = fp.str();
    }
    m.q.resize(3, opts.queries_per_step);
    m.t.setZero(3, opts.queries_per_step);
    if (K > 1) m.codes.setZero(K, opts.queries_per_step);
}

QueryNetFitter::~QueryNetFitter() = default;

std::int64_t QueryNetFitter::steps_done() const { return impl_->trainer->steps; }
const PreparedCloud& QueryNetFitter::cloud() const { return *impl_->cloud; }
const PreparedCloud& QueryNetFitter::cloud(int index) const {
    PCP_CHECK(index >= 0 && index < num_clouds(), "query fitting: no cloud " << index << " (" << num_clouds() << " fitted)");
    return *impl_->clouds[static_cast<std::size_t>(index)];
}
int QueryNetFitter::num_clouds() const { return static_cast<int>(impl_->clouds.size()); }
double QueryNetFitter::recent_loss() const { return impl_->recent.mean(); }
std::int64_t QueryNetFitter::pool_size() const { return impl_->queries.cols(); }

double QueryNetFitter::step() {
    Impl& m = *impl_;
    const std::int64_t s = m.trainer->steps;
    const Eigen::Index batch = m.options.queries_per_step;
    if (m.num_codes == 0) {
        detail::draw_batch(m.queries, m.targets, Rng(m.options.schedule.seed ^ 0x5EED0003ull, static_cast<std::uint64_t>(s)),
                           m.q.leftCols(batch), m.t.leftCols(batch));
    } else {  // a cloud per query in equal shares, then one of its queries; its one-hot code
        Rng rng(m.options.schedule.seed ^ 0x5EED0003ull, static_cast<std::uint64_t>(s));
        m.codes.setZero();
        for (Eigen::Index c = 0; c < batch; ++c) {
            const auto k = static_cast<std::size_t>(rng.below(static_cast<std::uint64_t>(m.num_codes)));
            const Eigen::Index j = m.pool_start[k] + static_cast<Eigen::Index>(rng.below(
                                                         static_cast<std::uint64_t>(m.pool_start[k + 1] - m.pool_start[k])));
            m.q.col(c) = m.queries.col(j);
            m.t.col(c) = m.targets.col(j);
            m.codes(static_cast<Eigen::Index>(k), c) = 1.0f;
        }
    }
    double loss;
    if (m.config.condition == nn::QueryCondition::Given) {
        m.gather_conditions(m.q, m.cond);
        loss = m.trainer->step(m.q, m.t, m.codes, m.cond);
    } else {
        loss = m.trainer->step(m.q, m.t, m.codes);
    }
    detail::check_loss(loss, "query fitting", s);
    m.recent.push(loss);
    return loss;
}

bool QueryNetFitter::run() {
    const Impl& m = *impl_;
    return detail::run_step_loop(*this, "query-net", m.options.steps, m.options.schedule);
}


void QueryNetFitter::sdf(const Eigen::Ref<const PointsF>& unit_points, Eigen::Ref<Eigen::VectorXf> values) const {
    PCP_CHECK(num_clouds() == 1, "query net sdf: " << num_clouds() << " clouds were fitted; say which one");
    sdf(0, unit_points, values);
}

void QueryNetFitter::sdf(int index, const Eigen::Ref<const PointsF>& unit_points, Eigen::Ref<Eigen::VectorXf> values) const {
    const Impl& m = *impl_;
    PCP_CHECK(values.size() == unit_points.rows(), "query net sdf: size mismatch");
    PCP_CHECK(index >= 0 && index < num_clouds(), "query net sdf: no cloud " << index << " (" << num_clouds() << " fitted)");
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
    // N x 3 row-major rows are the 3 x N columns the networks take: mapped, unless strided.
    const bool contiguous = unit_points.outerStride() == 3;
    auto run_batch = [&](Eigen::Index b, nn::GlobalSdfCache<float>& cache) {
        const Eigen::Index start = b * kEvalBatch, len = std::min<Eigen::Index>(kEvalBatch, n - start);
        MatF copy;
        if (!contiguous) copy = unit_points.middleRows(start, len).transpose();
        const Eigen::Map<const MatF> q(contiguous ? unit_points.data() + 3 * start : copy.data(), 3, len);
        if (m.num_codes > 0) {  // cloud `index`'s one-hot code
            MatF codes = MatF::Zero(m.num_codes, len);
            codes.row(index).setOnes();
            values.segment(start, len) = nn::global_sdf_eval<float>(tr.query_net, tr.decoder, q, codes, code, m.config, cache).transpose();
        } else if (m.config.condition == nn::QueryCondition::Given) {
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

void QueryNetFitter::checkpoint(const std::string& path) const {
    const Impl& m = *impl_;
    nn::NetFile<float> file;
    file.step = static_cast<std::uint64_t>(m.trainer->steps);
    nn::Metadata meta = detail::checkpoint_metadata(m.checkpoint_id);
    const nn::Stage2Trainer<float>& tr = *m.trainer;
    if (tr.code.size() > 0) {
        meta.add_floats("code", tr.code);
        meta.add_floats("code_adam_m", tr.adam_code.m);
        meta.add_floats("code_adam_v", tr.adam_code.v);
        meta.add_number("code_adam_t", tr.adam_code.t);
    }
    meta.add("recent_losses", m.recent.text());
    file.metadata = meta.text();
    file.nets.push_back(nn::make_record("query_net", tr.query_net, &tr.adam_query));
    if (tr.config.train_decoder) file.nets.push_back(nn::make_record("decoder", tr.decoder, &tr.adam_decoder));
    nn::save_net_file(path, file);
}

void QueryNetFitter::resume(const std::string& path) {
    Impl& m = *impl_;
    nn::Metadata meta;
    const nn::NetFile<float> file = detail::load_checkpoint(path, m.checkpoint_id, m.options.steps, &meta);
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
        m.trainer->code = meta.floats("code", C);
        m.trainer->adam_code.m = meta.floats("code_adam_m", C);
        m.trainer->adam_code.v = meta.floats("code_adam_v", C);
        m.trainer->adam_code.t = meta.number<std::int64_t>("code_adam_t");
    }
    m.trainer->steps = static_cast<std::int64_t>(file.step);
    m.recent.restore(meta.has("recent_losses") ? meta.get("recent_losses") : "", path);
}

}  // namespace pcp
