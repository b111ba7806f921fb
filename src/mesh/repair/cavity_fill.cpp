// Cavity fill on the dense fine grid (see include/pcp/mesh/repair/cavity_fill.hpp).
#include "pcp/mesh/repair/cavity_fill.hpp"

#include "pcp/core/error.hpp"
#include "mesh/grid/grid_samples.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

namespace pcp {

namespace {

enum Label : std::uint8_t { kNone = 0, kOutside = 1, kCavity = 2 };

}  // namespace

CavityFillStats fill_cavities(SdfGrid& grid, const CavityFillOptions& options, const VisibilityLabels* labels, const KdTree* data) {
    PCP_CHECK(options.core_cells > 0 && std::isfinite(options.core_cells), "cavity fill: core_cells must be > 0");
    PCP_CHECK(options.max_open >= 0 && options.max_open <= 1, "cavity fill: max_open must be in [0, 1]");
    PCP_CHECK(options.min_label_votes >= 0, "cavity fill: min_label_votes must be >= 0");
    CavityFillStats st;
    if (!options.enabled) return st;
    PCP_CHECK(options.labelled_max_open >= 0 && options.labelled_max_open <= 1, "cavity fill: labelled_max_open must be in [0, 1]");
    PCP_CHECK(options.supported_openings >= 0 && options.support_k > 0 && std::isfinite(options.support_k),
              "cavity fill: supported_openings must be >= 0 and support_k > 0");
    const bool vote = labels && options.min_label_votes > 0 && !labels->label.empty();
    const int R = grid.spec.resolution, n1 = R + 1;
    const std::int64_t total = std::int64_t(n1) * n1 * n1;
    const std::int64_t dense_blocks = std::int64_t(grid.blocks_per_axis) * grid.blocks_per_axis * grid.blocks_per_axis;
    if (total > options.max_samples || grid.num_blocks() != dense_blocks) {
        st.skipped = true;
        return st;
    }
    st.delta = options.core_cells * grid.spec.spacing().maxCoeff();
    const float delta = static_cast<float>(st.delta);
    const std::vector<float> value = detail::lattice_values(grid);
    for (float v : value) PCP_CHECK(!std::isnan(v), "cavity fill: the dense grid misses a sample");

    // The visibility label of every sample: -1 inside, +1 outside, 0 unknown or near the data.
    std::vector<std::int8_t> sight;
    if (vote) {
        sight.resize(static_cast<std::size_t>(total));
        for (std::int64_t g = 0; g < total; ++g)
            sight[static_cast<std::size_t>(g)] = static_cast<std::int8_t>(
                labels->label_at(grid.spec.sample_position(g % n1, (g / n1) % n1, g / (std::int64_t(n1) * n1))));
    }
    auto seen_at = [&sight](std::size_t g) { return sight.empty() ? 0 : int(sight[g]); };
    std::vector<std::uint8_t> label(static_cast<std::size_t>(total), kNone);
    std::vector<std::int64_t> front, next;
    auto neighbours = [n1](std::int64_t g, std::int64_t out[6]) {
        const std::int64_t i = g % n1, j = (g / n1) % n1, k = g / (std::int64_t(n1) * n1);
        int n = 0;
        if (i > 0) out[n++] = g - 1;
        if (i + 1 < n1) out[n++] = g + 1;
        if (j > 0) out[n++] = g - n1;
        if (j + 1 < n1) out[n++] = g + n1;
        if (k > 0) out[n++] = g - std::int64_t(n1) * n1;
        if (k + 1 < n1) out[n++] = g + std::int64_t(n1) * n1;
        return n;
    };
    // 1. The outside: from the box's faces through samples with F > delta; with labels also from
    //    every positive sample labelled outside, and never into a sample labelled inside.
    for (std::int64_t g = 0; g < total; ++g) {
        const std::int64_t i = g % n1, j = (g / n1) % n1, k = g / (std::int64_t(n1) * n1);
        const bool face = i == 0 || j == 0 || k == 0 || i == R || j == R || k == R;
        const float v = value[static_cast<std::size_t>(g)];
        if ((face && v > delta) || (v > 0.0f && seen_at(static_cast<std::size_t>(g)) > 0)) {
            label[static_cast<std::size_t>(g)] = kOutside;
            front.push_back(g);
        }
    }
    std::int64_t nb[6];
    // Grows the labelled `front`, one 6-neighbour layer at a time, into the unlabelled samples whose
    // value is above `floor`; each takes the label of the sample it is reached from.
    auto grow = [&](float floor) {
        while (!front.empty()) {
            next.clear();
            for (std::int64_t g : front) {
                const int n = neighbours(g, nb);
                for (int a = 0; a < n; ++a) {
                    const auto h = static_cast<std::size_t>(nb[a]);
                    if (label[h] == kNone && value[h] > floor && !(label[static_cast<std::size_t>(g)] == kOutside && seen_at(h) < 0)) {
                        label[h] = label[static_cast<std::size_t>(g)];
                        next.push_back(nb[a]);
                    }
                }
            }
            front.swap(next);
        }
    };
    grow(delta);
    // 2. Cavity cores (and the positive samples labelled inside); 3. both grow one layer at a time
    //    through the remaining positive samples.
    front.clear();
    for (std::int64_t g = 0; g < total; ++g) {
        const auto s = static_cast<std::size_t>(g);
        if (label[s] == kNone && (value[s] > delta || (value[s] > 0.0f && seen_at(s) < 0))) label[s] = kCavity;
        if (label[s] != kNone) front.push_back(g);
    }
    grow(0.0f);
    // 4. Pockets: 6-connected components of the positive samples not labelled outside. A pocket is
    //    filled when little of its boundary is open to the outside (pairs with outside samples, at
    //    most max_open of its boundary pairs; the rest are pairs with negative samples): a cavity
    //    behind pinholes is, a bay of the outside that the core threshold cut off is not (filling
    //    it would put a sheet where the two fronts met, away from the data). A pocket the labels
    //    call inside may be more open (labelled_max_open): its walls are perforated, not absent.
    std::vector<std::uint8_t> flip(static_cast<std::size_t>(total), 0);
    {
        std::vector<std::uint8_t> seen(static_cast<std::size_t>(total), 0);
        std::vector<std::int64_t> stack, members, openings;
        double scale = -1;  // the data's sampling scale, computed when first needed
        for (std::int64_t g = 0; g < total; ++g) {
            const auto s0 = static_cast<std::size_t>(g);
            if (value[s0] <= 0.0f || label[s0] == kOutside || seen[s0]) continue;
            members.clear();
            stack.assign(1, g);
            seen[s0] = 1;
            std::int64_t open = 0, closed = 0;
            openings.clear();
            while (!stack.empty()) {
                const std::int64_t c = stack.back();
                stack.pop_back();
                members.push_back(c);
                const int n = neighbours(c, nb);
                for (int a = 0; a < n; ++a) {
                    const auto h = static_cast<std::size_t>(nb[a]);
                    if (value[h] <= 0.0f) {
                        ++closed;
                    } else if (label[h] == kOutside) {
                        ++open;
                        openings.push_back(nb[a]);
                    } else if (!seen[h]) {
                        seen[h] = 1;
                        stack.push_back(nb[a]);
                    }
                }
            }
            ++st.pockets;
            std::int64_t inside_votes = 0, outside_votes = 0;
            for (std::int64_t c : members) {
                inside_votes += seen_at(static_cast<std::size_t>(c)) < 0;
                outside_votes += seen_at(static_cast<std::size_t>(c)) > 0;
            }
            const bool labelled_inside = vote && inside_votes >= options.min_label_votes && 20 * outside_votes <= inside_votes;
            const double limit = labelled_inside ? std::max(options.labelled_max_open, options.max_open) : options.max_open;
            if (double(open) > limit * double(open + closed)) {
                // More open than that, but labelled inside and open only where the data is: a
                // wall the field perforated all over, not open space.
                if (!labelled_inside || !data || options.supported_openings > 1.0) continue;
                if (scale < 0) scale = sampling_scale(*data);
                std::int64_t supported = 0;
                for (std::int64_t o : openings) {
                    float d = 0;
                    data->nearest_point(grid.spec.sample_position(int(o % n1), int((o / n1) % n1), int(o / (std::int64_t(n1) * n1))).cast<float>(), &d);
                    supported += double(d) <= options.support_k * scale;
                }
                if (double(supported) < options.supported_openings * double(openings.size())) continue;
                ++st.supported_cavities;
            }
            st.labelled_cavities += labelled_inside && double(open) > options.max_open * double(open + closed);
            ++st.cavities;
            st.cavity_samples += static_cast<std::int64_t>(members.size());
            for (std::int64_t c : members) flip[static_cast<std::size_t>(c)] = 1;
        }
    }
    if (st.cavity_samples == 0) return st;
    detail::for_each_stored_sample(grid, [&](float& v, std::int64_t g) {
        if (flip[static_cast<std::size_t>(g)]) v = -v;
    });
    return st;
}

}  // namespace pcp
