// Sampling a signed distance function on a regular grid, sparsely: only the blocks of cells near
// the zero level set are evaluated and stored, so memory and SDF evaluations grow with the
// surface's area rather than with resolution^3 (METHOD.md §1 "evaluate F_g on a grid (narrow band
// near G is enough)", §5 "128^3 ... 512^3 ... bounding box + 0.05 margin"). Two ways to find the
// band (coarse-to-fine on an octree of blocks, or near the input points), a growth pass that
// follows the zero set out of the band so that culling never cuts the surface open, and the dense
// grid as the reference both are tested against. marching_cubes.hpp meshes the result.
#pragma once

#include "pcp/core/progress.hpp"
#include "pcp/core/types.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <functional>
#include <vector>

namespace pcp {

/// A signed distance function evaluated in batches: values(i) = sdf(points.row(i)).
/// @param[in]  points  N x 3, float, unit-box coordinates (a few thousand rows per call)
/// @param[out] values  N, negative inside, positive outside
/// It is called from several OpenMP threads at once with different batches, so it must be
/// thread-safe (a neural SDF keeps one evaluation cache per thread, omp_get_thread_num()), and it
/// must be finite everywhere in the grid box (a NaN or Inf is reported as pcp::Error).
using SdfBatchFn =
    std::function<void(const Eigen::Ref<const PointsF>& points, Eigen::Ref<Eigen::VectorXf> values)>;

/// The lattice: `resolution` cells per axis, resolution + 1 samples per axis; sample (i, j, k) is
/// at box.min + (i, j, k) .* box.extent() / resolution. Cells are cubes only if the box is one.
struct GridSpec {
    int resolution = 128;  ///< cells per axis (>= 2); METHOD.md §5: 128 (ShapeNet, ABC), 512 (FAMOUS, scenes)
    Aabb box;              ///< sampled box, unit-box coordinates, margin included; every extent > 0

