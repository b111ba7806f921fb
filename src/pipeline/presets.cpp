// The named presets of the pipeline (see ReconstructOptions::preset in pcp/reconstruct.hpp), each a
// few changes to the default (ReconstructOptions{}); the measurements behind every value are in
// docs/NOTEBOOK.md.
#include "pcp/core/error.hpp"
#include "pcp/reconstruct.hpp"

namespace pcp {

ReconstructOptions ReconstructOptions::preset(const std::string& name) {
    ReconstructOptions o;  // the default preset (reconstruct.hpp)
    if (name == "default") return o;
    if (name == "paper") {
        // The paper's method and sizes: a self-prior of the paper's schedule, the query network's
        // 512 x 8 at a constant 1e-4 for about 100,000 steps of 400 queries, no denoising, no
        // winding sign (the repairs and surface passes, not in the paper, stay on).
        o.prior_source = PriorSource::SelfPrior;
        o.prior_tune_steps = 0;
        o.self_prior = PriorTrainOptions::preset("paper");
        o.fit = QueryFitOptions{};
        o.denoise = DenoiseOptions{};
        o.winding_sign.enabled = false;
        return o;
    }
    if (name == "fast") {
        // 2000 steps at 96 cells, denoised by the plane projection (3 passes): about half the
        // default's time on a 20k-point object (the README's main command).
        o.fit.steps = 2000;
        o.resolution = 96;
        o.denoise.mode_width = 0;
        o.denoise.auto_passes = 3;
        return o;
    }
    if (name == "scene") {
        // Rooms (ReconstructOptions::scene): a self-prior, the plane projection's 3 passes, the
        // paper's 512 cells, up to a million points fitted, faces kept only where the data supports
        // them, and none of the passes that assume a closed object (they would close or flip an open
        // room); measured on generated rooms and a fragment of a scanned room (docs/NOTEBOOK.md,
        // "Scenes").
        o.prior_source = PriorSource::SelfPrior;
        o.denoise.mode_width = 0;
        o.denoise.auto_passes = 3;
        o.noisy.recentre = false;
        o.max_fit_points = 1000000;
        o.scene.enabled = true;
        o.resolution = 512;
        o.sign_repair.enabled = false;
        o.cavity_fill.enabled = false;
        o.fine_repair.enabled = false;
        o.tunnel_fill.enabled = false;
        o.through_carve.enabled = false;
        o.winding_sign.enabled = false;
        o.thin_offset = 0;
        return o;
    }
    PCP_FAIL("unknown reconstruction preset '" << name << "' (use paper, default, fast or scene)");
}

bool ReconstructOptions::needs_visibility_labels() const {
    return (sign_repair.enabled && sign_repair.min_label_votes > 0) || (cavity_fill.enabled && cavity_fill.min_label_votes > 0) ||
           (winding_sign.enabled && winding_sign.orient_by_labels && !scene.enabled);
}

}  // namespace pcp
