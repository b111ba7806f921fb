// Clouds with the defects of real scans, made from a ground-truth mesh (not in the paper): the
// benchmark of what a scan does to a reconstruction (bench/pcp_make_defects, docs/BENCHMARKS.md).
// Every cloud is seeded and sampled by area on the mesh; lengths are fractions of the mesh's
// bounding-box diagonal, so a class means the same on every mesh. The classes:
//   clean        points on the surface, no noise
//   outliers     2 % of the points uniform in the box grown by 5 %
//   density      the density varying 1:20 along an axis (exponential in the coordinate)
//   sparse       3,000 points
//   one-sided    three cameras on one side (within 35 degrees of an axis, at twice the diagonal), each
//                keeping the samples nearest to it in its depth image; noise 0.1 % along the rays
//   hole         a cap of 3.6 % of the points (those nearest a surface point) left out
//   stripes      only the points in 60 parallel slabs across an axis, 40 % of each period
//   misregistered  two scans of half the points each, the second shifted by 0.3 %
//   heavy-noise  Gaussian noise of 1 %
//   mixed        density 1:5, noise 0.3 %, 1 % outliers
#pragma once

#include "pcp/core/types.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace pcp {

enum class Defect { Clean, Outliers, Density, Sparse, OneSided, Hole, Stripes, Misregistered, HeavyNoise, Mixed };

/// Every class, in the order above.
const std::vector<Defect>& all_defects();
std::string to_string(Defect defect);
/// The class called `name` (as to_string); throws pcp::Error listing the names otherwise.
Defect parse_defect(const std::string& name);

struct DefectOptions {
    Eigen::Index points = 20000;  ///< the cloud's size (the sparse class: 3,000; the one-sided class: at most this)
    std::uint64_t seed = 1;
    int axis = -1;                ///< the axis of the density gradient, the stripes and the cameras (-1: chosen by the seed)
};

/// The cloud of class `defect` made from `mesh` (its frame). Throws pcp::Error for a mesh with no
/// area or a face index out of range.
Points make_defect_cloud(const Mesh& mesh, Defect defect, const DefectOptions& options = {});

}  // namespace pcp
