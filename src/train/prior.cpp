// Stage 1: the local-context-prior trainer (see pcp/prior.hpp). Data preparation per cloud:
// normalise into the unit box, split into regions, normalise each region, sample its query pool
// in region coordinates (sigma_p from the region's own points, as the paper says). The step loop
// draws a region (a seeded shuffle per epoch) and queries_per_step of its queries (seeded per step),
// and calls nn::Stage1Trainer::step with the queries, their targets, and the targets again as the
// PointNet input (paper section 3: "regard their nearest neighbors ... as the input to PointNet").
#include "pcp/train/prior.hpp"

#include "pcp/cloud/kdtree.hpp"
#include "pcp/core/error.hpp"
#include "pcp/core/rng.hpp"
#include "pcp/nn/checkpoint.hpp"
#include "pcp/nn/networks.hpp"
#include "pcp/nn/pull_loss.hpp"
#include "pcp/nn/steps.hpp"
#include "pcp/version.hpp"
#include "train/scaffold.hpp"

#include <algorithm>
#include <numeric>
#include <sstream>

namespace pcp {

using MatF = nn::Mat<float>;

// ---- presets --------------------------------------------------------------------------------

PriorTrainOptions PriorTrainOptions::preset(const std::string& name) {
    PriorTrainOptions o;
    if (name == "paper") {
        o.network.condition = 512;
        return o;
    }
    if (name == "default") {
        o.network.width = 256;
        o.network.condition = 256;
        o.queries_per_step = 2000;
        o.epochs = 40;
        o.schedule.learning_rate = 5e-4;
        o.schedule.lr_schedule = LrScheduleKind::Cosine;
        o.schedule.warmup_steps = 100;
        o.sampling.uniform_fraction = 0.1f;  // see QueryFitOptions presets and docs/NOTEBOOK.md, "Uniform queries against floating blobs"
        return o;
    }
    if (name == "fast") {
        o.network.width = 128;
        o.network.depth = 6;
        o.network.condition = 128;
        o.network.pointnet_width = 256;
        o.network.pointnet_hidden = 256;
        o.sampling.queries_per_point = 20;
        o.queries_per_step = 1000;
        o.epochs = 20;
        o.schedule.learning_rate = 1e-3;
        o.schedule.lr_schedule = LrScheduleKind::Cosine;
        o.schedule.warmup_steps = 50;
        o.sampling.uniform_fraction = 0.1f;
        return o;
    }
    PCP_FAIL("unknown prior preset '" << name << "' (use paper, default or fast)");
}

// ---- LocalPrior ---------------------------------------------------------------------------------

struct LocalPrior::Nets {
    nn::PointNet<float> encoder;
    nn::BranchMlp<float> decoder;
};

LocalPrior::LocalPrior() : nets_(std::make_unique<Nets>()) {}

LocalPrior::LocalPrior(const PriorNetworkOptions& net, std::uint64_t seed) : network(net), nets_(std::make_unique<Nets>()) {
    PCP_CHECK(net.width >= 1 && net.depth >= 1 && net.condition >= 1 && net.pointnet_width >= 1 && net.pointnet_hidden >= 1,
              "prior: network sizes must be >= 1");
    nets_->encoder = nn::PointNet<float>(nn::pointnet_shape(net.condition, net.pointnet_width, net.pointnet_hidden));
    nets_->decoder = nn::BranchMlp<float>(nn::decoder_shape(net.condition, net.width, net.depth));
    nn::Rng rng(seed, 101);
    nn::init_pointnet(nets_->encoder, rng);
    nn::init_decoder_geometric(nets_->decoder, rng);
    provenance.library_version = PCP_VERSION_STRING;
}

LocalPrior::LocalPrior(const LocalPrior& o)
    : network(o.network), regions(o.regions), sampling(o.sampling), provenance(o.provenance),
      nets_(std::make_unique<Nets>(*o.nets_)) {}
LocalPrior::LocalPrior(LocalPrior&&) noexcept = default;
LocalPrior& LocalPrior::operator=(const LocalPrior& o) {
    if (this != &o) *this = LocalPrior(o);
    return *this;
}
LocalPrior& LocalPrior::operator=(LocalPrior&&) noexcept = default;
LocalPrior::~LocalPrior() = default;

const nn::PointNet<float>& LocalPrior::encoder() const { return nets_->encoder; }
const nn::BranchMlp<float>& LocalPrior::decoder() const { return nets_->decoder; }
nn::PointNet<float>& LocalPrior::encoder() { return nets_->encoder; }
nn::BranchMlp<float>& LocalPrior::decoder() { return nets_->decoder; }

Eigen::VectorXf LocalPrior::sdf(const Eigen::Ref<const PointsF>& points, const Eigen::Ref<const PointsF>& context) const {
    PCP_CHECK(context.rows() > 0, "prior: empty context");
    const int m = static_cast<int>(context.rows());
    nn::PointNetCache<float> enc(nets_->encoder.shape, m, false);
    const MatF ctx = context.transpose();
    nn::pointnet_forward<float>(nets_->encoder, ctx, enc);
    const MatF f = enc.f();
    const Eigen::Index n = points.rows();
    Eigen::VectorXf s(n);
    const int batch = 4096;
    nn::BranchMlpCache<float> cache(nets_->decoder.shape, batch, false);
    for (Eigen::Index start = 0; start < n; start += batch) {
        const Eigen::Index len = std::min<Eigen::Index>(batch, n - start);
        const MatF q = points.middleRows(start, len).transpose();
        s.segment(start, len) = nn::decoder_eval<float>(nets_->decoder, q, f, cache).transpose();
    }
    return s;
}

PointsF LocalPrior::pull(const Eigen::Ref<const PointsF>& queries, const Eigen::Ref<const PointsF>& context) const {
    PCP_CHECK(context.rows() > 0, "prior: empty context");
    nn::PointNetCache<float> enc(nets_->encoder.shape, static_cast<int>(context.rows()), false);
    const MatF ctx = context.transpose();
    nn::pointnet_forward<float>(nets_->encoder, ctx, enc);
    const MatF f = enc.f();
    const Eigen::Index n = queries.rows();
    PointsF pulled(n, 3);
    const int batch = 4096;
    nn::BranchMlpCache<float> cache(nets_->decoder.shape, batch, true);
    MatF p(3, batch);
    for (Eigen::Index start = 0; start < n; start += batch) {
        const Eigen::Index len = std::min<Eigen::Index>(batch, n - start);
        const MatF q = queries.middleRows(start, len).transpose();
        nn::branch_mlp_forward<float>(nets_->decoder, q, f, cache);
        nn::decoder_input_grad<float>(nets_->decoder, cache, false);
        nn::pull_points<float>(p.leftCols(len), q, cache.out.leftCols(len), cache.g_a.leftCols(len));
        pulled.middleRows(start, len) = p.leftCols(len).transpose();
    }
    return pulled;
}

// ---- PriorTrainer -------------------------------------------------------------------------------

namespace {

/// One region's training data in region coordinates: 3 x Q queries and their targets.
struct RegionPool {
    std::size_t cloud = 0;
    MatF queries, targets;
};

std::string summarize(const PriorTrainOptions& o) {
    std::ostringstream s;
    s << "grid=" << o.regions.grid << " normalization=" << to_string(o.regions.normalization)
      << " min_region_points=" << o.regions.min_points << " queries_per_point=" << o.sampling.queries_per_point
      << " sigma_neighbor=" << o.sampling.sigma_neighbor << " spreads=";
    for (std::size_t i = 0; i < o.sampling.spreads.size(); ++i) s << (i ? "," : "") << o.sampling.spreads[i];
    s << " uniform=" << o.sampling.uniform_fraction << "/" << o.sampling.uniform_margin << " width=" << o.network.width << " depth=" << o.network.depth << " condition=" << o.network.condition
      << " pointnet=" << o.network.pointnet_width << "/" << o.network.pointnet_hidden
      << " queries_per_step=" << o.queries_per_step << " epochs=" << o.epochs << " max_steps=" << o.max_steps
      << " lr=" << o.schedule.learning_rate << " schedule=" << to_string(o.schedule.lr_schedule)
      << " warmup=" << o.schedule.warmup_steps << " clip=" << o.schedule.clip_norm << " seed=" << o.schedule.seed;
    return s.str();
}

}  // namespace

struct PriorTrainer::Impl {
    PriorTrainOptions options;
    detail::CheckpointId checkpoint_id{"pcp-prior-checkpoint 1", "", "prior-training"};  ///< fingerprint: inputs + settings
    std::vector<std::string> names;
    std::vector<RegionPool> pools;
    std::int64_t total = 0;
    std::unique_ptr<nn::Stage1Trainer<float>> trainer;
    MatF q, t;                       ///< 3 x queries_per_step batch buffers
    std::vector<std::uint32_t> order;  ///< region order of the current epoch
    std::int64_t order_epoch = -1;
    detail::LossWindow recent;       ///< losses of the last min(regions, 100) steps

