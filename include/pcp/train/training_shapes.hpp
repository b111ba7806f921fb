// Generated training data for a generic local context prior (the built-in prior, issue 16): random
// CSG compositions of primitives -- boxes, rounded boxes, cylinders, cones, spheres and ellipsoids,
// tori, capsules, thin plates and open shells -- joined by union, smooth union (blends), difference
// (holes, pockets, through-holes) and intersection (sharp cuts), sampled uniformly by area with
// several densities and noise levels. Everything is generated from a seed; no third-party data.
//
// Sampling: the shape's signed distance is meshed by marching cubes on a dense grid, points are
// drawn uniformly by area on the triangles and projected onto the zero level set by Newton steps
// along the distance's gradient, then displaced by Gaussian noise.
#pragma once

#include "pcp/core/types.hpp"
#include "pcp/train/prior.hpp"

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace pcp {

struct TrainingShapeOptions {
    int count = 48;                 ///< number of shapes (clouds)
    std::uint64_t seed = 1;         ///< shape i is drawn from the stream (seed, i)
    /// Points per cloud: shape i takes points[i % size()].
    std::vector<Eigen::Index> points = {10000, 20000, 40000};
    /// Noise standard deviation relative to the shape's bounding-box diagonal: shape i takes
    /// noise[(i / points.size()) % size()].
    std::vector<double> noise = {0.0, 0.0, 0.002, 0.005};
    int mesh_resolution = 160;      ///< marching-cubes cells per axis for the area sampling
};

/// One generated shape: its signed distance (negative inside, about 1 unit across) and a name
/// listing its construction (e.g. "shape_007 box-minus-cylinder").
struct TrainingShape {
    std::string name;
    std::function<double(const Eigen::Vector3d&)> sdf;
    Aabb box;  ///< a box containing the surface
};

/// Shape `index` of the family drawn with `seed` (deterministic).
TrainingShape make_training_shape(int index, std::uint64_t seed);

/// `n` points on `shape`'s surface, uniform by area, with Gaussian noise of standard deviation
/// `noise` (absolute); deterministic given the arguments.
Points sample_training_shape(const TrainingShape& shape, Eigen::Index n, double noise, std::uint64_t seed,
                             int mesh_resolution = 160);

/// The clouds of options.count generated shapes (OpenMP over shapes; identical for any thread count).
std::vector<TrainingCloud> generate_training_clouds(const TrainingShapeOptions& options);

}  // namespace pcp
