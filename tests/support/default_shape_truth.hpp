// The built-in default shape's noise-free surface as evaluation samples (points with their exact
// normals), for the e2e tests that score a reconstruction of it with pcp::evaluate.
#pragma once

#include "pcp/cloud/shapes.hpp"
#include "pcp/eval/eval.hpp"

namespace pcp::test {

inline SurfaceSamples default_shape_truth(Eigen::Index n = 20000, std::uint64_t seed = 2) {
    const PointCloud truth = sample_default_shape(n, 0.0, seed);
    SurfaceSamples gt;
    gt.points = truth.points;
    gt.normals.resize(truth.points.rows(), 3);
    gt.normals << truth.properties.at("nx"), truth.properties.at("ny"), truth.properties.at("nz");
    return gt;
}

}  // namespace pcp::test
