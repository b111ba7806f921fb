// Sign repair on a coarse grid: components of one sign away from the data, flipped when most of
// their boundary is a zero crossing away from the data (see include/pcp/sign_repair.hpp).
#include "pcp/mesh/sign/sign_repair.hpp"

#include "pcp/core/error.hpp"
#include "pcp/cloud/kdtree.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <queue>
#include <unordered_map>

namespace pcp {
namespace {

/// Union-find over component ids with path halving.
struct Dsu {
    std::vector<int> parent;
    explicit Dsu(int n) : parent(static_cast<std::size_t>(n)) { std::iota(parent.begin(), parent.end(), 0); }
    int find(int a) {
        while (parent[a] != a) a = parent[a] = parent[parent[a]];
        return a;
    }
};

/// A region of one sign away from the data: a component, or several merged by flips.
struct Group {
    std::int64_t volume = 0;   ///< coarse samples
    std::int64_t near = 0;     ///< neighbour pairs (sample of the group, near sample)
    bool touches_box = false;  ///< holds a sample on the grid box's boundary
    int sign = 1;              ///< current sign, +1 or -1
    std::unordered_map<int, std::int64_t> across;  ///< root of an adjacent group of the other sign -> neighbour pairs
};

}  // namespace

SignRepair::SignRepair(const SdfBatchFn& field, const Aabb& box, const KdTree& tree, const SignRepairOptions& options,
                       const VisibilityLabels* labels) {
    const PointsF& points = tree.points();
    PCP_CHECK(options.resolution >= SignRepairOptions::kMinResolution && options.resolution <= SignRepairOptions::kMaxResolution,
              "sign repair: resolution must be in [" << SignRepairOptions::kMinResolution << ", "
                                                      << SignRepairOptions::kMaxResolution << "] (got " << options.resolution << ")");
    PCP_CHECK(options.near_cells >= 0 && options.near_spacings >= 0 && std::isfinite(options.near_cells) &&
                  std::isfinite(options.near_spacings),
              "sign repair: near_cells and near_spacings must be finite and >= 0");
    PCP_CHECK(options.max_unsupported >= 0 && options.max_unsupported < 1,
              "sign repair: max_unsupported must be in [0, 1) (got " << options.max_unsupported << ")");
    PCP_CHECK(options.min_label_votes >= 0, "sign repair: min_label_votes must be >= 0 (got " << options.min_label_votes << ")");
    PCP_CHECK(points.rows() >= 2, "sign repair: needs at least 2 points (got " << points.rows() << ")");
    spec_.resolution = options.resolution;
    spec_.box = box;
    if (!options.enabled) return;

    // 1. The coarse field, through the grid module's dense mode (same batching, same checks).
    SdfGridOptions go;
    go.band = NarrowBand::Dense;
    go.far_factor = options.far_factor;
    go.far_levels = options.far_levels;
    const SdfGrid grid = evaluate_sdf_grid(field, spec_, go);
    stats_.evaluations = grid.stats.evaluations;
    const int n1 = spec_.resolution + 1;
    const std::int64_t count = std::int64_t(n1) * n1 * n1;
    auto index = [n1](int i, int j, int k) { return (std::int64_t(k) * n1 + j) * n1 + i; };
    std::vector<std::int8_t> sign(static_cast<std::size_t>(count));
    PointsF nodes(count, 3);
    for (int k = 0; k < n1; ++k)
        for (int j = 0; j < n1; ++j)
            for (int i = 0; i < n1; ++i) {
                const std::int64_t n = index(i, j, k);
                sign[n] = grid.value(i, j, k) > 0.0f ? 1 : -1;
                nodes.row(n) = spec_.sample_position(i, j, k).cast<float>().transpose();
            }

    // 2. Near the data: within tau of an input point.
    const Eigen::VectorXf spacing = tree.kth_distance(points, 2);  // nearest other point
    std::vector<float> sorted(spacing.data(), spacing.data() + spacing.size());
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    const double median_spacing = sorted[sorted.size() / 2];
    stats_.tau = std::max(options.near_cells * spec_.spacing().maxCoeff(), options.near_spacings * median_spacing);
    const Eigen::VectorXf dist = tree.kth_distance(nodes, 1);
    std::vector<char> near(static_cast<std::size_t>(count));
    for (std::int64_t n = 0; n < count; ++n) near[n] = dist(n) <= stats_.tau;

    // 3a. Components: 6-neighbours of one sign, both away from the data (flood fill).
    std::vector<int> comp(static_cast<std::size_t>(count), -1);
    std::vector<Group> groups;
    std::vector<std::int64_t> stack;
    const int di[6] = {1, -1, 0, 0, 0, 0}, dj[6] = {0, 0, 1, -1, 0, 0}, dk[6] = {0, 0, 0, 0, 1, -1};
    for (std::int64_t seed = 0; seed < count; ++seed) {
        if (near[seed] || comp[seed] >= 0) continue;
        const int c = static_cast<int>(groups.size());
        groups.emplace_back();
        Group& g = groups.back();
        g.sign = sign[seed];
        comp[seed] = c;
        stack.assign(1, seed);
        while (!stack.empty()) {
            const std::int64_t n = stack.back();
            stack.pop_back();
            ++g.volume;
            const int i = int(n % n1), j = int((n / n1) % n1), k = int(n / (std::int64_t(n1) * n1));
            if (i == 0 || j == 0 || k == 0 || i == n1 - 1 || j == n1 - 1 || k == n1 - 1) g.touches_box = true;
            for (int d = 0; d < 6; ++d) {
                const int a = i + di[d], b = j + dj[d], e = k + dk[d];
                if (a < 0 || b < 0 || e < 0 || a >= n1 || b >= n1 || e >= n1) continue;
                const std::int64_t m = index(a, b, e);
                if (near[m] || sign[m] != g.sign || comp[m] >= 0) continue;
                comp[m] = c;
                stack.push_back(m);
            }
        }
    }
    // 3b. Boundary counts: each neighbour pair once (+x, +y, +z).
    for (int k = 0; k < n1; ++k)
        for (int j = 0; j < n1; ++j)
            for (int i = 0; i < n1; ++i) {
                const std::int64_t n = index(i, j, k);
                for (int d = 0; d < 6; d += 2) {
                    const int a = i + di[d], b = j + dj[d], e = k + dk[d];
                    if (a >= n1 || b >= n1 || e >= n1) continue;
                    const std::int64_t m = index(a, b, e);
                    const int cn = comp[n], cm = comp[m];
                    if (cn >= 0 && cm < 0) ++groups[cn].near;
                    if (cm >= 0 && cn < 0) ++groups[cm].near;
                    if (cn >= 0 && cm >= 0 && cn != cm) {  // different components side by side: other signs
                        ++groups[cn].across[cm];
                        ++groups[cm].across[cn];
                    }
                }
            }
    stats_.components = static_cast<int>(groups.size());

    // 3c. Flip, smallest region first; a flipped region merges with its neighbours (now its sign).
    const std::vector<int> original_sign = [&] {
        std::vector<int> s(groups.size());
        for (std::size_t c = 0; c < groups.size(); ++c) s[c] = groups[c].sign;
        return s;
    }();
    Dsu dsu(static_cast<int>(groups.size()));
    using Entry = std::pair<std::int64_t, int>;  // (volume when queued, group)
    std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> queue;
    for (std::size_t c = 0; c < groups.size(); ++c) queue.push({groups[c].volume, int(c)});
    while (!queue.empty()) {
        const auto [volume, c] = queue.top();
        queue.pop();
        if (dsu.find(c) != c || groups[c].volume != volume) continue;  // merged away, or re-queued
        Group& g = groups[c];
        std::int64_t away = 0;
        for (const auto& [other, pairs] : g.across) away += pairs;
        if (g.touches_box || away == 0 || double(away) <= options.max_unsupported * double(away + g.near)) continue;
        ++stats_.flipped_components;
        // Merge g and all its neighbours into the largest of them.
        std::vector<int> members{c};
        for (const auto& [other, pairs] : g.across) members.push_back(other);
        const int root = *std::max_element(members.begin(), members.end(),
                                           [&](int a, int b) { return groups[a].volume < groups[b].volume; });
        Group merged;
        merged.sign = -g.sign;
        for (int m : members) {
            Group& gm = groups[m];
            merged.volume += gm.volume;
            merged.near += gm.near;
            merged.touches_box = merged.touches_box || gm.touches_box;
        }
        for (int m : members) {
            for (const auto& [other, pairs] : groups[m].across) {
                if (std::find(members.begin(), members.end(), other) != members.end()) continue;
                merged.across[other] += pairs;
            }
        }
        for (int m : members) {
            dsu.parent[m] = root;
            if (m != root) groups[m] = Group{};
        }
        // The merged region's outer neighbours now point at root.
        for (const auto& [other, pairs] : merged.across) {
            auto& adj = groups[other].across;
            for (int m : members) adj.erase(m);
            adj[root] += pairs;
        }
        groups[root] = std::move(merged);
        queue.push({groups[root].volume, root});
    }

    // The sign of every sample away from the data after the component flips.
    std::vector<std::int8_t> current(static_cast<std::size_t>(count), 0);
    for (std::int64_t n = 0; n < count; ++n) {
        const int c = comp[n];
        if (c >= 0) current[n] = static_cast<std::int8_t>(groups[dsu.find(c)].sign != original_sign[c] ? -sign[n] : sign[n]);
    }

    // 3c'. Visibility labels: a negative region (after the flips) whose labelled samples mostly
    // say outside is flipped, unless it touches the box. Positive regions labelled inside are
    // left to the cavity fill, which also fills their layer near the data (a coarse flip would
    // leave that layer as an inner sheet).
    if (labels && options.min_label_votes > 0 && !labels->label.empty()) {
        std::unordered_map<int, std::pair<std::int64_t, std::int64_t>> votes;  // root -> (agree, disagree)
        for (std::int64_t n = 0; n < count; ++n) {
            if (near[n]) continue;
            const int l = labels->label_at(nodes.row(n).transpose().cast<double>());
            if (l == 0) continue;
            auto& v = votes[dsu.find(comp[n])];
            if ((current[n] > 0) == (l > 0)) ++v.first;
            else ++v.second;
        }
        std::vector<char> flip_root(groups.size(), 0);
        for (const auto& [root, v] : votes) {
            if (groups[root].touches_box || groups[root].sign > 0 || v.second < options.min_label_votes || v.second <= v.first)
                continue;
            flip_root[static_cast<std::size_t>(root)] = 1;
            ++stats_.label_flipped;
        }
        for (std::int64_t n = 0; n < count; ++n)
            if (!near[n] && flip_root[static_cast<std::size_t>(dsu.find(comp[n]))]) current[n] = static_cast<std::int8_t>(-current[n]);
    }

    // 4. Per coarse sample: near the data (0), kept (its sign), or flipped (twice its original sign).
    state_.assign(static_cast<std::size_t>(count), 0);
    for (std::int64_t n = 0; n < count; ++n) {
        if (near[n]) continue;
        const bool flip = current[n] != sign[n];
        state_[n] = static_cast<std::int8_t>(flip ? 2 * sign[n] : sign[n]);
        stats_.flipped_samples += flip;
    }
    if (stats_.flipped_samples == 0) state_.clear();
}

void SignRepair::apply(const Eigen::Ref<const PointsF>& points, Eigen::Ref<Eigen::VectorXf> values) const {
    PCP_CHECK(points.rows() == values.size(), "sign repair: " << points.rows() << " points but " << values.size() << " values");
    if (state_.empty()) return;
    const int R = spec_.resolution, n1 = R + 1;
    const Eigen::Array3f lo = spec_.box.min.cast<float>().array();
    const Eigen::Array3f inv = (double(R) / spec_.box.extent().array()).cast<float>();
    for (Eigen::Index p = 0; p < points.rows(); ++p) {
        const float v = values(p);
        const int s = v > 0.0f ? 1 : -1;
        const Eigen::Array3f t = (points.row(p).transpose().array() - lo) * inv;
        int c[3];
        float f[3];
        for (int a = 0; a < 3; ++a) {
            c[a] = std::clamp(static_cast<int>(std::floor(t(a))), 0, R - 1);
            f[a] = std::clamp(t(a) - float(c[a]), 0.0f, 1.0f);
        }
        // Trilinear vote among the cell's corners away from the data with the value's own sign:
        // flipped regions against kept ones.
        float vote = 0;
        for (int corner = 0; corner < 8; ++corner) {
            const int a = corner & 1, b = (corner >> 1) & 1, e = (corner >> 2) & 1;
            const std::int8_t state = state_[std::size_t((std::int64_t(c[2] + e) * n1 + (c[1] + b)) * n1 + (c[0] + a))];
            const float w = (a ? f[0] : 1 - f[0]) * (b ? f[1] : 1 - f[1]) * (e ? f[2] : 1 - f[2]);
            if (state == 2 * s) vote += w;
            else if (state == s) vote -= w;
        }
        if (vote <= 0) continue;
        values(p) = -v;
    }
}

}  // namespace pcp
