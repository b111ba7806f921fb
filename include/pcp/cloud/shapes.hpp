// Procedural shapes with known surfaces, sampled into unoriented point clouds: the embedded
// default input of pcp_reconstruct (needs no file) and the ground truth of tests. Sampling is
// uniform by area and seeded.
#pragma once

#include "pcp/core/types.hpp"

#include <cstdint>

namespace pcp {

/// The built-in default shape: a block with sharp edges, a cylindrical through-hole (genus 1) and a
/// thin fin (0.03 thick) standing on it; about 1 unit long. `n` points uniform by area on its
/// surface, each displaced by isotropic Gaussian noise of standard deviation `noise`. The exact
/// outward normals are in properties "nx", "ny", "nz" (of the noise-free positions).
PointCloud sample_default_shape(Eigen::Index n, double noise, std::uint64_t seed);

/// Signed distance bound of the default shape (exact sign, negative inside; magnitude exact away
/// from the CSG seams).
double default_shape_sdf(const Eigen::Vector3d& p);

/// `n` points uniform on a sphere (normals in "nx","ny","nz").
PointCloud sample_sphere(Eigen::Index n, double radius, const Eigen::Vector3d& center, std::uint64_t seed);

/// `n` points uniform by area on a torus around the z axis (major radius R, minor radius r).
PointCloud sample_torus(Eigen::Index n, double major_radius, double minor_radius, std::uint64_t seed);

}  // namespace pcp
