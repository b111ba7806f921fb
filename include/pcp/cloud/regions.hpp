// Local regions for learning the context prior (METHOD.md section 1, paper section 3): the cloud's
// bounding box is split into an n x n x n grid; the points of each non-empty cell form a region,
// which is normalised by subtracting its centre and scaling its longest bounding-box edge to 1.
// The paper's ablations (table 11) are the four normalisation variants; grid = 1 is its "0^3"
// (no split).
#pragma once

#include "pcp/cloud/kdtree.hpp"
#include "pcp/core/types.hpp"

#include <string>
#include <vector>

namespace pcp {

enum class RegionNormalization { None, Center, Scale, Both };

/// "none" | "center" | "scale" | "both"; throws pcp::Error on anything else.
RegionNormalization parse_region_normalization(const std::string& name);
std::string to_string(RegionNormalization normalization);

struct RegionOptions {
    int grid = 6;  ///< cells per axis (paper: 6; its ablation: 1 = no split, 4, 8)
    RegionNormalization normalization = RegionNormalization::Both;
    /// Cells with fewer points are skipped (the query spread needs each point's 50th neighbour).
    Eigen::Index min_points = 51;
};

struct Region {
    Eigen::Vector3i cell = Eigen::Vector3i::Zero();  ///< grid cell (i, j, k)
    IndexVector point_ids;                           ///< indices into the unit-box cloud
    Eigen::Vector3f center = Eigen::Vector3f::Zero();  ///< subtracted (zero without centring)
    float scale = 1.0f;                              ///< divided by (one without scaling)

    /// unit-box coordinates (N x 3) -> region coordinates
    PointsF to_region(const Eigen::Ref<const PointsF>& unit) const;
    /// region coordinates (N x 3) -> unit-box coordinates
    PointsF from_region(const Eigen::Ref<const PointsF>& local) const;
};

/// Splits `unit_points` (N x 3, unit box) into the non-empty cells of an options.grid^3 grid over
/// their bounding box; cells with fewer than options.min_points points are dropped. Regions are
/// ordered by cell (x fastest). Every point belongs to exactly one cell.
std::vector<Region> split_into_regions(const Eigen::Ref<const PointsF>& unit_points,
                                       const RegionOptions& options);

/// The points of `region`, in region coordinates.
PointsF region_points(const Eigen::Ref<const PointsF>& unit_points, const Region& region);

}  // namespace pcp
