// The training scaffold shared by both trainers (see scaffold.hpp and pcp/train/schedule.hpp).
#include "train/scaffold.hpp"

#include <cmath>
#include <cstdlib>
#include <numeric>
#include <sstream>

namespace pcp {

LrScheduleKind parse_lr_schedule(const std::string& name) {
    if (name == "constant") return LrScheduleKind::Constant;
    if (name == "cosine") return LrScheduleKind::Cosine;
    PCP_FAIL("unknown learning-rate schedule '" << name << "' (use constant or cosine)");
}

std::string to_string(LrScheduleKind kind) { return kind == LrScheduleKind::Cosine ? "cosine" : "constant"; }

namespace detail {

nn::OptimOptions make_optim(const TrainingSchedule& s, std::int64_t total_steps) {
    nn::OptimOptions optim;
    optim.lr.lr = s.learning_rate;
    if (s.lr_schedule == LrScheduleKind::Cosine) {
        optim.lr.kind = nn::LrSchedule::Kind::Cosine;
        optim.lr.total_steps = total_steps;
        optim.lr.final_lr = 0.02 * s.learning_rate;
    }
    optim.lr.warmup_steps = s.warmup_steps;
    optim.clip_norm = s.clip_norm;
    return optim;
}

void draw_batch(const MatF& pool_queries, const MatF& pool_targets, Rng rng, Eigen::Ref<MatF> q, Eigen::Ref<MatF> t) {
    const auto available = static_cast<std::uint64_t>(pool_queries.cols());
    for (Eigen::Index i = 0; i < q.cols(); ++i) {
        const auto j = static_cast<Eigen::Index>(rng.below(available));
        q.col(i) = pool_queries.col(j);
        t.col(i) = pool_targets.col(j);
    }
}

void check_loss(double loss, const char* stage, std::int64_t step) {
    PCP_CHECK(std::isfinite(loss), stage << ": the loss became " << loss << " at step " << step
                                         << "; lower the learning rate or enable gradient clipping");
}

void LossWindow::push(double loss) {
    losses_.push_back(loss);
    if (losses_.size() > capacity_) losses_.pop_front();
}

double LossWindow::mean() const {
    if (losses_.empty()) return 0.0;
    return std::accumulate(losses_.begin(), losses_.end(), 0.0) / static_cast<double>(losses_.size());
}

std::string LossWindow::text() const {
    std::ostringstream out;
    out << std::hexfloat;
    for (std::size_t i = 0; i < losses_.size(); ++i) out << (i ? " " : "") << losses_[i];
    return out.str();
}

void LossWindow::restore(const std::string& text, const std::string& source) {
    losses_.clear();
    std::istringstream in(text);
    for (std::string token; in >> token;) {
        char* end = nullptr;
        const double v = std::strtod(token.c_str(), &end);
        PCP_CHECK(end == token.c_str() + token.size() && std::isfinite(v),
                  source << ": bad loss '" << token << "' in the checkpoint (corrupt file?)");
        push(v);
    }
}

nn::Metadata checkpoint_metadata(const CheckpointId& id) {
    nn::Metadata meta;
    meta.add("format", id.format);
    meta.add("fingerprint", id.fingerprint);
    return meta;
}

nn::NetFile<float> load_checkpoint(const std::string& path, const CheckpointId& id, std::int64_t total_steps,
                                   nn::Metadata* metadata) {
    nn::NetFile<float> file = nn::load_net_file<float>(path);
    const nn::Metadata meta(file.metadata, path + ": the checkpoint");
    PCP_CHECK(meta.has("format") && meta.get("format") == id.format, path << ": not a " << id.what << " checkpoint of this version");
    meta.expect("fingerprint", id.fingerprint,
                "it was written for other inputs or settings; run without --resume to start again");
    PCP_CHECK(static_cast<std::int64_t>(file.step) <= total_steps,
              path << ": the checkpoint is past the planned " << total_steps << " steps");
    if (metadata) *metadata = meta;
    return file;
}

}  // namespace detail
}  // namespace pcp
