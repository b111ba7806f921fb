// The reconstruction pipeline (see pcp/reconstruct.hpp): denoise (optional) -> one PreparedCloud
// -> prior (given, resumed beside the checkpoint, or trained on the cloud) -> query-network fit ->
// sign decision on the grid box's boundary (samples there lie outside the shape: if most are
// negative, the field is negated) -> sign repair -> winding-number sign away from the data -> grid
// (narrow band, or dense for the cavity fill) -> cavity fill -> fine sign repair ->
// marching cubes -> surface fit (components away from the data removed, vertices moved onto the
// data) -> bilateral smoothing (noisy clouds) -> input frame. Every mesh stage sees F_g - iso and works at level 0.
#include "pcp/reconstruct.hpp"

#include "pcp/cloud/prepared_cloud.hpp"
#include "pcp/cloud/regions.hpp"
#include "pcp/core/error.hpp"
#include "pcp/core/rng.hpp"
#include "pcp/mesh/marching_cubes.hpp"
#include "pcp/mesh/mesh_check.hpp"
#include "pcp/mesh/surface_fit.hpp"
#include "pcp/mesh/thin_level.hpp"
#include "pcp/nn/gemm.hpp"
#include "pcp/train/builtin_prior.hpp"
#include "mesh/sample_memo.hpp"
#include "mesh/grid_samples.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <vector>