    /// Cell size along each axis: box.extent() / resolution.
    Eigen::Vector3d spacing() const { return box.extent() / resolution; }
    /// Position of sample (i, j, k), 0 <= i, j, k <= resolution.
    Eigen::Vector3d sample_position(std::int64_t i, std::int64_t j, std::int64_t k) const {
        return box.min + (box.extent().array() * Eigen::Array3d(double(i), double(j), double(k)) / resolution)
                             .matrix();
    }
};

/// The grid over `bbox` grown by `margin` on every side (METHOD.md §5: bounding box + 0.05).
GridSpec make_grid_spec(const Aabb& bbox, int resolution, double margin = 0.05);

/// Which blocks are evaluated.
enum class NarrowBand {
    Dense,       ///< every block (the reference; resolution^3 memory)
    Coarse,      ///< coarse-to-fine: octree of blocks, a node is refined when |sdf(centre)| <=
                 ///< coarse_factor * its half-diagonal
    NearPoints,  ///< the blocks within point_band_cells cells of the band points
};

struct SdfGridOptions {
    NarrowBand band = NarrowBand::Coarse;
    int block_cells = 8;           ///< cells per block edge (2..64); a block stores (block_cells + 1)^3 floats
    double coarse_factor = 2.0;    ///< Coarse: safety factor on the half-diagonal (1 is exact for a true
                                   ///< distance; larger for an SDF that is only roughly a distance)
    double point_band_cells = 3.0; ///< NearPoints: keep blocks within this many cells (largest spacing) of a point
    bool grow = true;              ///< add every missing block into which the zero set crosses from a stored one,
                                   ///< until none is left: the band then never cuts the surface open
    /// Points per SdfBatchFn call (blocks are grouped up to this size; a block is at least one
    /// call). 512 (was 4096): a batch's activations then stay in the core's cache; `bench_nn`'s SDF
    /// evaluation at the default's sizes, 2 threads, 512 against 4096 points: 351,000 against
    /// 247,000 points/s natively and 270,000 against 211,000 built for AVX2 on a 2-core Emerald
    /// Rapids (docs/NOTEBOOK.md, "Two points under a supported vertex"); the values are the same.
    int batch_size = 512;
    /// Any band: the field is first evaluated at the stored blocks' corners only; a block whose 8
    /// corners have one sign and |sdf| > far_factor * its half-diagonal is far from the zero set
    /// (for a true distance, factor 1 is exact) and is filled by trilinear interpolation of its
    /// corners instead of being evaluated: every sample of the stored blocks is still stored (the
    /// cavity and tunnel fills need the whole lattice: Dense), with the right sign and a magnitude
    /// above (far_factor - 1) * half-diagonal for a 1-Lipschitz field, but only the cells near
    /// the zero set cost evaluations; the blocks the growth pass adds are refined the same way.
    /// 0 = evaluate every sample (the reference).
    double far_factor = 0.0;
    /// With far_factor: levels of the refinement. 1 = blocks only (a block that is not far
    /// is evaluated whole); each further level splits the cells that are not far into their 8
    /// halves and tests those the same way (their corners evaluated), so that at 3 levels of 8-cell
    /// blocks only the 2-cell cells near the zero set are evaluated whole. block_cells must be
    /// divisible by 2^(far_levels - 1).
    int far_levels = 1;
    ProgressCallback progress;     ///< stage "sdf-grid", step/total in SDF evaluations; false = cancel (pcp::Error)
};

/// What evaluate_sdf_grid did.
struct SdfGridStats {
    std::int64_t evaluations = 0;         ///< SDF values computed in total (coarse + blocks)
    std::int64_t coarse_evaluations = 0;  ///< of which octree node centres (Coarse band) or block corners (far_factor)
    std::int64_t interpolated_blocks = 0; ///< with far_factor: blocks filled from their corners
    std::int64_t interpolated_samples = 0; ///< with far_factor: samples filled from the corners of a far cell
    std::int64_t grown_blocks = 0;        ///< blocks added by the growth pass
    int growth_rounds = 0;                ///< growth passes that added blocks
};

/// A sparse, block-structured grid of SDF samples. Block (bx, by, bz) covers cells
/// [b * B, min(b * B + B, resolution)) on each axis (B = block_cells) and stores the samples of
/// its closed box, (B + 1)^3 floats, x fastest (entries beyond a truncated block's cells are NaN).
/// A sample on a face shared with a stored neighbour is evaluated once, by the block that owns it,
/// and copied to the others, so the blocks agree on every sign even if the SDF is not
/// bit-reproducible across batches, and a dense grid costs exactly (R + 1)^3 evaluations.
struct SdfGrid {
    GridSpec spec;
    int block_cells = 8;                   ///< B
    int blocks_per_axis = 0;               ///< ceil(resolution / B)
    std::vector<std::int64_t> block_keys;  ///< K stored blocks, sorted: (bz * nb + by) * nb + bx
    std::vector<float> values;             ///< K * (B + 1)^3 samples, block after block
    SdfGridStats stats;

    int num_blocks() const { return static_cast<int>(block_keys.size()); }
    /// Index of block (bx, by, bz) in block_keys, or -1 if it is not stored.
    int find_block(int bx, int by, int bz) const;
    /// Sample (i, j, k) (0..resolution) or NaN when no stored block holds it.
    float value(int i, int j, int k) const;
};

/// Evaluates `sdf` on the blocks selected by `options.band` (OpenMP over batches of blocks).
/// For NarrowBand::NearPoints use the overload with points. Throws pcp::Error on bad options
/// (resolution < 2, empty or non-finite box, block_cells outside 2..64, ...), on a non-finite SDF
/// value (naming the point), on an exception thrown by `sdf`, and on cancellation.
SdfGrid evaluate_sdf_grid(const SdfBatchFn& sdf, const GridSpec& spec, const SdfGridOptions& options = {});

/// As above; `band_points` (N x 3, unit-box coordinates) select the blocks for NarrowBand::NearPoints
/// and are ignored by the other modes.
SdfGrid evaluate_sdf_grid(const SdfBatchFn& sdf, const GridSpec& spec, const SdfGridOptions& options,
                          const Eigen::Ref<const PointsF>& band_points);

}  // namespace pcp