    void prepare(const std::vector<const PreparedCloud*>& clouds);

    std::size_t region_of_step(std::int64_t step) {
        const auto r = static_cast<std::int64_t>(pools.size());
        const std::int64_t epoch = step / r;
        if (epoch != order_epoch) {  // a seeded shuffle per epoch (Fisher-Yates)
            order.resize(pools.size());
            std::iota(order.begin(), order.end(), 0u);
            Rng rng(options.schedule.seed ^ 0x5EED0001ull, static_cast<std::uint64_t>(epoch));
            for (std::size_t i = order.size(); i > 1; --i) std::swap(order[i - 1], order[rng.below(i)]);
            order_epoch = epoch;
        }
        return order[static_cast<std::size_t>(step % r)];
    }
};

PriorTrainer::PriorTrainer(const std::vector<TrainingCloud>& clouds, const PriorTrainOptions& options)
    : impl_(std::make_unique<Impl>()) {
    impl_->options = options;
    PCP_CHECK(!clouds.empty(), "prior training: no input clouds");
    std::vector<PreparedCloud> prepared;
    prepared.reserve(clouds.size());
    for (const TrainingCloud& cloud : clouds) prepared.emplace_back(cloud.points, cloud.name, min_points_for(options.sampling));
    std::vector<const PreparedCloud*> list;
    for (const PreparedCloud& c : prepared) list.push_back(&c);
    impl_->prepare(list);
}

PriorTrainer::PriorTrainer(const PreparedCloud& cloud, const PriorTrainOptions& options) : impl_(std::make_unique<Impl>()) {
    impl_->options = options;
    impl_->prepare({&cloud});
}

/// Splits every (unit-box) cloud into regions, samples each region's query pool in region
/// coordinates, fingerprints inputs and settings, and builds the networks and the optimiser.
void PriorTrainer::Impl::prepare(const std::vector<const PreparedCloud*>& clouds) {
    const TrainingSchedule& sched = options.schedule;
    PCP_CHECK(options.queries_per_step >= 1, "prior training: queries_per_step must be >= 1");
    PCP_CHECK(options.epochs >= 1 || options.max_steps > 0, "prior training: epochs or max_steps must be >= 1");
    PCP_CHECK(options.regions.min_points >= min_points_for(options.sampling),
              "prior training: regions need at least " << min_points_for(options.sampling)
                                                      << " points for the query spread (min_points)");
    if (options.start) {  // fine-tuning: the start prior's networks on its own regions
        options.network = options.start->network;
        options.regions = options.start->regions;
    }
    std::ostringstream fp;
    fp << summarize(options);
    if (options.start)
        fp << " | start: " << options.start->provenance.settings << " (" << options.start->provenance.steps << " steps, loss "
           << options.start->provenance.final_loss << ")";
    std::vector<std::vector<Region>> all_regions;
    for (std::size_t c = 0; c < clouds.size(); ++c) {
        const PreparedCloud& cloud = *clouds[c];
        PCP_CHECK(cloud.size() >= min_points_for(options.sampling),
                  cloud.name() << ": " << cloud.size() << " points; the query spread needs at least " << min_points_for(options.sampling));
        names.push_back(cloud.name());
        fp << " | " << cloud.name() << " (" << cloud.size() << " points, data " << std::hex << cloud.input_hash() << std::dec << ")";
        std::vector<Region> regions = split_into_regions(cloud.unit(), options.regions);
        all_regions.push_back(std::move(regions));
    }
    std::size_t region_count = 0;
    for (const auto& regions : all_regions) region_count += regions.size();
    PCP_CHECK(region_count > 0, "prior training: no region of any input has at least " << options.regions.min_points
                                  << " points (a " << options.regions.grid << "^3 grid); use a coarser grid or denser clouds");
    // Each region's pool holds at most the queries its steps draw (SamplingOptions::max_queries):
    // the steps visit the regions in turn, so each region gets ceil(total / regions) of them.
    const auto n_regions = static_cast<std::int64_t>(region_count);
    total = options.max_steps > 0 ? options.max_steps : static_cast<std::int64_t>(options.epochs) * n_regions;
    const SamplingOptions sampling = capped_at_draws(options.sampling, (total + n_regions - 1) / n_regions * options.queries_per_step);
    for (std::size_t c = 0; c < clouds.size(); ++c) {
        const PreparedCloud& cloud = *clouds[c];
        const std::vector<Region>& regions = all_regions[c];
        for (std::size_t r = 0; r < regions.size(); ++r) {
            // Each region's own points in region coordinates: sigma_p and the targets come from
            // the region alone (paper section 3), so each region has its own small tree.
            const KdTree tree(region_points(cloud.unit(), regions[r]));
            const std::uint64_t stream_seed = sched.seed * 0x9E3779B97F4A7C15ull + (c << 20) + r;
            const QuerySet set = sample_queries(tree, sampling, stream_seed);
            RegionPool pool;
            pool.cloud = c;
            pool.queries = set.queries.transpose();
            pool.targets = set.targets.transpose();
            pools.push_back(std::move(pool));
        }
    }
    checkpoint_id.fingerprint = fp.str();
    recent = detail::LossWindow(static_cast<std::size_t>(std::min<std::int64_t>(n_regions, 100)));

    const LocalPrior init = options.start ? *options.start : LocalPrior(options.network, sched.seed);
    const int qn = options.queries_per_step;
    trainer = std::make_unique<nn::Stage1Trainer<float>>(init.encoder(), init.decoder(), qn, qn, detail::make_optim(sched, total));
    q.resize(3, qn);
    t.resize(3, qn);
}

PriorTrainer::~PriorTrainer() = default;

std::int64_t PriorTrainer::steps_done() const { return impl_->trainer->steps; }
std::int64_t PriorTrainer::total_steps() const { return impl_->total; }
std::size_t PriorTrainer::num_regions() const { return impl_->pools.size(); }
std::int64_t PriorTrainer::pool_size() const {
    std::int64_t n = 0;
    for (const RegionPool& pool : impl_->pools) n += pool.queries.cols();
    return n;
}

double PriorTrainer::recent_loss() const { return impl_->recent.mean(); }

double PriorTrainer::step() {
    Impl& m = *impl_;
    const std::int64_t s = m.trainer->steps;
    const RegionPool& pool = m.pools[m.region_of_step(s)];
    detail::draw_batch(pool.queries, pool.targets, Rng(m.options.schedule.seed ^ 0x5EED0002ull, static_cast<std::uint64_t>(s)), m.q, m.t);
    const double loss = m.trainer->step(m.q, m.t, m.t);
    detail::check_loss(loss, "prior training", s);
    m.recent.push(loss);
    return loss;
}

void PriorTrainer::checkpoint(const std::string& path) const {
    const Impl& m = *impl_;
    nn::NetFile<float> file;
    file.step = static_cast<std::uint64_t>(m.trainer->steps);
    nn::Metadata meta = detail::checkpoint_metadata(m.checkpoint_id);
    meta.add("recent_losses", m.recent.text());
    file.metadata = meta.text();
    file.nets.push_back(nn::make_record("encoder", m.trainer->encoder, &m.trainer->adam_encoder));
    file.nets.push_back(nn::make_record("decoder", m.trainer->decoder, &m.trainer->adam_decoder));
    nn::save_net_file(path, file);
}

void PriorTrainer::resume(const std::string& path) {
    Impl& m = *impl_;
    nn::Metadata meta;
    const nn::NetFile<float> file = detail::load_checkpoint(path, m.checkpoint_id, m.total, &meta);
    const nn::NetRecord<float>& enc = file.get("encoder");
    const nn::NetRecord<float>& dec = file.get("decoder");
    PCP_CHECK(enc.has_adam && dec.has_adam, path << ": the checkpoint holds no optimiser state");
    m.trainer->encoder = nn::to_pointnet(enc);
    m.trainer->decoder = nn::to_branch_mlp(dec);
    m.trainer->adam_encoder = enc.adam;
    m.trainer->adam_decoder = dec.adam;
    m.trainer->steps = static_cast<std::int64_t>(file.step);
    m.recent.restore(meta.has("recent_losses") ? meta.get("recent_losses") : "", path);
}

bool PriorTrainer::run() { return detail::run_step_loop(*this, "prior", impl_->total, impl_->options.schedule); }

LocalPrior PriorTrainer::prior() const {
    const Impl& m = *impl_;
    LocalPrior p(m.options.network, m.options.schedule.seed);
    p.encoder() = m.trainer->encoder;
    p.decoder() = m.trainer->decoder;
    p.regions = m.options.regions;
    p.sampling = m.options.sampling;
    p.provenance.inputs = m.names;
    p.provenance.settings = summarize(m.options);
    p.provenance.steps = steps_done();
    p.provenance.final_loss = recent_loss();
    return p;
}

LocalPrior train_prior(const std::vector<TrainingCloud>& clouds, const PriorTrainOptions& options) {
    PriorTrainer trainer(clouds, options);
    trainer.run();
    return trainer.prior();
}

}  // namespace pcp
