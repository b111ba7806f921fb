// Winding-number sign correction (see include/pcp/mesh/sign/winding_sign.hpp).
#include "pcp/mesh/sign/winding_sign.hpp"

#include "pcp/core/error.hpp"


#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <vector>

namespace pcp {

namespace {

constexpr double kFourPi = 4.0 * 3.14159265358979323846;
constexpr int kLeafSize = 8;

/// A Barnes-Hut node: the points [begin, end) of the permuted order, their area-weighted centre,
/// dipole sum_i a_i n_i and radius around the centre; children -1 for a leaf.
struct Node {
    Eigen::Vector3f centre = Eigen::Vector3f::Zero();
    Eigen::Vector3f dipole = Eigen::Vector3f::Zero();
    float radius = 0;
    std::int32_t begin = 0, end = 0, left = -1, right = -1;
};

float dipole_term(const Eigen::Vector3f& source, const Eigen::Vector3f& moment, const Eigen::Vector3f& q) {
    const Eigen::Vector3f d = source - q;
    const float r2 = d.squaredNorm();
    if (r2 <= 1e-20f) return 0.0f;
    return moment.dot(d) / (r2 * std::sqrt(r2));
}

void check_options(const WindingSignOptions& options) {
    check_field_normals_options(options.normals, "winding sign");
    PCP_CHECK(options.near_k >= 0 && std::isfinite(options.near_k), "winding sign: near_k must be >= 0");
    PCP_CHECK(options.labels_near_k >= 0 && std::isfinite(options.labels_near_k), "winding sign: labels_near_k must be >= 0");
    PCP_CHECK(options.margin >= 0 && options.margin < 0.5, "winding sign: margin must be in [0, 0.5)");
    PCP_CHECK(options.opening >= 1 && std::isfinite(options.opening), "winding sign: opening must be >= 1");
    PCP_CHECK(options.precheck_points >= 0, "winding sign: precheck_points must be >= 0");
    PCP_CHECK(options.precheck_slack >= 0 && options.precheck_slack <= 1, "winding sign: precheck_slack must be in [0, 1]");
}

}  // namespace

struct WindingSign::Impl {
    WindingSignOptions options;
    const KdTree* cloud = nullptr;
    PointsF normals;
    Eigen::VectorXf areas;
    // Barnes-Hut tree over the points in `order`; positions and moments a_i n_i stored permuted.
    std::vector<Node> nodes;
    PointsF sorted_points, sorted_moments;
    WindingSignStats stats;
    /// Per point, the distance within which the field keeps its sign: labels_near_k scales around a
    /// point the labels' spread oriented, tau around the others (labels' normals only; empty: tau).
    std::vector<float> reach;
    /// The label grid of the constructor from labels (empty otherwise; without its cell lists):
    /// apply() makes its outside cells outside.
    VisibilityLabels labels;
    mutable std::atomic<std::int64_t> corrected{0};

    int build(std::vector<std::int32_t>& order, int begin, int end, const PointsF& pts) {
        const int id = static_cast<int>(nodes.size());
        nodes.emplace_back();
        Node node;
        node.begin = begin;
        node.end = end;
        double area = 0;
        Eigen::Vector3d centre = Eigen::Vector3d::Zero(), dipole = Eigen::Vector3d::Zero();
        Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::max()), hi = -lo;
        for (int i = begin; i < end; ++i) {
            const std::int32_t p = order[static_cast<std::size_t>(i)];
            const double a = areas(p);
            area += a;
            centre += a * pts.row(p).transpose().cast<double>();
            dipole += a * normals.row(p).transpose().cast<double>();
            lo = lo.cwiseMin(pts.row(p).transpose());
            hi = hi.cwiseMax(pts.row(p).transpose());
        }
        node.centre = area > 0 ? Eigen::Vector3f((centre / area).cast<float>()) : Eigen::Vector3f(0.5f * (lo + hi));
        node.dipole = dipole.cast<float>();
        for (int i = begin; i < end; ++i)
            node.radius = std::max(node.radius, (pts.row(order[static_cast<std::size_t>(i)]).transpose() - node.centre).norm());
        if (end - begin > kLeafSize) {
            int axis = 0;
            (hi - lo).maxCoeff(&axis);
            const int mid = begin + (end - begin) / 2;
            std::nth_element(order.begin() + begin, order.begin() + mid, order.begin() + end,
                             [&](std::int32_t a, std::int32_t b) { return pts(a, axis) < pts(b, axis); });
            node.left = build(order, begin, mid, pts);
            node.right = build(order, mid, end, pts);
        }
        nodes[static_cast<std::size_t>(id)] = node;
        return id;
    }

    /// The constructors' common start: the options checked and kept; false when disabled (the
    /// identity), else the cloud, its size and tau recorded.
    bool start(const WindingSignOptions& o, const KdTree& tree) {
        options = o;
        check_options(o);
        if (!o.enabled) return false;
        cloud = &tree;
        stats.points = tree.size();
        stats.tau = o.near_k * sampling_scale(tree);
        return true;
    }

