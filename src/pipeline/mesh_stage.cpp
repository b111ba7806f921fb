// The mesh stage (see mesh_stage.hpp): the field, the grid, the grid passes, the extraction, the
// surface passes, the output. Every step sees F_g - iso and works at level 0.
#include "mesh_stage.hpp"

#include "pcp/core/error.hpp"
#include "pcp/mesh/surface/mesh_ops.hpp"
#include "pcp/mesh/grid/marching_cubes.hpp"
#include "pcp/mesh/grid/mesh_check.hpp"
#include "pcp/nn/gemm.hpp"
#include "mesh/grid/sample_memo.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <optional>
#include <vector>

namespace pcp::detail {

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

}  // namespace

ProgressCallback chain(const ProgressCallback& a, const ProgressCallback& b) {
    if (!a) return b;
    if (!b) return a;
    return [a, b](const Progress& p) { return a(p) && b(p); };
}

PointsF per_input_point(const PointsF& values, const PreparedCloud& cloud, const Eigen::Ref<const Points>& all_points,
                        bool subsampled) {
    if (!subsampled) return values;
    const IndexVector nearest = cloud.tree().nearest(cloud.normalization().to_unit(all_points));
    PointsF out(all_points.rows(), values.cols());
    for (Eigen::Index i = 0; i < all_points.rows(); ++i) out.row(i) = values.row(nearest(i));
    return out;
}

Mesh mesh_stage(const QueryNetFitter& fitter, int index, const PreparedCloud& cloud, const Eigen::Ref<const Points>& all_points,
                bool subsampled, const VisibilityLabels& labels, const ReconstructOptions& given, ReconstructReport& r,
                Points* normals) {
    auto t0 = std::chrono::steady_clock::now();
    const bool noisy = r.denoise_passes > 0;
    const ReconstructOptions options = overlay_options(given, noisy);
    const GridPrecision grid_precision(options.fp32_grid);
    const GridSpec spec = make_grid_spec(bounding_box(cloud.unit().cast<double>()), options.resolution, options.margin);

    // ---- field: outside is positive. Decided on the grid box's boundary, which encloses the whole
    // cloud (scenes: on the free space away from the data, scene_free_space_samples).
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
    // The level near each input point: thin_offset, raised further by the thin probe where the
    // grid's solid has no inside under a point (include/pcp/mesh/repair/thin_level.hpp).
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
    // The oriented normals of the input points (include/pcp/mesh/sign/field_normals.hpp): the unit
    // box's uniform scale keeps directions, so they are the input frame's too.
    if (normals && options.normal_source == NormalSource::Field) {
        const FieldNormals oriented = orient_normals_by_field(fitted, cloud.tree(), options.normals);
        r.normals = oriented.stats;
        *normals = per_input_point(oriented.normals, cloud, all_points, subsampled).cast<double>();
    }
    // Away from the data the sign is the winding number's of the oriented input points
    // (include/pcp/mesh/sign/winding_sign.hpp), oriented by which side the visibility labels see
    // outside; where the labels orient too few (thin parts seen from both sides), by the field.
    WindingSign winding;
    if (options.winding_sign.orient_by_labels && !labels.label.empty()) winding = WindingSign(labels, cloud.tree(), options.winding_sign);
    if (!winding.stats().by_labels || winding.stats().skipped) winding = WindingSign(level, cloud.tree(), options.winding_sign);
    r.winding_sign = winding.stats();
    // Regions whose sign the data does not support are flipped (include/pcp/mesh/sign/sign_repair.hpp)
    // on a coarse grid never finer than the fine one. The repair sees the fitted field, and the
    // winding number corrects its result but for the regions the repair opened: the other way
    // round, the winding number's flips near a noisy wall joined the field's plug of a barely
    // scanned bore to the wall's solid, and the repair, which flips a region the data does not
    // bound, kept the plug.
    SignRepairOptions so = options.sign_repair;
    so.resolution = std::min(so.resolution, options.resolution);
    // The coarse grid's values are kept for the fine grid's samples at the same points (only for a
    // resolution the repair accepts: it reports any other itself).
    std::optional<SampleMemo> memo;
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
        // drew into needles.
        for (Eigen::Index i = 0; i < v.size(); ++i)
            if (raw(i) < 0 && repaired(i) > 0 && v(i) < 0) v(i) = repaired(i);
    };

    // ---- grid: narrow band, or dense where the fills need every sample of the lattice.
    SdfGridOptions go = options.grid;
    go.progress = chain(go.progress, options.progress);
    const std::int64_t lattice = std::int64_t(options.resolution + 1) * (options.resolution + 1) * (options.resolution + 1);
    if ((options.cavity_fill.enabled && lattice <= options.cavity_fill.max_samples) ||
        (options.tunnel_fill.enabled && lattice <= options.tunnel_fill.max_samples))
        go.band = NarrowBand::Dense;
    // The points the surface passes fit to: a denoised cloud's input as given (NoisyCloudOptions::fit_raw_points).
    std::unique_ptr<KdTree> raw_tree;
    if (noisy && options.noisy.fit_raw_points) raw_tree = std::make_unique<KdTree>(cloud.normalization().to_unit(all_points));
    MeshContext c(cloud, raw_tree ? *raw_tree : cloud.tree(), labels, options, r, thin_level);
    c.grid = go.band == NarrowBand::NearPoints ? evaluate_sdf_grid(field, spec, go, cloud.unit()) : evaluate_sdf_grid(field, spec, go);
    c.dense = go.band == NarrowBand::Dense;
    r.winding_corrected = winding.corrected();
    r.sdf_reused = memo ? memo->reused() : 0;
    r.sdf_evaluations = c.grid.stats.evaluations + repair.stats().evaluations - r.sdf_reused;

    run_passes(grid_passes(), c);
    r.seconds_grid = seconds_since(t0);

    // ---- extraction at F_g = iso + the thin level, then each vertex moved back by its level.
    t0 = std::chrono::steady_clock::now();
    c.mesh = marching_cubes(c.grid, options.marching_cubes);
    if (thin > 0) {
        Eigen::VectorXd back(c.mesh.vertices.rows());
        for (Eigen::Index i = 0; i < back.size(); ++i)
            back(i) = -static_cast<double>(thin_level(c.mesh.vertices.row(i).transpose().cast<float>()));
        c.mesh = offset_along_normals(c.mesh, back);
    }
    PCP_CHECK(c.mesh.faces.rows() > 0, "reconstruction produced an empty mesh: the fitted SDF has no zero crossing "
                                       "in the grid (train longer, or check the input)");
    c.noise_spread = options.surface_fit.noise_spread;
    run_passes(surface_passes(), c);

    // ---- output: the input frame.
    Mesh mesh = cloud.normalization().from_unit(c.mesh);
    r.closed = is_closed_and_oriented(mesh);
    if (normals && options.normal_source != NormalSource::Field) {
        // Read off the final mesh at the point nearest to each input point (include/pcp/mesh/sign/field_normals.hpp).
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

}  // namespace pcp::detail
