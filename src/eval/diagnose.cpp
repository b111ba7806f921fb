// The error budget of pcp_eval --diagnose (include/pcp/eval/diagnose.hpp): connected components
// with their topology, support by the input cloud, and the split of evaluate()'s L2-CD into
// pieces. Both meshes go through evaluate()'s frame and sampling (eval_frame.hpp, same seeds), so
// the pieces add up to its chamfer_l2. Nearest-sample queries use KdTree (float, frame of size ~1);
// exact point-to-triangle distances (offset, missing surface) use point_to_mesh_distance.
#include "pcp/eval/diagnose.hpp"

#include "eval/eval_frame.hpp"
#include "pcp/cloud/kdtree.hpp"
#include "pcp/core/error.hpp"
#include "pcp/mesh/grid/mesh_check.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <utility>

namespace pcp {

namespace {

/// For each vertex, the index of the first vertex at exactly the same position (V x 1).
std::vector<std::int32_t> weld_exact(const Points& v) {
    const Eigen::Index n = v.rows();
    std::vector<std::int32_t> order(static_cast<std::size_t>(n));
    std::iota(order.begin(), order.end(), 0);
    auto less = [&](std::int32_t a, std::int32_t b) {
        for (int c = 0; c < 3; ++c)
            if (v(a, c) != v(b, c)) return v(a, c) < v(b, c);
        return a < b;
    };
    std::sort(order.begin(), order.end(), less);
    std::vector<std::int32_t> rep(static_cast<std::size_t>(n));
    for (std::size_t i = 0; i < order.size(); ++i) {
        const bool same = i > 0 && v.row(order[i]) == v.row(order[i - 1]);
        rep[static_cast<std::size_t>(order[i])] = same ? rep[static_cast<std::size_t>(order[i - 1])] : order[i];
    }
    return rep;
}

std::int32_t find_root(std::vector<std::int32_t>& parent, std::int32_t x) {
    while (parent[static_cast<std::size_t>(x)] != x) {
        parent[static_cast<std::size_t>(x)] = parent[static_cast<std::size_t>(parent[static_cast<std::size_t>(x)])];
        x = parent[static_cast<std::size_t>(x)];
    }
    return x;
}

double face_area(const Mesh& m, Eigen::Index f) {
    const Eigen::Vector3d a = m.vertices.row(m.faces(f, 0)), b = m.vertices.row(m.faces(f, 1)), c = m.vertices.row(m.faces(f, 2));
    const double area = 0.5 * (b - a).cross(c - a).norm();
    return std::isfinite(area) ? area : 0.0;
}

/// Components of `mesh` (sorted by decreasing area) and the component of each face (F x 1).
struct Components {
    std::vector<ComponentInfo> info;
    std::vector<std::int32_t> of_face;
    std::vector<std::vector<std::int32_t>> vertices;  ///< welded vertex ids of each component
};

Components find_components(const Mesh& mesh) {
    const std::vector<std::int32_t> rep = weld_exact(mesh.vertices);
    std::vector<std::int32_t> parent(rep.size());
    std::iota(parent.begin(), parent.end(), 0);
    const Eigen::Index faces = mesh.faces.rows();
    for (Eigen::Index f = 0; f < faces; ++f) {
        const std::int32_t a = find_root(parent, rep[static_cast<std::size_t>(mesh.faces(f, 0))]);
        for (int k = 1; k < 3; ++k) {
            const std::int32_t b = find_root(parent, rep[static_cast<std::size_t>(mesh.faces(f, k))]);
            if (a != b) parent[static_cast<std::size_t>(b)] = a;
        }
    }
    // Number the roots in face order, then gather each component's faces.
    std::vector<std::int32_t> label(rep.size(), -1);
    std::vector<std::vector<Eigen::Index>> faces_of;
    std::vector<std::int32_t> of_face(static_cast<std::size_t>(faces));
    for (Eigen::Index f = 0; f < faces; ++f) {
        const std::int32_t root = find_root(parent, rep[static_cast<std::size_t>(mesh.faces(f, 0))]);
        if (label[static_cast<std::size_t>(root)] < 0) {
            label[static_cast<std::size_t>(root)] = static_cast<std::int32_t>(faces_of.size());
            faces_of.emplace_back();
        }
        of_face[static_cast<std::size_t>(f)] = label[static_cast<std::size_t>(root)];
        faces_of[static_cast<std::size_t>(label[static_cast<std::size_t>(root)])].push_back(f);
    }
    const std::size_t count = faces_of.size();
    std::vector<ComponentInfo> info(count);
    std::vector<std::vector<std::int32_t>> verts(count);
    std::vector<std::int32_t> local(rep.size(), -1);
    for (std::size_t c = 0; c < count; ++c) {
        // The component as its own mesh over welded vertices, counted by mesh_topology.
        Mesh sub;
        sub.faces.resize(static_cast<Eigen::Index>(faces_of[c].size()), 3);
        for (std::size_t i = 0; i < faces_of[c].size(); ++i) {
            const Eigen::Index f = faces_of[c][i];
            info[c].area += face_area(mesh, f);
            for (int k = 0; k < 3; ++k) {
                const std::int32_t w = rep[static_cast<std::size_t>(mesh.faces(f, k))];
                if (local[static_cast<std::size_t>(w)] < 0) {
                    local[static_cast<std::size_t>(w)] = static_cast<std::int32_t>(verts[c].size());
                    verts[c].push_back(w);
                }
                sub.faces(static_cast<Eigen::Index>(i), k) = local[static_cast<std::size_t>(w)];
            }
        }
        sub.vertices = mesh.vertices(verts[c], Eigen::all);
        for (std::int32_t w : verts[c]) local[static_cast<std::size_t>(w)] = -1;
        const MeshTopology t = mesh_topology(sub);
        ComponentInfo& ci = info[c];
        ci.faces = t.F;
        ci.vertices = t.V;
        ci.edges = t.E;
        ci.euler = t.euler();
        ci.boundary_edges = t.edges_not_in_two_faces;
        ci.closed = t.closed_manifold_oriented();
        ci.genus = ci.closed ? static_cast<int>((2 - ci.euler) / 2) : -1;
    }
    // Sort by decreasing area (ties: more faces first, then discovery order).
    std::vector<std::int32_t> order(count);
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(), [&](std::int32_t a, std::int32_t b) {
        if (info[static_cast<std::size_t>(a)].area != info[static_cast<std::size_t>(b)].area)
            return info[static_cast<std::size_t>(a)].area > info[static_cast<std::size_t>(b)].area;
        return info[static_cast<std::size_t>(a)].faces > info[static_cast<std::size_t>(b)].faces;
    });
    std::vector<std::int32_t> rank(count);
    Components out;
    for (std::size_t r = 0; r < count; ++r) {
        rank[static_cast<std::size_t>(order[r])] = static_cast<std::int32_t>(r);
        out.info.push_back(info[static_cast<std::size_t>(order[r])]);
        out.vertices.push_back(std::move(verts[static_cast<std::size_t>(order[r])]));
    }
    out.of_face.resize(of_face.size());
    for (std::size_t f = 0; f < of_face.size(); ++f) out.of_face[f] = rank[static_cast<std::size_t>(of_face[f])];
    return out;
}

double median(Eigen::VectorXf values) {
    PCP_CHECK(values.size() > 0, "diagnose: median of nothing");
    float* mid = values.data() + values.size() / 2;
    std::nth_element(values.data(), mid, values.data() + values.size());
    return static_cast<double>(*mid);
}

/// Median distance from each point of `tree` to its nearest other point.
double median_spacing(const KdTree& tree) {
    PCP_CHECK(tree.size() >= 2, "diagnose: need at least two points to measure their spacing");
    return median(tree.kth_distance(tree.points(), 2));
}

}  // namespace