    /// Step 2 from oriented normals: the areas, the enclosed volume's sign and the Barnes-Hut tree.
    void adopt(FieldNormals oriented, const KdTree& tree) {
        const PointsF& pts = tree.points();
        const Eigen::Index n = pts.rows();
        normals = std::move(oriented.normals);
        stats.weak_orientation = oriented.stats.weak_orientation;
        stats.against_own_vote = oriented.stats.against_own_vote;

        // 2. Areas and the Barnes-Hut tree.
        const int ka = static_cast<int>(std::min<Eigen::Index>(9, n));  // 8 other points + the point itself
        const Eigen::VectorXf rk = tree.kth_distance(pts, ka);
        areas = (rk.array().square() * static_cast<float>(3.14159265358979323846 / (ka - 1))).matrix();
        // The enclosed volume, (1/3) sum_i a_i n_i . (p_i - c), is positive for outward normals. A
        // field negative outside (a wrong global sign) would orient them all inward and the winding
        // number would be -1 inside: then the normals are turned, so w is a proper inside indicator
        // whatever the field's convention.
        {
            const Eigen::RowVector3d c = pts.cast<double>().colwise().mean();
            double volume = 0;
            for (Eigen::Index i = 0; i < n; ++i)
                volume += double(areas(i)) * normals.row(i).cast<double>().dot(pts.row(i).cast<double>() - c) / 3.0;
            stats.inward = volume < 0;
            if (stats.inward) normals = -normals;
        }
        std::vector<std::int32_t> order(static_cast<std::size_t>(n));
        std::iota(order.begin(), order.end(), 0);
        nodes.reserve(static_cast<std::size_t>(2 * n / kLeafSize + 16));
        build(order, 0, static_cast<int>(n), pts);
        sorted_points.resize(n, 3);
        sorted_moments.resize(n, 3);
        for (Eigen::Index i = 0; i < n; ++i) {
            const std::int32_t p = order[static_cast<std::size_t>(i)];
            sorted_points.row(i) = pts.row(p);
            sorted_moments.row(i) = areas(p) * normals.row(p);
        }
    }

    float winding_at(const Eigen::Vector3f& q) const {
        const float open2 = static_cast<float>(options.opening * options.opening);
        double sum = 0;
        std::int32_t stack[128];
        int top = 0;
        stack[top++] = 0;
        while (top > 0) {
            const Node& n = nodes[static_cast<std::size_t>(stack[--top])];
            const float d2 = (n.centre - q).squaredNorm();
            if (d2 > open2 * n.radius * n.radius) {
                sum += dipole_term(n.centre, n.dipole, q);
            } else if (n.left < 0) {
                for (std::int32_t i = n.begin; i < n.end; ++i)
                    sum += dipole_term(sorted_points.row(i).transpose(), sorted_moments.row(i).transpose(), q);
            } else {
                stack[top++] = n.left;
                stack[top++] = n.right;
            }
        }
        return static_cast<float>(sum / kFourPi);
    }
};

WindingSign::WindingSign() : impl_(std::make_unique<Impl>()) { impl_->options.enabled = false; }
WindingSign::~WindingSign() = default;
WindingSign::WindingSign(WindingSign&&) noexcept = default;
WindingSign& WindingSign::operator=(WindingSign&&) noexcept = default;

