// The settings table and the validator (see pcp/settings.hpp).
#include "pcp/settings.hpp"

#include "pcp/cloud/regions.hpp"
#include "pcp/cloud/sampling.hpp"
#include "pcp/core/error.hpp"

#include <cmath>
#include <cstdio>
#include <sstream>
#include <type_traits>
#include <utility>

namespace pcp {

namespace {

std::string text(double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.6g", v);
    return buf;
}

[[noreturn]] void refuse(const std::string& name, const std::string& range, const std::string& value) {
    PCP_FAIL(name << " must be " << range << " (got '" << value << "')");
}

/// `value` as a T (an integer or a finite real), the whole text; refused with `range` otherwise.
template <class T>
T parse_number(const std::string& name, const std::string& range, const std::string& value) {
    std::size_t used = 0;
    try {
        if constexpr (std::is_integral_v<T>) {
            const long long v = std::stoll(value, &used);
            if (used == value.size()) return static_cast<T>(v);
        } else {
            const double v = std::stod(value, &used);
            if (used == value.size() && std::isfinite(v)) return static_cast<T>(v);
        }
    } catch (const std::exception&) {
    }
    refuse(name, range, value);
}

/// A number stored at field(options) (field: a generic lambda returning a reference), valid where
/// `ok` says so.
template <class Field, class Ok>
Setting number(const char* name, const char* group, const char* help, Field field, const char* range, Ok ok, bool listed = false) {
    Setting s{name, group, help, range, listed, {}, {}, {}};
    using T = std::decay_t<decltype(field(std::declval<ReconstructOptions&>()))>;
    s.get = [field](const ReconstructOptions& o) {
        if constexpr (std::is_integral_v<T>) return std::to_string(field(o));
        else return text(static_cast<double>(field(o)));
    };
    s.set = [field, name, range](ReconstructOptions& o, const std::string& v) { field(o) = parse_number<T>(name, range, v); };
    s.valid = [field, ok](const ReconstructOptions& o) { return ok(field(o)); };
    return s;
}

/// One of `names`, stored through `to` / read through `from`.
Setting choice(const char* name, const char* group, const char* help, const char* range, std::function<std::string(const ReconstructOptions&)> get,
               std::function<bool(ReconstructOptions&, const std::string&)> put, bool listed = false) {
    Setting s{name, group, help, range, listed, std::move(get), {}, {}};
    s.set = [put, name, range](ReconstructOptions& o, const std::string& v) {
        if (!put(o, v)) refuse(name, range, v);
    };
    s.valid = [](const ReconstructOptions&) { return true; };
    return s;
}

/// on | off, stored at field(options).
template <class Field>
Setting on_off(const char* name, const char* group, const char* help, Field field, bool listed = false) {
    return choice(name, group, help, "on or off", [field](const ReconstructOptions& o) { return field(o) ? "on" : "off"; },
                  [field](ReconstructOptions& o, const std::string& v) {
                      if (v != "on" && v != "off") return false;
                      field(o) = v == "on";
                      return true;
                  },
                  listed);
}

/// auto | on | off for a pass whose default differs for the clouds the pipeline denoised: on and
/// off set both (clean: field, noisy: noisy_field); auto keeps the preset's.
template <class Field, class NoisyField>
Setting auto_on_off(const char* name, const char* group, const char* help, Field field, NoisyField noisy_field) {
    return choice(name, group, help, "auto, on or off",
                  [field, noisy_field](const ReconstructOptions& o) {
                      return field(o) != noisy_field(o) ? std::string("auto") : field(o) ? "on" : "off";
                  },
                  [field, noisy_field](ReconstructOptions& o, const std::string& v) {
                      if (v != "auto" && v != "on" && v != "off") return false;
                      if (v != "auto") field(o) = noisy_field(o) = v == "on";
                      return true;
                  },
                  true);
}

#define PCP_FIELD(expr) [](auto& o) -> auto& { return o.expr; }

std::vector<Setting> make_settings() {
    const auto at_least = [](double lo) { return [lo](auto x) { return static_cast<double>(x) >= lo; }; };
    const auto within = [](double lo, double hi) { return [lo, hi](auto x) { return static_cast<double>(x) >= lo && static_cast<double>(x) <= hi; }; };
    std::vector<Setting> s;
    // ---- prior (stage 1)
    s.push_back(choice("prior-source", "Prior (stage 1)",
                       "Without --prior: the built-in generic prior (fine-tuned on the input for prior-tune-steps), a self-prior "
                       "learned on the input first, or (auto) the built-in one for clean clouds and a self-prior for noisy ones",
                       "auto, builtin or self",
                       [](const ReconstructOptions& o) {
                           return o.prior_source == PriorSource::Builtin ? "builtin" : o.prior_source == PriorSource::SelfPrior ? "self" : "auto";
                       },
                       [](ReconstructOptions& o, const std::string& v) {
                           if (v == "auto") o.prior_source = PriorSource::Auto;
                           else if (v == "builtin") o.prior_source = PriorSource::Builtin;
                           else if (v == "self") o.prior_source = PriorSource::SelfPrior;
                           else return false;
                           return true;
                       },
                       true));
    s.push_back(number("prior-tune-steps", "Prior (stage 1)", "Fine-tune the built-in prior on the input for this many steps first (0: frozen)",
                       PCP_FIELD(prior_tune_steps), ">= 0", at_least(0), true));
    // The self-prior's own settings (set_option makes the prior source self when one is given).
    s.push_back(number("prior-epochs", "Prior (stage 1)", "Self-prior epochs (passes over the input's regions)", PCP_FIELD(self_prior.epochs),
                       ">= 1", at_least(1)));
    s.push_back(number("prior-steps", "Prior (stage 1)", "Stop the self-prior after this many steps instead (0: epochs x regions)",
                       PCP_FIELD(self_prior.max_steps), ">= 0", at_least(0)));
    s.push_back(number("prior-grid", "Prior (stage 1)", "Self-prior region grid: cells per axis (1: no split, the paper's 0^3)",
                       PCP_FIELD(self_prior.regions.grid), "in [1, 64]", within(1, 64)));
    s.push_back(choice("prior-normalization", "Prior (stage 1)", "Self-prior per-region normalisation", "none, center, scale or both",
                       [](const ReconstructOptions& o) { return to_string(o.self_prior.regions.normalization); },
                       [](ReconstructOptions& o, const std::string& v) {
                           if (v != "none" && v != "center" && v != "scale" && v != "both") return false;
                           o.self_prior.regions.normalization = parse_region_normalization(v);
                           return true;
                       }));
    // ---- input
    {
        Setting d{"denoise", "Input",
                  "Denoise the input first: passes of moving each point onto its neighbours' plane or its own side's mode "
                  "(0: off), or auto (when the cloud is noisy)",
                  "auto or a number of passes in [0, 100]", true, {}, {}, {}};
        d.get = [](const ReconstructOptions& o) { return o.denoise.automatic ? std::string("auto") : std::to_string(o.denoise.passes); };
        d.set = [range = d.range](ReconstructOptions& o, const std::string& v) {
            o.denoise.automatic = v == "auto";
            if (!o.denoise.automatic) o.denoise.passes = parse_number<int>("denoise", range, v);
        };
        d.valid = [](const ReconstructOptions& o) { return o.denoise.passes >= 0 && o.denoise.passes <= 100; };
        s.push_back(d);
    }
    s.push_back(number("denoise-neighbors", "Input", "Neighbours per plane fit of the denoiser", PCP_FIELD(denoise.neighbors), "in [3, 256]",
                       within(3, 256)));
    s.push_back(number("denoise-mode-width", "Input",
                       "0: the denoiser projects onto the plane; W > 0: moves each point to the mode of its neighbours' heights "
                       "nearest its own (kernel W x the noise), keeping the two sides of a thin part apart",
                       PCP_FIELD(denoise.mode_width), ">= 0", at_least(0)));
    s.push_back(number("max-points", "Input",
                       "Fit inputs of more points on a uniform random subsample of this many (0: all; the mesh and the normals "
                       "still cover every point)",
                       PCP_FIELD(max_fit_points), "0 or at least the query spread's neighbours + 1", [](auto) { return true; }, true));
    // ---- queries (both stages)
    {
        Setting q{"spreads", "Queries", "Query spreads in units of sigma_p, comma-separated (query j of a point uses spread j mod count)",
                  "positive numbers, comma-separated", false, {}, {}, {}};
        q.get = [](const ReconstructOptions& o) {
            std::string out;
            for (float x : o.fit.sampling.spreads) out += (out.empty() ? "" : ",") + text(x);
            return out;
        };
        q.set = [range = q.range](ReconstructOptions& o, const std::string& v) {
            std::vector<float> spreads;
            std::stringstream in(v);
            std::string item;
            while (std::getline(in, item, ',')) spreads.push_back(parse_number<float>("spreads", range, item));
            o.fit.sampling.spreads = o.self_prior.sampling.spreads = spreads;
        };
        q.valid = [](const ReconstructOptions& o) {
            for (float x : o.fit.sampling.spreads)
                if (!(x > 0)) return false;
            return !o.fit.sampling.spreads.empty();
        };
        s.push_back(q);
    }
    {
        Setting u = number("uniform-fraction", "Queries", "Extra queries drawn uniformly in the grown bounding box, as a fraction of the others (0: the paper)",
                           PCP_FIELD(fit.sampling.uniform_fraction), "in [0, 10]", within(0, 10));
        const auto set_fit = u.set;
        u.set = [set_fit](ReconstructOptions& o, const std::string& v) {
            set_fit(o, v);
            o.self_prior.sampling.uniform_fraction = o.fit.sampling.uniform_fraction;
        };
        s.push_back(u);
    }
    // ---- query network (stage 2)
    s.push_back(number("steps", "Query network (stage 2)", "Query-network steps", PCP_FIELD(fit.steps), ">= 1", at_least(1), true));
    s.push_back(number("batch", "Query network (stage 2)", "Queries per step", PCP_FIELD(fit.queries_per_step), ">= 1", at_least(1), true));
    s.push_back(number("batch-parts", "Query network (stage 2)",
                       "Split each step's batch into this many parts, one thread each (0: one per thread; 1: the whole batch); speed only",
                       PCP_FIELD(fit.batch_parts), ">= 0", at_least(0)));
    s.push_back(number("lr", "Query network (stage 2)", "Peak learning rate", PCP_FIELD(fit.schedule.learning_rate), "> 0",
                       [](double x) { return x > 0; }, true));
    s.push_back(number("width", "Query network (stage 2)", "Query-network width", PCP_FIELD(fit.width), ">= 1", at_least(1), true));
    s.push_back(number("depth", "Query network (stage 2)", "Query-network hidden layers", PCP_FIELD(fit.depth), ">= 1", at_least(1), true));
    s.push_back(choice("ablation", "Query network (stage 2)", "The paper's stage-2 ablations (include/pcp/train/query_fit.hpp)",
                       "none, no-shift, direct, free-code, pointnet-code, no-prior or tune-prior",
                       [](const ReconstructOptions& o) { return to_string(o.fit.ablation); },
                       [](ReconstructOptions& o, const std::string& v) {
                           for (QueryAblation a : {QueryAblation::None, QueryAblation::NoShift, QueryAblation::Direct, QueryAblation::FreeCode,
                                                   QueryAblation::PointNetCode, QueryAblation::NoPrior, QueryAblation::TunePrior})
                               if (to_string(a) == v) {
                                   o.fit.ablation = a;
                                   return true;
                               }
                           return false;
                       },
                       true));
    s.push_back(number("checkpoint-every", "Query network (stage 2)", "Steps between checkpoints (0: none but at the end)",
                       PCP_FIELD(fit.schedule.checkpoint_every), ">= 0", at_least(0)));
    s.push_back(number("progress-every", "Query network (stage 2)", "Steps between progress lines", PCP_FIELD(fit.schedule.progress_every),
                       ">= 1", at_least(1)));
    // ---- sign
    s.push_back(on_off("sign-repair", "Sign", "Flip regions of the fitted field whose sign the data does not support, on a coarse grid",
                       PCP_FIELD(sign_repair.enabled), true));
    s.push_back(number("sign-repair-resolution", "Sign", "Cells per axis of the sign repair's coarse grid (never more than resolution; with sign-repair)", PCP_FIELD(sign_repair.resolution),
                       "in [2, 256]", within(SignRepairOptions::kMinResolution, SignRepairOptions::kMaxResolution)));
    s.push_back(number("label-votes", "Sign",
                       "With N > 0, the sign repair also flips a region away from the data that at least N of its samples, and "
                       "more than agree, see on the other side by visibility (0: off; with sign-repair)",
                       PCP_FIELD(sign_repair.min_label_votes), ">= 0", at_least(0)));
    s.push_back(on_off("winding-sign", "Sign",
                       "Away from the data, the sign of the generalised winding number of the oriented input points",
                       PCP_FIELD(winding_sign.enabled), true));
    s.push_back(choice("winding-normals", "Sign",
                       "Orient the winding number's points by which side the visibility labels see outside (by the field where they "
                       "orient fewer than half), or by the field only (with winding-sign)",
                       "labels or field", [](const ReconstructOptions& o) { return o.winding_sign.orient_by_labels ? "labels" : "field"; },
                       [](ReconstructOptions& o, const std::string& v) {
                           if (v != "labels" && v != "field") return false;
                           o.winding_sign.orient_by_labels = v == "labels";
                           return true;
                       }));
    s.push_back(number("winding-near", "Sign", "Distance from the data, in sampling scales, within which the field keeps its own sign",
                       PCP_FIELD(winding_sign.near_k), "in [0, 100]", within(0, 100)));
    // ---- grid
    s.push_back(number("resolution", "Grid", "Marching-cubes cells along the longest axis", PCP_FIELD(resolution), "in [8, 2048]",
                       within(8, 2048), true));
    s.push_back(number("margin", "Grid", "Margin around the cloud's unit box", PCP_FIELD(margin), ">= 0", at_least(0)));
    s.push_back(number("iso", "Grid", "The level extracted: F_g = iso", PCP_FIELD(iso), "a finite number", [](double) { return true; }));
    {
        // Both grids, the fine one and the sign repair's coarse one.
        Setting f = number("grid-far-factor", "Grid",
                           "Blocks whose corners are farther than this x the block's half-diagonal from the zero set, all of one sign, "
                           "are interpolated from their corners instead of evaluated (0: evaluate every sample; both grids)",
                           PCP_FIELD(grid.far_factor), ">= 0", at_least(0));
        const auto set_f = f.set;
        f.set = [set_f](ReconstructOptions& o, const std::string& v) {
            set_f(o, v);
            o.sign_repair.far_factor = o.grid.far_factor;
        };
        s.push_back(f);
        Setting l = number("grid-far-levels", "Grid", "Levels of that test, each halving the cells that are not far (1: the 8-cell blocks only)",
                           PCP_FIELD(grid.far_levels), "in [1, 4]", within(1, 4));
        const auto set_l = l.set;
        l.set = [set_l](ReconstructOptions& o, const std::string& v) {
            set_l(o, v);
            o.sign_repair.far_levels = o.grid.far_levels;
        };
        s.push_back(l);
    }
    s.push_back(choice("grid-precision", "Grid", "Precision of the field's evaluations for meshing: fp32 even when training runs bf16, or the training's",
                       "fp32 or training", [](const ReconstructOptions& o) { return o.fp32_grid ? "fp32" : "training"; },
                       [](ReconstructOptions& o, const std::string& v) {
                           if (v != "fp32" && v != "training") return false;
                           o.fp32_grid = v == "fp32";
                           return true;
                       }));
    s.push_back(number("thin-offset", "Grid",
                       "Keep thin parts whole: near the data, extract at iso + this (unit-box units), then move the mesh back (0: off)",
                       PCP_FIELD(thin_offset), "in [0, 0.1)", [](double x) { return x >= 0 && x < 0.1; }, true));
    s.push_back(number("thin-probe", "Grid",
                       "Where the field has no inside this many grid cells under a point of the data, raise the thin level until it has (0: off; needs thin-offset > 0)",
                       PCP_FIELD(thin_probe), "in [0, 4]", within(0, 4)));
    // ---- grid passes
    s.push_back(on_off("cavity-fill", "Grid passes", "Fill the pockets of outside that the outside cannot reach (a noisy scan's hollow shells; it and tunnel-fill make the grid dense up to 2^24 samples)",
                       PCP_FIELD(cavity_fill.enabled), true));
    s.push_back(on_off("fine-repair", "Grid passes", "Flip thin regions of the fine grid bounded mostly by a zero crossing away from the data",
                       PCP_FIELD(fine_repair.enabled)));
    s.push_back(on_off("tunnel-fill", "Grid passes", "Plug the passages through the solid two cells across or less", PCP_FIELD(tunnel_fill.enabled),
                       true));
    s.push_back(on_off("through-carve", "Grid passes", "Open the inside samples on lines that cross no wall of the data",
                       PCP_FIELD(through_carve.enabled), true));
    s.push_back(choice("mc-ambiguity", "Grid passes", "How marching cubes cuts a face whose diagonal corners share a sign",
                       "join, decider or separate",
                       [](const ReconstructOptions& o) {
                           return o.marching_cubes.ambiguity == McAmbiguity::JoinInside          ? "join"
                                  : o.marching_cubes.ambiguity == McAmbiguity::AsymptoticDecider ? "decider"
                                                                                                 : "separate";
                       },
                       [](ReconstructOptions& o, const std::string& v) {
                           if (v == "join") o.marching_cubes.ambiguity = McAmbiguity::JoinInside;
                           else if (v == "decider") o.marching_cubes.ambiguity = McAmbiguity::AsymptoticDecider;
                           else if (v == "separate") o.marching_cubes.ambiguity = McAmbiguity::SeparateInside;
                           else return false;
                           return true;
                       }));
    // ---- surface passes
    s.push_back(on_off("shell-centre", "Surface passes", "On a noisy cloud, the surface in the middle of the noise band's shell (needs cavity-fill: the shell is what it filled)",
                       PCP_FIELD(shell_centre.enabled)));
    s.push_back(auto_on_off("recentre", "Surface passes",
                            "Before the surface fit, move the mesh onto the middle of the points' noise (auto: on noisy clouds)",
                            PCP_FIELD(recentre.enabled), PCP_FIELD(noisy.recentre)));
    s.push_back(on_off("surface-fit", "Surface passes", "Remove components with no input points near them and move the surface onto the data",
                       PCP_FIELD(surface_fit.enabled), true));
    s.push_back(number("surface-fit-iterations", "Surface passes", "Rounds of the surface fit's move onto the data (0: the component filter only)",
                       PCP_FIELD(surface_fit.iterations), "in [0, 100]", within(0, 100)));
    s.push_back(auto_on_off("smooth", "Surface passes", "Bilateral smoothing of the final mesh (auto: on noisy clouds)",
                            PCP_FIELD(smoothing.enabled), PCP_FIELD(noisy.smooth)));
    s.push_back(on_off("fair", "Surface passes", "Where no input point lies under the surface, the smoothest surface that joins the rest",
                       PCP_FIELD(fairing.enabled), true));
    {
        Setting g{"sheet-gap", "Surface passes", "Least gap between the two sides of a thin part (unit-box units; 0: off)", "in [0, 0.1)", false,
                  {}, {}, {}};
        g.get = [](const ReconstructOptions& o) { return text(o.sheet_gap.enabled ? o.sheet_gap.min_gap : 0.0); };
        g.set = [range = g.range](ReconstructOptions& o, const std::string& v) {
            const double gap = parse_number<double>("sheet-gap", range, v);
            if (!(gap >= 0 && gap < 0.1)) refuse("sheet-gap", range, v);
            o.sheet_gap.enabled = gap > 0;
            if (gap > 0) o.sheet_gap.min_gap = gap;
        };
        g.valid = [](const ReconstructOptions& o) { return !o.sheet_gap.enabled || (o.sheet_gap.min_gap > 0 && o.sheet_gap.min_gap < 0.1); };
        s.push_back(g);
    }
    // ---- output
    s.push_back(choice("normals-from", "Output",
                       "The oriented normals (--normals): the final mesh's at the nearest point, the PCA normal turned to the mesh's "
                       "side, or the PCA normal oriented by the fitted field's own votes",
                       "mesh, pca or field", [](const ReconstructOptions& o) { return to_string(o.normal_source); },
                       [](ReconstructOptions& o, const std::string& v) {
                           if (v != "mesh" && v != "pca" && v != "field") return false;
                           o.normal_source = parse_normal_source(v);
                           return true;
                       },
                       true));
    return s;
}

#undef PCP_FIELD

}  // namespace

const std::vector<Setting>& reconstruct_settings() {
    static const std::vector<Setting> settings = make_settings();
    return settings;
}

const Setting* find_setting(const std::string& name) {
    for (const Setting& s : reconstruct_settings())
        if (s.name == name) return &s;
    return nullptr;
}

void set_option(ReconstructOptions& options, const std::string& name, const std::string& value) {
    const Setting* s = find_setting(name);
    PCP_CHECK(s, "unknown setting '" << name << "' (pcp_reconstruct --list-settings lists them)");
    s->set(options, value);
    if (!s->valid(options)) refuse(name, s->range, value);
    // The self-prior's own settings imply it.
    if (name == "prior-epochs" || name == "prior-steps" || name == "prior-grid" || name == "prior-normalization")
        options.prior_source = PriorSource::SelfPrior;
}

void check_options(const ReconstructOptions& options) {
    for (const Setting& s : reconstruct_settings())
        if (!s.valid(options)) refuse(s.name, s.range, s.get(options));
    const Eigen::Index min_points = min_points_for(options.fit.sampling);
    PCP_CHECK(options.max_fit_points == 0 || options.max_fit_points >= min_points,
              "max-points must be 0 or >= " << min_points << " (got '" << options.max_fit_points << "')");
    PCP_CHECK(options.thin_company >= 1 && options.thin_company <= 8 && options.noisy.thin_company >= 1 && options.noisy.thin_company <= 8,
              "reconstruct: thin_company and noisy.thin_company must be in [1, 8], got " << options.thin_company << " and "
                                                                                         << options.noisy.thin_company);
    PCP_CHECK(std::isfinite(options.thin_min_share) && options.thin_min_share >= 0 && options.thin_min_share <= 1,
              "reconstruct: thin_min_share must be in [0, 1], got " << options.thin_min_share);
}

}  // namespace pcp