std::vector<ComponentInfo> mesh_components(const Mesh& mesh) {
    detail::check_mesh(mesh, "input");
    return find_components(mesh).info;
}

Diagnosis diagnose(const Mesh& pred, const Mesh& gt, const Eigen::Ref<const Points>* input, const DiagnoseOptions& options) {
    detail::check_mesh(pred, "predicted");
    detail::check_mesh(gt, "ground-truth");
    PCP_CHECK(options.support_k > 0 && options.near_k > 0, "diagnose: support_k and near_k must be > 0");
    PCP_CHECK(options.floating_fraction >= 0 && options.floating_fraction < 1, "diagnose: floating_fraction must be in [0, 1)");
    if (input) {
        PCP_CHECK(input->rows() >= 2, "diagnose: the input cloud needs at least two points");
        PCP_CHECK(input->allFinite(), "diagnose: the input cloud has non-finite coordinates");
    }
    EvalOptions eval_options;
    eval_options.protocol = options.protocol;
    eval_options.samples = options.samples;
    const Eigen::Index n = resolved_samples(eval_options);
    const Normalization frame = detail::eval_frame(gt.vertices, options.protocol);
    const Mesh pred_f = detail::to_frame(pred, frame), gt_f = detail::to_frame(gt, frame);

    Diagnosis d;
    d.frame_scale = 1.0 / frame.scale;
    d.samples = n;
    d.has_input = input != nullptr;

    // The same samples as evaluate(): pred with seed, GT with seed + 1.
    const SurfaceSamples ps = sample_mesh_surface(pred_f, n, options.seed);
    const SurfaceSamples gs = sample_mesh_surface(gt_f, n, options.seed + 1);
    const KdTree pred_tree(ps.points.cast<float>()), gt_tree(gs.points.cast<float>());

    // Components and their areas.
    const Components comps = find_components(pred_f);
    d.pred_components = comps.info;
    d.gt_components = find_components(gt_f).info;
    for (const ComponentInfo& c : d.pred_components) d.pred_area += c.area;
    for (const ComponentInfo& c : d.gt_components) d.gt_area += c.area;

    // Spacing, support radius, near threshold.
    std::vector<bool> away(static_cast<std::size_t>(n), false);
    if (input) {
        const KdTree input_tree(frame.to_unit_double(*input).cast<float>());
        d.spacing = median_spacing(input_tree);
        d.support_radius = options.support_k * d.spacing;
        Eigen::VectorXf to_input;
        input_tree.nearest(ps.points.cast<float>(), &to_input);
        const std::size_t count = comps.info.size();
        std::vector<Eigen::Index> samples_in(count, 0), unsupported_in(count, 0);
        Eigen::Index unsupported = 0;
        for (Eigen::Index i = 0; i < n; ++i) {
            const auto c = static_cast<std::size_t>(comps.of_face[static_cast<std::size_t>(ps.faces(i))]);
            const bool bad = static_cast<double>(to_input(i)) > d.support_radius;
            ++samples_in[c];
            unsupported_in[c] += bad;
            unsupported += bad;
        }
        d.unsupported_area_fraction = static_cast<double>(unsupported) / static_cast<double>(n);
        for (std::size_t c = 0; c < count; ++c) {
            ComponentInfo& ci = d.pred_components[c];
            if (samples_in[c] > 0) {
                ci.unsupported_fraction = static_cast<double>(unsupported_in[c]) / static_cast<double>(samples_in[c]);
            } else {  // too small to get a sample: judge it by its vertices
                const PointsF v = pred_f.vertices(comps.vertices[c], Eigen::all).cast<float>();
                Eigen::VectorXf dist;
                input_tree.nearest(v, &dist);
                ci.unsupported_fraction = static_cast<double>((dist.array().cast<double>() > d.support_radius).count()) /
                                          static_cast<double>(dist.size());
            }
            ci.floating = ci.unsupported_fraction > options.floating_fraction;
            if (ci.floating) {
                ++d.floating_components;
                d.floating_area += ci.area;
            }
        }
        d.floating_area_fraction = d.pred_area > 0 ? d.floating_area / d.pred_area : 0.0;
        for (Eigen::Index i = 0; i < n; ++i) {
            const auto c = static_cast<std::size_t>(comps.of_face[static_cast<std::size_t>(ps.faces(i))]);
            away[static_cast<std::size_t>(i)] = static_cast<double>(to_input(i)) > d.support_radius || d.pred_components[c].floating;
        }
    } else {
        d.spacing = median_spacing(gt_tree);
        d.support_radius = options.support_k * d.spacing;
    }
    d.near_threshold = options.near_k * d.spacing;

    // Accuracy: pred -> GT nearest-sample distances, exactly as compare_samples().
    const double half_over_n = 0.5 / static_cast<double>(n);
    Eigen::VectorXf p2g;
    const IndexVector p2g_nn = gt_tree.nearest(ps.points.cast<float>(), &p2g);
    std::vector<Eigen::Index> main_ids;
    for (Eigen::Index i = 0; i < n; ++i) {
        const double sq = static_cast<double>(p2g(i)) * static_cast<double>(p2g(i)) * half_over_n;
        if (away[static_cast<std::size_t>(i)]) {
            d.accuracy_away_l2 += sq;
        } else {
            d.accuracy_main_l2 += sq;
            main_ids.push_back(i);
        }
    }
    d.accuracy_l2 = d.accuracy_away_l2 + d.accuracy_main_l2;
    d.away_sample_fraction = 1.0 - static_cast<double>(main_ids.size()) / static_cast<double>(n);

    // Offset and roughness of the main surface: exact distance to the GT, signed by the normal of
    // the nearest GT sample; a closed oriented GT with negative volume has inward faces, so flip.
    if (!main_ids.empty()) {
        const Points main_points = ps.points(main_ids, Eigen::all);
        const Eigen::VectorXd exact = point_to_mesh_distance(gt_f, main_points);
        double flip = 1.0;
        const MeshTopology gt_topology = mesh_topology(gt_f);
        if (gt_topology.closed_manifold_oriented()) {
            double volume = 0.0;
            for (Eigen::Index f = 0; f < gt_f.faces.rows(); ++f) {
                const Eigen::Vector3d a = gt_f.vertices.row(gt_f.faces(f, 0)), b = gt_f.vertices.row(gt_f.faces(f, 1)),
                                      c = gt_f.vertices.row(gt_f.faces(f, 2));
                volume += a.dot(b.cross(c)) / 6.0;
            }
            flip = volume < 0 ? -1.0 : 1.0;
            d.offset_signed_by_closed_gt = true;
        }
        Eigen::VectorXd signed_d(static_cast<Eigen::Index>(main_ids.size()));
        for (Eigen::Index k = 0; k < signed_d.size(); ++k) {
            const Eigen::Index i = main_ids[static_cast<std::size_t>(k)];
            const Eigen::Index q = p2g_nn(i);
            const double side = (ps.points.row(i) - gs.points.row(q)).dot(gs.normals.row(q));
            signed_d(k) = (side < 0 ? -flip : flip) * exact(k);
        }
        d.offset = signed_d.mean();
        d.roughness = std::sqrt((signed_d.array() - d.offset).square().mean());
        d.mean_abs_distance = exact.mean();
    }

    // Completeness: GT -> pred nearest-sample distances; missing by the exact distance to pred.
    Eigen::VectorXf g2p;
    pred_tree.nearest(gs.points.cast<float>(), &g2p);
    const Eigen::VectorXd to_pred = point_to_mesh_distance(pred_f, gs.points);
    Eigen::Index missing = 0;
    for (Eigen::Index i = 0; i < n; ++i) {
        const double sq = static_cast<double>(g2p(i)) * static_cast<double>(g2p(i)) * half_over_n;
        if (to_pred(i) > d.near_threshold) {
            ++missing;
            d.completeness_missing_l2 += sq;
        } else {
            d.completeness_rest_l2 += sq;
        }
    }
    d.completeness_l2 = d.completeness_missing_l2 + d.completeness_rest_l2;
    d.missing_area_fraction = static_cast<double>(missing) / static_cast<double>(n);
    d.chamfer_l2 = d.accuracy_l2 + d.completeness_l2;
    return d;
}

}  // namespace pcp