WindingSign::WindingSign(const SdfBatchFn& field, const KdTree& cloud, const WindingSignOptions& options)
    : impl_(std::make_unique<Impl>()) {
    Impl& m = *impl_;
    const auto t0 = std::chrono::steady_clock::now();
    if (!m.start(options, cloud)) return;
    const Eigen::Index n = cloud.size();

    // 0. A sample first: a cloud the field clearly cannot orient is skipped at a fraction of the cost.
    if (options.precheck_points > 0 && n > 2 * Eigen::Index(options.precheck_points)) {
        const double estimate = confident_vote_fraction(field, cloud, options.normals, options.precheck_points);
        if (estimate < options.min_confident - options.precheck_slack) {
            m.stats.confident = std::llround(estimate * double(n));
            m.stats.sampled = options.precheck_points;
            m.stats.skipped = true;
            m.stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            return;
        }
    }

    // 1. PCA normals, oriented by the field's votes (field_normals.hpp).
    FieldNormals oriented = orient_normals_by_field(field, cloud, options.normals);
    m.stats.confident = oriented.stats.confident;
    if (double(m.stats.confident) < options.min_confident * double(n)) {
        // The field is flat or unsigned near most of the data (a very noisy cloud): it cannot
        // orient the points, and a winding number of badly oriented points would do harm.
        m.stats.skipped = true;
        m.stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        return;
    }
    m.adopt(std::move(oriented), cloud);
    m.stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

WindingSign::WindingSign(const VisibilityLabels& labels, const KdTree& cloud, const WindingSignOptions& options)
    : impl_(std::make_unique<Impl>()) {
    Impl& m = *impl_;
    const auto t0 = std::chrono::steady_clock::now();
    if (!m.start(options, cloud)) return;
    const Eigen::Index n = cloud.size();
    m.stats.by_labels = true;
    // 1. PCA normals, oriented by which side the labels see outside (field_normals.hpp).
    FieldNormals oriented = orient_normals_by_labels(labels, cloud, options.normals);
    m.stats.confident = oriented.stats.confident;
    if (double(m.stats.confident) < options.min_confident * double(n)) {
        // Too few points with an outside on one side only (thin parts seen from both sides, or a
        // cloud too small for the label cells): the orientation would be a guess.
        m.stats.skipped = true;
    } else {
        const auto weak_reach = static_cast<float>(options.labels_near_k * sampling_scale(cloud));
        m.reach.resize(static_cast<std::size_t>(n));
        for (Eigen::Index i = 0; i < n; ++i)
            m.reach[static_cast<std::size_t>(i)] =
                std::abs(oriented.votes(i)) < options.normals.confident_vote ? weak_reach : static_cast<float>(m.stats.tau);
        m.adopt(std::move(oriented), cloud);
        // A cell the rays see outside is outside, whatever w: the middle of a bore whose wall the
        // scanner missed sees the rest of the part around it.
        m.labels.origin = labels.origin;
        m.labels.cell = labels.cell;
        m.labels.dims = labels.dims;
        m.labels.label = labels.label;
    }
    m.stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

Eigen::VectorXf WindingSign::winding(const Eigen::Ref<const PointsF>& points) const {
    const Impl& m = *impl_;
    Eigen::VectorXf w = Eigen::VectorXf::Zero(points.rows());
    if (m.nodes.empty()) return w;
    for (Eigen::Index i = 0; i < points.rows(); ++i) w(i) = m.winding_at(points.row(i).transpose());
    return w;
}

void WindingSign::apply(const Eigen::Ref<const PointsF>& points, Eigen::Ref<Eigen::VectorXf> values) const {
    const Impl& m = *impl_;
    if (!active()) return;
    PCP_CHECK(points.rows() == values.size(), "winding sign: " << points.rows() << " points but " << values.size() << " values");
    // With the labels' normals, a sample whose nearest point took its orientation from its
    // neighbours (a thin part seen from both sides) is decided only beyond labels_near_k.
    NeighborIndices nearest;
    NeighborDistances dist;
    m.cloud->knn(points, 1, nearest, dist);
    const float tau = static_cast<float>(m.stats.tau), lo = static_cast<float>(0.5 - m.options.margin),
                hi = static_cast<float>(0.5 + m.options.margin);
    std::int64_t changed = 0;
    for (Eigen::Index i = 0; i < points.rows(); ++i) {
        if (dist(i, 0) <= (m.reach.empty() ? tau : m.reach[static_cast<std::size_t>(nearest(i, 0))])) continue;
        // A cell the rays see outside is outside, whatever w (most of the grid: no tree walk).
        if (!m.labels.label.empty() && m.labels.label_at(points.row(i).transpose().cast<double>()) > 0) {
            if (values(i) < 0) {
                values(i) = -values(i);
                ++changed;
            }
            continue;
        }
        const float w = m.winding_at(points.row(i).transpose());
        if ((w > hi && values(i) > 0) || (w < lo && values(i) < 0)) {
            values(i) = -values(i);
            ++changed;
        }
    }
    m.corrected += changed;
}

const PointsF& WindingSign::normals() const { return impl_->normals; }
const Eigen::VectorXf& WindingSign::areas() const { return impl_->areas; }
const WindingSignStats& WindingSign::stats() const { return impl_->stats; }
bool WindingSign::active() const { return impl_->options.enabled && !impl_->nodes.empty(); }
std::int64_t WindingSign::corrected() const { return impl_->corrected.load(); }

Eigen::VectorXf winding_number_brute_force(const Eigen::Ref<const PointsF>& points, const Eigen::Ref<const PointsF>& normals,
                                           const Eigen::Ref<const Eigen::VectorXf>& areas,
                                           const Eigen::Ref<const PointsF>& queries) {
    PCP_CHECK(points.rows() == normals.rows() && points.rows() == areas.size(),
              "winding number: points, normals and areas differ in count");
    Eigen::VectorXf w(queries.rows());
    for (Eigen::Index q = 0; q < queries.rows(); ++q) {
        double sum = 0;
        for (Eigen::Index i = 0; i < points.rows(); ++i)
            sum += dipole_term(points.row(i).transpose(), areas(i) * normals.row(i).transpose(), queries.row(q).transpose());
        w(q) = static_cast<float>(sum / kFourPi);
    }
    return w;
}

}  // namespace pcp
