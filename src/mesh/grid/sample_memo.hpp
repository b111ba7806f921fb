// Private helper of the pipeline's mesh stage (src/pipeline/reconstruct.cpp): a field's values at
// the samples of one lattice, recorded while a grid on that lattice is evaluated and reused by a
// finer grid wherever its samples are the same points, so that the networks are not evaluated
// twice there (the sign repair's 64-cell grid and the 128-cell fine grid share every second fine
// sample: GridSpec::sample_position gives the same double, hence the same float point).
#pragma once

#include "pcp/mesh/grid/sdf_grid.hpp"

#include <atomic>
#include <cstdint>
#include <memory>

namespace pcp::detail {

class SampleMemo {
public:
    /// An empty record of the samples of `lattice` ((resolution + 1)^3 of them).
    explicit SampleMemo(const GridSpec& lattice);

    /// `field`, recording its value at every point it is given that is exactly a sample of the
    /// lattice (others pass through unrecorded). The returned function refers to this memo.
    SdfBatchFn recording(const SdfBatchFn& field);

    /// `field`, with the recorded value taken for every point that is exactly a recorded sample and
    /// `field` called once per batch on the rest. A field that gives a point the same value in any
    /// batch gets the values `field` alone gives (tests/mesh/grid/test_sample_memo.cpp). The networks
    /// nearly do: a point in the ragged last panel of a batch (fewer than the GEMM kernel's 4
    /// columns) goes through the kernel's remainder path, whose rounding can differ in the last bit;
    /// the meshes of the cases checked came out byte-identical (docs/NOTEBOOK.md, "Time to accuracy
    /// with 2400 steps").
    SdfBatchFn reusing(const SdfBatchFn& field);

    /// Points whose value `reusing` took from the record.
    std::int64_t reused() const { return reused_.load(); }

    /// The lattice sample at exactly the point p (its linear index (k n1 + j) n1 + i, n1 =
    /// resolution + 1), or -1: the nearest sample's position, recomputed, must equal p as floats.
    std::int64_t index_of(const Eigen::Vector3f& p) const;

private:
    GridSpec spec_;
    std::int64_t n1_;
    std::unique_ptr<std::atomic<float>[]> values_;  ///< NaN: not recorded
    std::atomic<std::int64_t> reused_{0};
};

}  // namespace pcp::detail
