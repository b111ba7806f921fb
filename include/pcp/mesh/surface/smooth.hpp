// Mesh smoothing for noisy clouds (not in the paper). The surface of a noisy cloud keeps the
// noise's bumps even after the surface fit (surface_fit.hpp), because the data under each vertex is
// itself noisy: normal consistency suffers most (docs/NOTEBOOK.md, "Cavity fill and smoothing of
// noisy clouds").
// pcp::reconstruct runs the bilateral normal filter on the meshes of the clouds it denoised.
#pragma once

#include "pcp/core/types.hpp"

namespace pcp {

/// Bilateral normal filtering (Zheng et al. 2011, "Bilateral normal filtering for mesh denoising")
/// followed by the vertex update of Sun et al. 2007: each face normal becomes the average of the
/// normals of the faces sharing a vertex with it, weighted by area x exp(-d^2 / 2 sigma_s^2) (d the
/// distance between face centroids, sigma_s = spatial x the mean such distance) x exp(-|n_f - n_g|^2
/// / 2 sigma_r^2), `normal_iterations` times; then the vertices are moved `vertex_iterations` times
/// onto the planes of their faces' filtered normals. Flat faces get flat and sharp edges stay sharp
/// (the normals of the two sides differ by more than sigma_r), where a Laplacian smoothing rounds them.
struct BilateralOptions {
    int normal_iterations = 40;
    int vertex_iterations = 40;
    double sigma_r = 0.5;    ///< normal difference scale (|n_f - n_g| in [0, 2])
    double spatial = 1.0;    ///< sigma_s in units of the mean distance between neighbouring face centroids
};
Mesh bilateral_smooth(const Mesh& mesh, const BilateralOptions& options = {});

/// Whether pcp::reconstruct smooths the final mesh, and how.
struct SmoothOptions {
    bool enabled = false;  ///< clean clouds' meshes (NoisyCloudOptions::smooth for the clouds the pipeline denoised)
    BilateralOptions bilateral;
};

}  // namespace pcp