namespace pcp {

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

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

/// Scenes (ReconstructOptions::scene): the free space the scanner stood in is the bulk of the
/// cloud's box away from the data (a room's interior; the box hugs the walls). The lattice points of
/// the box (per_axis^3) farther than 4 x the sampling scale from every input point; the fitted field
/// is made positive there (normals towards the free space, faces seen from the scanner's side). The
/// box boundary instead when none is that far.
PointsF scene_free_space_samples(const PreparedCloud& cloud, int per_axis) {
    const PointsF& unit = cloud.unit();
    const Eigen::RowVector3f lo = unit.colwise().minCoeff(), hi = unit.colwise().maxCoeff();
    PointsF lattice(static_cast<Eigen::Index>(per_axis) * per_axis * per_axis, 3);
    Eigen::Index n = 0;
    for (int i = 0; i < per_axis; ++i)
        for (int j = 0; j < per_axis; ++j)
            for (int k = 0; k < per_axis; ++k) {
                const Eigen::RowVector3f t((i + 0.5f) / static_cast<float>(per_axis), (j + 0.5f) / static_cast<float>(per_axis),
                                           (k + 0.5f) / static_cast<float>(per_axis));
                lattice.row(n++) = lo + t.cwiseProduct(hi - lo);
            }
    Eigen::VectorXf distance;
    cloud.tree().nearest(lattice, &distance);
    const float far = static_cast<float>(4.0 * sampling_scale(cloud.tree()));
    PointsF out((distance.array() > far).count(), 3);
    Eigen::Index m = 0;
    for (Eigen::Index i = 0; i < lattice.rows(); ++i)
        if (distance(i) > far) out.row(m++) = lattice.row(i);
    if (out.rows() == 0) {
        Aabb box;
        box.min = lo.transpose().cast<double>();
        box.max = hi.transpose().cast<double>();
        return box_boundary_samples(box, 12);
    }
    return out;
}

ProgressCallback chain(const ProgressCallback& a, const ProgressCallback& b) {
    if (!a) return b;
    if (!b) return a;
    return [a, b](const Progress& p) { return a(p) && b(p); };
}

/// The grid's precision (ReconstructOptions::fp32_grid), restored when the scope ends.
struct GridPrecision {
    nn::Precision saved = nn::gemm_precision();
    explicit GridPrecision(bool fp32) {
        if (fp32) nn::set_gemm_precision(nn::Precision::Fp32);
    }
    ~GridPrecision() { nn::set_gemm_precision(saved); }
    GridPrecision(const GridPrecision&) = delete;
    GridPrecision& operator=(const GridPrecision&) = delete;
};

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

/// Per-point values of the fitted cloud, given to every input point: the same rows, or, when the
/// fit used a subsample, the row of the fitted point nearest to each input point.
PointsF per_input_point(const PointsF& values, const PreparedCloud& cloud, const Eigen::Ref<const Points>& all_points,
                        bool subsampled) {
    if (!subsampled) return values;
    const IndexVector nearest = cloud.tree().nearest(cloud.normalization().to_unit(all_points));
    PointsF out(all_points.rows(), values.cols());
    for (Eigen::Index i = 0; i < all_points.rows(); ++i) out.row(i) = values.row(nearest(i));
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
    po.schedule.progress = chain(po.schedule.progress, options.progress);
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

/// Inside / outside by visibility through the cloud (include/pcp/cloud/visibility.hpp): the labels
/// of the fit's sign guide and of the sign repair's label vote (empty when neither is on).
VisibilityLabels visibility_labels(const PreparedCloud& cloud, const ReconstructOptions& options, ReconstructReport& r) {
    VisibilityLabels labels;
    if (options.fit.sign_guide.enabled || (options.sign_repair.enabled && options.sign_repair.min_label_votes > 0)) {
        VisibilityOptions vo = options.fit.sign_guide.visibility;
        vo.seed = options.fit.schedule.seed;
        labels = label_by_visibility(cloud.tree(), vo);
    }
    r.visibility = labels.stats;
    return labels;
}

/// From the fitted field of cloud `index` to its mesh in the input frame: sign, thin offset,
/// winding sign, sign repair, grid, cavity fill, fine repair, tunnel fill, marching cubes, surface fit,
/// smoothing, normals.
Mesh mesh_stage(const QueryNetFitter& fitter, int index, const PreparedCloud& cloud, const Eigen::Ref<const Points>& all_points,
                bool subsampled, const VisibilityLabels& labels, const ReconstructOptions& options, ReconstructReport& r,
                Points* normals) {
    auto t0 = std::chrono::steady_clock::now();
    SignRepairOptions so = options.sign_repair;
    const GridPrecision grid_precision(options.fp32_grid);
    const GridSpec spec = make_grid_spec(bounding_box(cloud.unit().cast<double>()), options.resolution, options.margin);
    // Outside is positive: decide on the grid box's boundary, which encloses the whole cloud (scenes: on the free
    // space away from the data, scene_free_space_samples).
    const PointsF boundary = options.scene.enabled ? scene_free_space_samples(cloud, 24) : box_boundary_samples(spec.box, 12);
    Eigen::VectorXf bvals(boundary.rows());
    fitter.sdf(index, boundary, bvals);
    r.sign_flipped = (bvals.array() < static_cast<float>(options.iso)).count() * 2 > bvals.size();
    const float iso = static_cast<float>(options.iso);
    // The thin offset (ReconstructOptions::thin_offset) raises the level only near the data: by
    // thin_offset within the surface fit's support radius of an input point, fading to nothing at
    // twice that radius, so that a field hovering just above zero away from the data grows no sheet.
    const float thin = static_cast<float>(options.thin_offset);
    const float near_r = thin > 0 ? static_cast<float>(options.surface_fit.support_k * sampling_scale(cloud.tree())) : 0.0f;
    // The level near each input point: thin_offset, raised further below where the grid's solid
    // has no inside under a point (include/pcp/mesh/thin_level.hpp).
    ThinLevel thin_level(cloud.tree(), thin, near_r);
    const float sign = r.sign_flipped ? -1.0f : 1.0f;
    // The grid box is the cloud's box plus a margin, so its faces are outside the shape: the field
    // is clamped to be positive there, which closes any sheet that would leave the box.
    const Eigen::Array3f lo = spec.box.min.cast<float>().array(), hi = spec.box.max.cast<float>().array();
    const Eigen::Array3f tol = (spec.spacing() * 1e-3).cast<float>().array();
    const auto outside = static_cast<float>(1e-3 * spec.spacing().minCoeff());
    // F_g - iso, positive on the box's faces; `fitted` also less the thin level near the data (what
    // the mesh stages see), `level` without it (what the winding sign's orientation votes see: a
    // point is a witness only where the zero set passes near it, field_normals.hpp).
    const auto evaluate = [&](const Eigen::Ref<const PointsF>& q, Eigen::Ref<Eigen::VectorXf> v, bool with_thin) {
        fitter.sdf(index, q, v);
        if (sign < 0) v = -v;
        if (iso != 0.0f) v.array() -= iso;
        if (with_thin && thin > 0)
            for (Eigen::Index i = 0; i < q.rows(); ++i) v(i) -= thin_level(q.row(i).transpose());
        for (Eigen::Index i = 0; i < q.rows(); ++i) {
            const Eigen::Array3f p = q.row(i).transpose().array();
            if (((p - lo).abs() <= tol).any() || ((p - hi).abs() <= tol).any()) v(i) = std::max(v(i), outside);
        }
    };
    const SdfBatchFn fitted = [&](const Eigen::Ref<const PointsF>& q, Eigen::Ref<Eigen::VectorXf> v) { evaluate(q, v, true); };
    const SdfBatchFn level = [&](const Eigen::Ref<const PointsF>& q, Eigen::Ref<Eigen::VectorXf> v) { evaluate(q, v, false); };
    // The oriented normals of the input points (include/pcp/mesh/field_normals.hpp): the unit
    // box's uniform scale keeps directions, so they are the input frame's too.
    if (normals && options.normal_source == NormalSource::Field) {
        const FieldNormals oriented = orient_normals_by_field(fitted, cloud.tree(), options.normals);
        r.normals = oriented.stats;
        *normals = per_input_point(oriented.normals, cloud, all_points, subsampled).cast<double>();
    }
    // Away from the data the sign is the winding number's of the field-oriented input points
    // (include/pcp/mesh/winding_sign.hpp); not in the scene mode: an open room has no inside.
    WindingSignOptions winding_options = options.winding_sign;
    if (options.scene.enabled) winding_options.enabled = false;
    // Oriented by which side the visibility labels see outside, when there are labels: the field
    // orients too few points on every shared case (its negative shell around noisy data has no
    // growth across the points, include/pcp/mesh/winding_sign.hpp). Where the labels cannot (thin
    // parts seen from both sides: a table, a chair), by the field as before.
    WindingSign winding;
    if (winding_options.orient_by_labels && !labels.label.empty()) winding = WindingSign(labels, cloud.tree(), winding_options);
    if (!winding.stats().by_labels || winding.stats().skipped) winding = WindingSign(level, cloud.tree(), winding_options);
    r.winding_sign = winding.stats();
    // Regions whose sign the data does not support are flipped (include/pcp/mesh/sign_repair.hpp);
    // the coarse grid is never finer than the fine one. The repair sees the fitted field, and the
    // winding number corrects its result but for the regions the repair opened: the other way
    // round, the winding number's flips near a wall (right ones: a noisy wall made solid) joined
    // the field's plug of a barely scanned bore to the wall's solid, and the repair, which flips a
    // region the data does not bound, kept the plug (abc_00011084 seed 1; docs/BENCHMARKS.md, "The
    // sign repair before the winding number").
    so.resolution = std::min(so.resolution, options.resolution);
    // The coarse grid's values are kept for the fine grid's samples at the same points (only for a
    // resolution the repair accepts: it reports any other itself).
    std::optional<detail::SampleMemo> memo;
    if (so.enabled && so.resolution >= SignRepairOptions::kMinResolution && so.resolution <= SignRepairOptions::kMaxResolution) {
        GridSpec coarse_spec = spec;
        coarse_spec.resolution = so.resolution;
        memo.emplace(coarse_spec);
    }
    const SignRepair repair(memo ? memo->recording(fitted) : fitted, spec.box, cloud.tree(), so, &labels);
    r.sign_repair = repair.stats();
    const SdfBatchFn fitted_fine = memo ? memo->reusing(fitted) : fitted;
    const bool winding_active = winding.active();
    const SdfBatchFn field = [&](const Eigen::Ref<const PointsF>& q, Eigen::Ref<Eigen::VectorXf> v) {
        fitted_fine(q, v);
        if (!winding_active) {  // skipped or off (most scans, scenes): no copies per batch
            repair.apply(q, v);
            return;
        }
        const Eigen::VectorXf raw = v;
        repair.apply(q, v);
        const Eigen::VectorXf repaired = v;
        winding.apply(q, v);
        // A region the repair opened (made outside) stays open: the winding number, high in a bore
        // the scan left half enclosed, would close parts of it again, slivers that the fairing
        // drew into needles at 256 cells (tests/realdata, abc_00016513).
        for (Eigen::Index i = 0; i < v.size(); ++i)
            if (raw(i) < 0 && repaired(i) > 0 && v(i) < 0) v(i) = repaired(i);
    };
    SdfGridOptions go = options.grid;
    go.progress = chain(go.progress, options.progress);
    // Scenes: only the blocks near the data, and no growth along the zero set away from it (the
    // faces there are trimmed anyway): the closed hull of a room costs nothing.
    if (options.scene.enabled) {
        go.band = NarrowBand::NearPoints;
        go.grow = false;
    }
    // The cavity fill needs every sample of the lattice (include/pcp/mesh/cavity_fill.hpp).
    const std::int64_t lattice = std::int64_t(options.resolution + 1) * (options.resolution + 1) * (options.resolution + 1);
    if ((options.cavity_fill.enabled && lattice <= options.cavity_fill.max_samples) ||
        (options.tunnel_fill.enabled && lattice <= options.tunnel_fill.max_samples))
        go.band = NarrowBand::Dense;
    SdfGrid grid = go.band == NarrowBand::NearPoints ? evaluate_sdf_grid(field, spec, go, cloud.unit())
                                                     : evaluate_sdf_grid(field, spec, go);
    // Enclosed pockets of "outside": the hollow shells of noisy scans (include/pcp/mesh/cavity_fill.hpp).
    CavityFillOptions fill = options.cavity_fill;
    if (r.denoise_passes > 0) fill.max_open = fill.noisy_max_open;  // a noisy cloud: only the closed pockets
    // A noisy cloud's shell: its inner wall, which the fill removes, puts the surface in the middle
    // of the noise band later (include/pcp/mesh/shell_centre.hpp).
    std::optional<SdfGrid> before_fill;
    if (r.denoise_passes > 0 && options.shell_centre.enabled && fill.enabled && go.band == NarrowBand::Dense) before_fill = grid;
    r.cavity_fill = fill_cavities(grid, fill, &labels, &cloud.tree());
    // Membranes and bubbles too thin for the coarse grid (include/pcp/mesh/fine_repair.hpp).
    r.fine_repair = repair_fine_grid(grid, cloud.tree(), options.fine_repair);
    // Passages through the solid too narrow for the data to support: the small handles of a bumpy
    // field (include/pcp/mesh/tunnel_fill.hpp); a pocket a plug closed off is then a cavity.
    r.tunnel_fill = fill_tunnels(grid, options.tunnel_fill);
    if (r.tunnel_fill.plugged > 0) {
        const CavityFillStats again = fill_cavities(grid, fill, &labels, &cloud.tree());
        r.cavity_fill.cavities += again.cavities;
        r.cavity_fill.cavity_samples += again.cavity_samples;
        r.cavity_fill.labelled_cavities += again.labelled_cavities;
        r.cavity_fill.supported_cavities += again.supported_cavities;
    }
    // Openings the field spans though lines pass through them that cross no wall of the data
    // (include/pcp/mesh/through_carve.hpp).
    // Not in the scene mode: a room open at its top has lines over its floor that pass no wall, as
    // a cap the scan missed has (include/pcp/mesh/through_carve.hpp), and the floor would go.
    ThroughCarveOptions carve = options.through_carve;
    if (options.scene.enabled) carve.enabled = false;
    r.through_carve = carve_through_lines(grid, cloud.tree(), carve);
    // The dual: bridges of solid as thin, cut where that removes a handle and leaves the solid whole.
    r.bridge_cut = cut_bridges(grid, options.tunnel_fill);
    // Sheets the grid's samples miss at thin_offset: their level raised (ReconstructOptions::thin_probe).
    if (thin > 0 && options.thin_probe > 0) {
        const auto reach = static_cast<float>(options.thin_probe * spec.spacing().minCoeff());
        r.thin_raised = thin_level.raise_where_thin(grid, reach, r.denoise_passes > 0 ? options.thin_company_noisy : options.thin_company,
                                                    options.thin_min_share);
        // The shell centring's copy from before the fill alike, or a raised sheet looks to it like a
        // hollow the fill closed.
        if (before_fill) thin_level.shift_like_raise(*before_fill);
    }
    r.winding_corrected = winding.corrected();
    r.sdf_reused = memo ? memo->reused() : 0;
    r.sdf_evaluations = grid.stats.evaluations + repair.stats().evaluations - r.sdf_reused;
    r.seconds_grid = seconds_since(t0);

    t0 = std::chrono::steady_clock::now();
    // Extracted at F_g = iso + the thin level, then moved back by it (ReconstructOptions::thin_offset).
    Mesh mc_mesh = marching_cubes(grid, options.marching_cubes);
    if (thin > 0) {  // back by the level each vertex was raised by
        Eigen::VectorXd back(mc_mesh.vertices.rows());
        for (Eigen::Index i = 0; i < back.size(); ++i)
            back(i) = -static_cast<double>(thin_level(mc_mesh.vertices.row(i).transpose().cast<float>()));
        mc_mesh = offset_along_normals(mc_mesh, back);
    }
    PCP_CHECK(mc_mesh.faces.rows() > 0, "reconstruction produced an empty mesh: the fitted SDF has no zero crossing "
                                        "in the grid (train longer, or check the input)");
    if (before_fill && r.cavity_fill.cavity_samples > 0)
        mc_mesh = centre_in_shells(mc_mesh, *before_fill, grid, cloud.tree(), options.shell_centre.max_thickness_k * sampling_scale(cloud.tree()),
                                   &r.shell_centre);
    SurfaceFitOptions fit_options = options.surface_fit;
    if (r.denoise_passes > 0) fit_options.neighbors = fit_options.noisy_neighbors;  // a noisy cloud: average more points
    // A denoised cloud's mesh is fitted to the input points as given (SurfaceFitOptions::noisy_raw_points).
    std::unique_ptr<KdTree> raw_tree;
    if (r.denoise_passes > 0 && fit_options.noisy_raw_points) raw_tree = std::make_unique<KdTree>(cloud.normalization().to_unit(all_points));
    const KdTree& fit_cloud = raw_tree ? *raw_tree : cloud.tree();
    // Onto the middle of the noise before the fit (RecentreOptions; noisy clouds by default).
    if (r.denoise_passes > 0 ? options.recentre.noisy : options.recentre.clean) {
        mc_mesh = recentre_on_points(mc_mesh, fit_cloud, options.recentre, &r.recentre);
        r.recentre.applied = true;
        // The fit then leaves out the far side of thin parts, by the spread measured here (SurfaceFitOptions::noise_spread).
        if (fit_options.noise_spread == 0) fit_options.noise_spread = r.recentre.spread;
    }
    const Mesh fitted_mesh = fit_surface_to_points(mc_mesh, fit_cloud, fit_options, &r.surface_fit);
    PCP_CHECK(fitted_mesh.faces.rows() > 0, "reconstruction produced no surface near the input points (every piece of "
                                            "the fitted SDF's zero set lies away from the data)");
    // The noise's bumps that the fit onto noisy data keeps (include/pcp/mesh/smooth.hpp).
    r.smoothed = r.denoise_passes > 0 ? options.smoothing.noisy : options.smoothing.clean;
    Mesh unit_mesh = r.smoothed ? bilateral_smooth(fitted_mesh, options.smoothing.bilateral) : fitted_mesh;
    // Where no data lies under it, the smoothest surface that joins the data (FairOptions); a scene
    // trims those faces instead.
    if (options.fairing.enabled && !options.scene.enabled) unit_mesh = fair_unsupported(unit_mesh, fit_cloud, options.fairing, &r.fairing);
    // The two sides of a thin part, which the move back and the fit bring onto the same data, apart
    // again (include/pcp/mesh/sheet_gap.hpp), where the solid that marching cubes extracted lies
    // between them.
    // On a noisy cloud only near the sheets the thin level found: elsewhere the sides that meet
    // there are a noisy field's crumpled pockets, which moving apart roughens (abc_00010089).
    if (options.sheet_gap.enabled && (r.denoise_passes == 0 || r.thin_raised > 0)) {
        const bool everywhere = r.denoise_passes == 0;
        unit_mesh = keep_sheets_apart(
            unit_mesh,
            [&](const Eigen::Vector3d& p) {
                if (!everywhere && !thin_level.raised_at(p.cast<float>())) return std::numeric_limits<float>::quiet_NaN();
                return detail::stored_at(grid, p);
            },
            options.sheet_gap, &r.sheet_gap);
    }
    // The support filter's size rule again on the final geometry: the fit and the smoothing shrink a
    // lone sample's octahedron beside the data to a point (remove_small_components).
    if (options.surface_fit.enabled)
        unit_mesh = remove_small_components(unit_mesh, options.surface_fit.min_extent_k * r.surface_fit.scale, &r.collapsed_removed);
    // Scenes: open where the data ends (ReconstructOptions::scene).
    if (options.scene.enabled) {
        unit_mesh = trim_unsupported_faces(unit_mesh, cloud.tree(), options.scene.support_k * sampling_scale(cloud.tree()),
                                           &r.scene_trimmed);
        PCP_CHECK(unit_mesh.faces.rows() > 0, "scene mode: no face of the mesh lies near the input points");
    }
    Mesh mesh = cloud.normalization().from_unit(unit_mesh);
    r.closed = is_closed_and_oriented(mesh);
    if (normals && options.normal_source != NormalSource::Field) {
        // Read off the final mesh at the point nearest to each input point (include/pcp/mesh/field_normals.hpp).
        const auto t_normals = std::chrono::steady_clock::now();
        *normals = mesh_normals_at(mesh, all_points);
        if (options.normal_source == NormalSource::PcaByMesh) {
            // The PCA direction of the (denoised) cloud, turned to the mesh's side.
            const PointsF pca = per_input_point(pca_normals(cloud.tree(), options.normals.normal_k), cloud, all_points, subsampled);
            for (Eigen::Index i = 0; i < normals->rows(); ++i) {
                const Eigen::RowVector3d d = pca.row(i).cast<double>();
                normals->row(i) = d.dot(normals->row(i)) < 0 ? Eigen::RowVector3d(-d) : d;
            }
        }
        r.normals.points = normals->rows();
        r.normals.seconds = seconds_since(t_normals);
    }
    r.seconds_mesh = seconds_since(t0);
    return mesh;
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
    fo.schedule.progress = chain(fo.schedule.progress, options.progress);
    const VisibilityLabels labels = visibility_labels(cloud, options, r);
    QueryNetFitter fitter(cloud, *prior, fo, &labels);
    if (!fitter.run()) {
        r.cancelled = true;
        return Mesh{};
    }
    if (options.keep_checkpoints && !ckpt.empty()) fitter.checkpoint(ckpt);
    r.guided_per_step = fitter.guided_per_step();
    r.fit_loss = fitter.recent_loss();
    r.fit_steps = fitter.steps_done();
    r.seconds_fit = seconds_since(t0);

    Mesh mesh = mesh_stage(fitter, 0, cloud, all_points, subsampled, labels, options, r, normals);
    std::error_code ignored;
    if (!prior_ckpt.empty() && !options.keep_checkpoints) std::filesystem::remove(prior_ckpt, ignored);
    return mesh;
}

/// The options both entry points check before any work.
void check_pipeline_options(const ReconstructOptions& options) {
    PCP_CHECK(options.max_fit_points >= 0, "reconstruct: max_fit_points must be >= 0, got " << options.max_fit_points);
    PCP_CHECK(std::isfinite(options.thin_offset) && options.thin_offset >= 0 && options.thin_offset < 0.1,
              "reconstruct: thin_offset must be in [0, 0.1) (unit-box units), got " << options.thin_offset);
    PCP_CHECK(std::isfinite(options.thin_probe) && options.thin_probe >= 0 && options.thin_probe <= 4,
              "reconstruct: thin_probe must be in [0, 4] (grid cells), got " << options.thin_probe);
    PCP_CHECK(options.thin_company >= 1 && options.thin_company <= 8 && options.thin_company_noisy >= 1 && options.thin_company_noisy <= 8,
              "reconstruct: thin_company and thin_company_noisy must be in [1, 8], got " << options.thin_company << " and "
                                                                                        << options.thin_company_noisy);
    PCP_CHECK(std::isfinite(options.thin_min_share) && options.thin_min_share >= 0 && options.thin_min_share <= 1,
              "reconstruct: thin_min_share must be in [0, 1], got " << options.thin_min_share);
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
    check_pipeline_options(options);
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
    check_pipeline_options(options);
    PCP_CHECK(options.fit.ablation == QueryAblation::None && !options.fit.sign_guide.enabled,
              "reconstruct_many: several clouds are fitted with the method itself only (ablation none, no sign guide)");
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
    fo.schedule.progress = chain(fo.schedule.progress, options.progress);
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
            meshes.push_back(mesh_stage(fitter, k, *prepared[static_cast<std::size_t>(k)], clouds[static_cast<std::size_t>(k)],
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
