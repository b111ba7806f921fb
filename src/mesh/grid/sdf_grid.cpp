// Sparse SDF grid evaluation (include/pcp/sdf_grid.hpp): choosing the blocks of the narrow band
// (dense, coarse-to-fine octree, or near the band points), evaluating them in parallel batches
// through the caller's SdfBatchFn (each sample once: a sample shared by stored blocks is evaluated
// by its owner and copied to the others, so the blocks agree on it bit for bit), and the growth
// pass that adds every missing block the zero set crosses into.
//
// Letters: R = resolution (cells per axis), B = block_cells, S = B + 1 samples per block edge,
// nb = ceil(R / B) blocks per axis, K = stored blocks. Sample (i, j, k) of block (bx, by, bz) is
// global sample (bx * B + i, by * B + j, bz * B + k) and lives at values[blk * S^3 + (k * S + j) * S + i].
#include "pcp/mesh/grid/sdf_grid.hpp"

#include "pcp/core/error.hpp"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <exception>
#include <limits>
#include <mutex>
#include <utility>

namespace pcp {
namespace {

struct Layout {
    int R = 0, B = 0, S = 0, nb = 0;
    std::int64_t S3 = 0;

    std::int64_t key(int bx, int by, int bz) const { return (std::int64_t(bz) * nb + by) * nb + bx; }
    Eigen::Vector3i coords(std::int64_t k) const {
        return {int(k % nb), int((k / nb) % nb), int(k / (std::int64_t(nb) * nb))};
    }
    /// Cells of block coordinate b along one axis (B except for a truncated last block).
    int cells(int b) const { return std::min(B, R - b * B); }
    std::int64_t local_index(int i, int j, int k) const { return (std::int64_t(k) * S + j) * S + i; }
};

Layout make_layout(int resolution, int block_cells) {
    Layout L;
    L.R = resolution;
    L.B = block_cells;
    L.S = block_cells + 1;
    L.nb = (resolution + block_cells - 1) / block_cells;
    L.S3 = std::int64_t(L.S) * L.S * L.S;
    return L;
}

/// Runs bodies on several threads and keeps the first exception, to rethrow it after the
/// parallel region (an exception must not leave an OpenMP region).
class FirstError {
public:
    template <class F>
    void run(F&& body) {
        if (failed_.load(std::memory_order_relaxed)) return;
        try {
            body();
        } catch (...) {
            std::lock_guard<std::mutex> lock(mutex_);
            if (!error_) error_ = std::current_exception();
            failed_ = true;
        }
    }
    void rethrow() const {
        if (error_) std::rethrow_exception(error_);
    }

private:
    std::atomic<bool> failed_{false};
    std::mutex mutex_;
    std::exception_ptr error_;
};

void check_finite(const Eigen::Ref<const PointsF>& points, const Eigen::Ref<const Eigen::VectorXf>& values) {
    for (Eigen::Index i = 0; i < values.size(); ++i) {
        PCP_CHECK(std::isfinite(values[i]),
                  "sdf_grid: the SDF function returned " << values[i] << " at point (" << points(i, 0) << ", "
                      << points(i, 1) << ", " << points(i, 2)
                      << "); it must be finite everywhere in the grid box");
    }
}

void report(const SdfGridOptions& options, std::int64_t done, std::int64_t total,
            std::chrono::steady_clock::time_point start) {
    if (!options.progress) return;
    Progress p;
    p.stage = "sdf-grid";
    p.step = done;
    p.total = total;
    p.elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    PCP_CHECK(options.progress(p), "sdf_grid: cancelled by the progress callback");
}

/// values = sdf(points), in parallel batches of options.batch_size rows.
Eigen::VectorXf evaluate_points(const SdfBatchFn& sdf, const PointsF& points, const SdfGridOptions& options) {
    Eigen::VectorXf values(points.rows());
    const std::int64_t n = points.rows();
    const std::int64_t batches = (n + options.batch_size - 1) / options.batch_size;
    FirstError errors;
#pragma omp parallel for schedule(dynamic, 1)
    for (std::int64_t b = 0; b < batches; ++b) {
        errors.run([&] {
            const std::int64_t first = b * options.batch_size;
            const std::int64_t count = std::min<std::int64_t>(options.batch_size, n - first);
            sdf(points.middleRows(first, count), values.segment(first, count));
            check_finite(points.middleRows(first, count), values.segment(first, count));
        });
    }
    errors.rethrow();
    return values;
}

/// The grid while it is being built: blocks in evaluation order plus a sorted lookup.
struct Builder {
    Layout L;
    std::vector<std::int64_t> keys;
    std::vector<float> values;
    std::vector<std::pair<std::int64_t, int>> lookup;  // (key, index), sorted by key
    /// Block index by key, -1 where not stored: a table of nb^3 entries where that is at most
    /// kMaxTable (8-cell blocks up to 2,048 cells; 64 MiB), else empty and find() searches lookup.
    /// find() runs for every sample the refinement and the owner rule touch.
    std::vector<std::int32_t> table;
    static constexpr std::int64_t kMaxTable = std::int64_t(1) << 24;

    void rebuild_lookup() {
        lookup.resize(keys.size());
        for (std::size_t b = 0; b < keys.size(); ++b) lookup[b] = {keys[b], int(b)};
        std::sort(lookup.begin(), lookup.end());
        const std::int64_t n = std::int64_t(L.nb) * L.nb * L.nb;
        table.clear();
        if (n <= kMaxTable) {
            table.assign(std::size_t(n), -1);
            for (std::size_t b = 0; b < keys.size(); ++b) table[std::size_t(keys[b])] = std::int32_t(b);
        }
    }
    int find(int bx, int by, int bz) const {
        if (bx < 0 || by < 0 || bz < 0 || bx >= L.nb || by >= L.nb || bz >= L.nb) return -1;
        const std::int64_t k = L.key(bx, by, bz);
        if (!table.empty()) return table[std::size_t(k)];
        auto it = std::lower_bound(lookup.begin(), lookup.end(), std::make_pair(k, -1));
        return (it != lookup.end() && it->first == k) ? it->second : -1;
    }
};

/// A sample on a block face is held by up to 8 blocks. Its owner is the first stored block in a
/// fixed preference order that depends only on the sample (along each axis, the block that starts
/// at or before it first); every other copy takes the owner's value. Returns the owner's index and
/// sets O to its coordinates, or returns -2 when global sample g lies inside a single block.
int sample_owner(const Builder& G, const Eigen::Vector3i& g, Eigen::Vector3i& O) {
    const Layout& L = G.L;
    int cand[3][2], count[3];
    bool shared = false;
    for (int a = 0; a < 3; ++a) {
        cand[a][0] = std::min(g[a] / L.B, L.nb - 1);
        count[a] = 1;
        if (g[a] % L.B == 0 && g[a] / L.B - 1 >= 0 && g[a] / L.B - 1 != cand[a][0]) cand[a][count[a]++] = g[a] / L.B - 1;
        shared = shared || count[a] > 1;
    }
    if (!shared) return -2;
    for (int iz = 0; iz < count[2]; ++iz)
        for (int iy = 0; iy < count[1]; ++iy)
            for (int ix = 0; ix < count[0]; ++ix) {
                O = Eigen::Vector3i(cand[0][ix], cand[1][iy], cand[2][iz]);
                const int owner = G.find(O.x(), O.y(), O.z());
                if (owner >= 0) return owner;
            }
    return -1;
}

/// Calls visit(i, j, k) for the local samples of block b that b owns (the ones it must evaluate).
template <class Visit>
void for_each_owned_sample(const Builder& G, int b, Visit&& visit) {
    const Layout& L = G.L;
    const Eigen::Vector3i X = L.coords(G.keys[std::size_t(b)]);
    const Eigen::Vector3i c(L.cells(X.x()), L.cells(X.y()), L.cells(X.z()));
    Eigen::Vector3i O;
    for (int k = 0; k <= c.z(); ++k)
        for (int j = 0; j <= c.y(); ++j)
            for (int i = 0; i <= c.x(); ++i) {
                const int owner = sample_owner(G, X * L.B + Eigen::Vector3i(i, j, k), O);
                if (owner == -2 || owner == b) visit(i, j, k);
            }
}

/// Copies every shared sample's owner value into the other stored copies. The owner's own copy
/// is never written, so blocks can be processed in parallel.
void canonicalize(Builder& G) {
    const Layout& L = G.L;
#pragma omp parallel for schedule(dynamic, 16)
    for (std::int64_t b = 0; b < std::int64_t(G.keys.size()); ++b) {
        const Eigen::Vector3i X = L.coords(G.keys[std::size_t(b)]);
        const Eigen::Vector3i c(L.cells(X.x()), L.cells(X.y()), L.cells(X.z()));
        Eigen::Vector3i O;
        for (int k = 0; k <= c.z(); ++k)
            for (int j = 0; j <= c.y(); ++j)
                for (int i = 0; i <= c.x(); ++i) {
                    const Eigen::Vector3i g = X * L.B + Eigen::Vector3i(i, j, k);
                    const int owner = sample_owner(G, g, O);
                    if (owner < 0 || owner == int(b)) continue;
                    const Eigen::Vector3i lo = g - O * L.B;
                    G.values[std::size_t(b * L.S3 + L.local_index(i, j, k))] =
                        G.values[std::size_t(owner * L.S3 + L.local_index(lo.x(), lo.y(), lo.z()))];
                }
    }
}

/// Evaluates the samples that blocks [first, K) of G own (every sample of the block except those
/// a preferred stored neighbour owns; canonicalize copies those). Blocks are grouped into batches
/// of about options.batch_size points, batches run in parallel, and the progress callback is
/// called between chunks of batches on the calling thread. G.rebuild_lookup() must have run.
void evaluate_blocks(const SdfBatchFn& sdf, const GridSpec& spec, Builder& G, std::size_t first,
                     const SdfGridOptions& options, SdfGridStats& stats, std::chrono::steady_clock::time_point start) {
    const Layout& L = G.L;
    const std::size_t K = G.keys.size();
    std::vector<std::int64_t> block_samples(K - first);
#pragma omp parallel for schedule(dynamic, 16)
    for (std::int64_t b = std::int64_t(first); b < std::int64_t(K); ++b) {
        std::int64_t n = 0;
        for_each_owned_sample(G, int(b), [&n](int, int, int) { ++n; });
        block_samples[std::size_t(b) - first] = n;
    }
    // Group consecutive blocks up to batch_size samples (at least one block per group).
    std::vector<std::size_t> group_begin{first};
    std::int64_t in_group = 0, total = 0;
    for (std::size_t b = first; b < K; ++b) {
        const std::int64_t n = block_samples[b - first];
        if (in_group > 0 && in_group + n > options.batch_size) {
            group_begin.push_back(b);
            in_group = 0;
        }
        in_group += n;
        total += n;
    }
    group_begin.push_back(K);
    const std::int64_t groups = std::int64_t(group_begin.size()) - 1;
    const std::int64_t chunk = 16 * std::max(1, omp_get_max_threads());

    std::int64_t done = 0;
    if (first == 0) report(options, 0, total, start);  // the stage's first line, before any work
    for (std::int64_t c0 = 0; c0 < groups; c0 += chunk) {
        const std::int64_t c1 = std::min(groups, c0 + chunk);
        FirstError errors;
#pragma omp parallel
        {
            PointsF points;  // this thread's batch: up to batch_size rows (or one block)
            Eigen::VectorXf values;
#pragma omp for schedule(dynamic, 1)
            for (std::int64_t g = c0; g < c1; ++g) {
                errors.run([&] {
                    std::int64_t n = 0;
                    for (std::size_t b = group_begin[g]; b < group_begin[g + 1]; ++b) n += block_samples[b - first];
                    if (points.rows() < n) {
                        points.resize(n, 3);
                        values.resize(n);
                    }
                    std::int64_t row = 0;
                    for (std::size_t b = group_begin[g]; b < group_begin[g + 1]; ++b) {
                        const Eigen::Vector3i X = L.coords(G.keys[b]);
                        for_each_owned_sample(G, int(b), [&](int i, int j, int k) {
                            const Eigen::Vector3d p = spec.sample_position(std::int64_t(X.x()) * L.B + i,
                                                                           std::int64_t(X.y()) * L.B + j,
                                                                           std::int64_t(X.z()) * L.B + k);
                            points(row, 0) = static_cast<float>(p.x());
                            points(row, 1) = static_cast<float>(p.y());
                            points(row, 2) = static_cast<float>(p.z());
                            ++row;
                        });
                    }
                    sdf(points.topRows(n), values.head(n));
                    check_finite(points.topRows(n), values.head(n));
                    row = 0;
                    for (std::size_t b = group_begin[g]; b < group_begin[g + 1]; ++b) {
                        float* block = G.values.data() + std::int64_t(b) * L.S3;
                        for_each_owned_sample(G, int(b), [&](int i, int j, int k) {
                            block[L.local_index(i, j, k)] = values[row++];
                        });
                    }
                });
            }
        }
        errors.rethrow();
        for (std::int64_t g = c0; g < c1; ++g)
            for (std::size_t b = group_begin[g]; b < group_begin[g + 1]; ++b) done += block_samples[b - first];
        report(options, done, total, start);
    }
    stats.evaluations += total;
}

/// far_factor > 0: the stored blocks refined cell by cell down from the blocks, so that only the
/// samples near the zero set are evaluated. A cell of the current level whose 8 corners have one
/// sign and |value| > far_factor * its half-diagonal is far from the zero set; it is filled later
/// by trilinear interpolation of its corners. Any other cell is split into its 8 halves for the
/// next level (their corners evaluated), and at the last of options.far_levels levels every
/// sample of its closed box is evaluated. Every value is written to its owner block
/// (sample_owner); canonicalize copies it to the other blocks. The far and the evaluated cells
/// partition each block's half-open box (a cell holds the samples of its half-open box, plus
/// those on the grid's last plane), and a block owns its half-open box, so the parallel fill is
/// deterministic. A sparse band's block whose upper neighbour is not stored also owns the samples
/// of that upper face: a serial pass fills those a far cell left, in the fixed order of the cells.
class GridRefinement {
public:
    /// Refines blocks [first, K) of G (the samples they share with earlier blocks and own are
    /// evaluated or filled again).
    GridRefinement(const SdfBatchFn& sdf, const GridSpec& spec, Builder& G, std::size_t first, const SdfGridOptions& options,
                   SdfGridStats& stats, std::chrono::steady_clock::time_point start)
        : sdf_(sdf), spec_(spec), G_(G), L_(G.L), options_(options), stats_(stats), start_(start), first_(first),
          dense_(G.keys.size() == std::size_t(G.L.nb) * G.L.nb * G.L.nb),
          total_(dense_ ? std::int64_t(G.L.R + 1) * (G.L.R + 1) * (G.L.R + 1) : std::int64_t(G.keys.size() - first) * G.L.S3) {
        // A dense grid stores block key k at index k (evaluate_impl), which at() relies on.
        for (std::size_t k = 0; dense_ && k < G.keys.size(); ++k) PCP_CHECK(G.keys[k] == std::int64_t(k), "sdf_grid: dense blocks out of order");
    }

    void run() {
        report(options_, 0, total_, start_);
        std::vector<Cell> cells;
        cells.reserve(G_.keys.size() - first_);
        for (std::size_t b = first_; b < G_.keys.size(); ++b) cells.push_back({L_.coords(G_.keys[b]) * L_.B, L_.B});
        std::vector<Cell> far, last;
        for (int level = 0; !cells.empty(); ++level) {
            std::vector<std::int64_t> corners;
            for (const Cell& c : cells)
                for (int q = 0; q < 8; ++q) corners.push_back(linear(corner(c, q)));
            const std::int64_t evaluated = evaluate(corners);
            if (level == 0) stats_.coarse_evaluations += evaluated;
            std::vector<Cell> next;
            for (const Cell& c : cells) {
                if (is_far(c)) {
                    far.push_back(c);
                    if (level == 0) ++stats_.interpolated_blocks;
                } else if (level + 1 < options_.far_levels && c.size > 1) {
                    split(c, next);
                } else {
                    last.push_back(c);
                }
            }
            cells.swap(next);
        }
        // Every sample of the cells that may hold the zero set.
        std::vector<std::int64_t> samples;
        for (const Cell& c : last) {
            const Eigen::Vector3i e = extent(c);
            for (int k = 0; k <= e.z(); ++k)
                for (int j = 0; j <= e.y(); ++j)
                    for (int i = 0; i <= e.x(); ++i) samples.push_back(linear(c.origin + Eigen::Vector3i(i, j, k)));
        }
        evaluate(samples);
        fill(far);
        if (!dense_) fill_upper_faces(far);
        report(options_, total_, total_, start_);
    }

private:
    struct Cell {
        Eigen::Vector3i origin;  // lattice coordinates of its lowest sample
        int size;                // nominal cells per edge (truncated by the grid's end: extent())
    };

    Eigen::Vector3i extent(const Cell& c) const {
        return {std::min(c.size, L_.R - c.origin.x()), std::min(c.size, L_.R - c.origin.y()),
                std::min(c.size, L_.R - c.origin.z())};
    }
    /// Corner q (bit 0: +x, bit 1: +y, bit 2: +z).
    Eigen::Vector3i corner(const Cell& c, int q) const {
        const Eigen::Vector3i e = extent(c);
        return c.origin + Eigen::Vector3i(q & 1 ? e.x() : 0, q & 2 ? e.y() : 0, q & 4 ? e.z() : 0);
    }
    std::int64_t linear(const Eigen::Vector3i& g) const {
        const std::int64_t n1 = L_.R + 1;
        return (std::int64_t(g.z()) * n1 + g.y()) * n1 + g.x();
    }
    Eigen::Vector3i unlinear(std::int64_t n) const {
        const std::int64_t n1 = L_.R + 1;
        return {int(n % n1), int((n / n1) % n1), int(n / (n1 * n1))};
    }
    /// The owner's stored copy of global sample g, which must lie in a stored block's closed box
    /// (dense grid: the block that starts at or before it, whose index is its key).
    float& at(const Eigen::Vector3i& g) const {
        Eigen::Vector3i X(std::min(g.x() / L_.B, L_.nb - 1), std::min(g.y() / L_.B, L_.nb - 1),
                          std::min(g.z() / L_.B, L_.nb - 1));
        std::int64_t index = L_.key(X.x(), X.y(), X.z());
        if (!dense_) {
            Eigen::Vector3i O;
            const int owner = sample_owner(G_, g, O);
            if (owner >= 0) {
                X = O;
                index = owner;
            } else {
                index = G_.find(X.x(), X.y(), X.z());
            }
            PCP_CHECK(index >= 0, "sdf_grid: refinement sample " << g.transpose() << " lies in no stored block");
        }
        const Eigen::Vector3i l = g - X * L_.B;
        return G_.values[std::size_t(index * L_.S3 + L_.local_index(l.x(), l.y(), l.z()))];
    }
    bool is_far(const Cell& c) const {
        const double bound = options_.far_factor * 0.5 * (extent(c).cast<double>().array() * spec_.spacing().array()).matrix().norm();
        int positive = 0, negative = 0;
        for (int q = 0; q < 8; ++q) {
            const float value = at(corner(c, q));
            if (!(std::abs(double(value)) > bound)) return false;
            (value > 0 ? positive : negative) += 1;
        }
        return positive == 8 || negative == 8;
    }
    void split(const Cell& c, std::vector<Cell>& out) const {
        const int h = c.size / 2;
        for (int q = 0; q < 8; ++q) {
            const Eigen::Vector3i o = c.origin + Eigen::Vector3i(q & 1 ? h : 0, q & 2 ? h : 0, q & 4 ? h : 0);
            if ((o.array() < L_.R).all()) out.push_back({o, h});
        }
    }

    /// Evaluates the samples among `wanted` (global linear indices, repeats allowed) that have no
    /// value yet, in chunks with progress between them; returns how many.
    std::int64_t evaluate(std::vector<std::int64_t>& wanted) {
        std::sort(wanted.begin(), wanted.end());
        wanted.erase(std::unique(wanted.begin(), wanted.end()), wanted.end());
        wanted.erase(std::remove_if(wanted.begin(), wanted.end(), [&](std::int64_t n) { return !std::isnan(at(unlinear(n))); }),
                     wanted.end());
        const std::int64_t n = std::int64_t(wanted.size());
        const std::int64_t chunk = std::int64_t(options_.batch_size) * 16 * std::max(1, omp_get_max_threads());
        for (std::int64_t first = 0; first < n; first += chunk) {
            const std::int64_t count = std::min(chunk, n - first);
            PointsF points(count, 3);
            for (std::int64_t r = 0; r < count; ++r) {
                const Eigen::Vector3i g = unlinear(wanted[std::size_t(first + r)]);
                points.row(r) = spec_.sample_position(g.x(), g.y(), g.z()).cast<float>().transpose();
            }
            const Eigen::VectorXf values = evaluate_points(sdf_, points, options_);
            for (std::int64_t r = 0; r < count; ++r) at(unlinear(wanted[std::size_t(first + r)])) = values[r];
            done_ += count;
            report(options_, done_, total_, start_);
        }
        stats_.evaluations += n;
        return n;
    }

    /// Sample (i, j, k) of a cell of extent e from its corner values v (corner order of corner()).
    static float trilinear(const float v[8], const Eigen::Vector3i& e, int i, int j, int k) {
        const float x = float(i) / float(e.x()), y = float(j) / float(e.y()), z = float(k) / float(e.z());
        const float lo = (1 - y) * ((1 - x) * v[0] + x * v[1]) + y * ((1 - x) * v[2] + x * v[3]);
        const float hi = (1 - y) * ((1 - x) * v[4] + x * v[5]) + y * ((1 - x) * v[6] + x * v[7]);
        return (1 - z) * lo + z * hi;
    }

    /// The samples of the far cells' half-open boxes that were not evaluated, from their corners.
    void fill(const std::vector<Cell>& far) {
        std::int64_t filled = 0;
#pragma omp parallel for schedule(dynamic, 64) reduction(+ : filled)
        for (std::int64_t f = 0; f < std::int64_t(far.size()); ++f) {
            const Cell& c = far[std::size_t(f)];
            const Eigen::Vector3i e = extent(c);
            float v[8];
            for (int q = 0; q < 8; ++q) v[q] = at(corner(c, q));
            // The half-open box, closed on the grid's last plane.
            const Eigen::Vector3i end(c.origin.x() + e.x() == L_.R ? e.x() : e.x() - 1,
                                      c.origin.y() + e.y() == L_.R ? e.y() : e.y() - 1,
                                      c.origin.z() + e.z() == L_.R ? e.z() : e.z() - 1);
            for (int k = 0; k <= end.z(); ++k)
                for (int j = 0; j <= end.y(); ++j)
                    for (int i = 0; i <= end.x(); ++i) {
                        float& s = at(c.origin + Eigen::Vector3i(i, j, k));
                        if (!std::isnan(s)) continue;
                        s = trilinear(v, e, i, j, k);
                        ++filled;
                    }
        }
        stats_.interpolated_samples += filled;
    }

    /// Sparse band: the samples on the upper faces of the far cells still empty after fill(),
    /// which their block owns because the neighbour above is not stored, from the first far cell
    /// (in cell order) that holds them.
    void fill_upper_faces(const std::vector<Cell>& far) {
        std::int64_t filled = 0;
        for (const Cell& c : far) {
            const Eigen::Vector3i e = extent(c);
            float v[8];
            for (int q = 0; q < 8; ++q) v[q] = at(corner(c, q));
            for (int k = 0; k <= e.z(); ++k)
                for (int j = 0; j <= e.y(); ++j)
                    for (int i = 0; i <= e.x(); ++i) {
                        if (i < e.x() && j < e.y() && k < e.z()) continue;  // the half-open box: filled
                        float& s = at(c.origin + Eigen::Vector3i(i, j, k));
                        if (!std::isnan(s)) continue;
                        s = trilinear(v, e, i, j, k);
                        ++filled;
                    }
        }
        stats_.interpolated_samples += filled;
    }

    const SdfBatchFn& sdf_;
    const GridSpec& spec_;
    Builder& G_;
    const Layout& L_;
    const SdfGridOptions& options_;
    SdfGridStats& stats_;
    std::chrono::steady_clock::time_point start_;
    std::size_t first_;
    bool dense_;  // every block stored (block index = key)
    std::int64_t total_;
    std::int64_t done_ = 0;
};

/// Coarse-to-fine band: an octree over the blocks, starting from one node covering all of them.
/// A node is refined (or, at block size, kept) when |sdf(centre)| <= factor * half-diagonal:
/// for a true distance (1-Lipschitz) a node failing the test contains no zero.
std::vector<std::int64_t> coarse_band(const SdfBatchFn& sdf, const GridSpec& spec, const Layout& L,
                                      const SdfGridOptions& options, SdfGridStats& stats) {
    int size = 1;
    while (size < L.nb) size *= 2;
    const Eigen::Vector3d spacing = spec.spacing();
    std::vector<Eigen::Vector3i> nodes{Eigen::Vector3i::Zero()};
    std::vector<std::int64_t> kept;
    for (; !nodes.empty(); size /= 2) {
        PointsF centres(static_cast<Eigen::Index>(nodes.size()), 3);
        std::vector<double> half_diagonal(nodes.size());
        for (std::size_t n = 0; n < nodes.size(); ++n) {
            const Eigen::Array3d lo = (nodes[n] * L.B).cast<double>().array();
            const Eigen::Array3d hi = ((nodes[n].array() + size) * L.B).min(L.R).cast<double>();
            centres.row(n) =
                (spec.box.min.array() + spacing.array() * 0.5 * (lo + hi)).cast<float>().matrix().transpose();
            half_diagonal[n] = 0.5 * ((hi - lo) * spacing.array()).matrix().norm();
        }
        const Eigen::VectorXf values = evaluate_points(sdf, centres, options);
        stats.coarse_evaluations += centres.rows();
        stats.evaluations += centres.rows();
        std::vector<Eigen::Vector3i> children;
        for (std::size_t n = 0; n < nodes.size(); ++n) {
            if (std::abs(double(values[n])) > options.coarse_factor * half_diagonal[n]) continue;
            if (size == 1) {
                kept.push_back(L.key(nodes[n].x(), nodes[n].y(), nodes[n].z()));
                continue;
            }
            const int h = size / 2;
            for (int c = 0; c < 8; ++c) {
                const Eigen::Vector3i child = nodes[n] + h * Eigen::Vector3i(c & 1, (c >> 1) & 1, (c >> 2) & 1);
                if ((child.array() < L.nb).all()) children.push_back(child);
            }
        }
        nodes.swap(children);
        if (size == 1) break;
    }
    std::sort(kept.begin(), kept.end());
    return kept;
}

/// Point-guided band: the blocks whose box comes within `radius` of a band point.
std::vector<std::int64_t> near_point_band(const GridSpec& spec, const Layout& L,
                                          const Eigen::Ref<const PointsF>& points, const SdfGridOptions& options) {
    const Eigen::Vector3d spacing = spec.spacing();
    const double radius = options.point_band_cells * spacing.maxCoeff();
    std::vector<std::uint8_t> marked(std::size_t(L.nb) * L.nb * L.nb, 0);  // nb^3 = R^3 / B^3 bytes
    FirstError errors;
#pragma omp parallel for schedule(static)
    for (Eigen::Index n = 0; n < points.rows(); ++n) {
        errors.run([&] {
            const Eigen::Vector3d p = points.row(n).transpose().cast<double>();
            PCP_CHECK(p.allFinite(), "sdf_grid: band point " << n << " is not finite");
            if (((p.array() + radius) < spec.box.min.array()).any() ||
                ((p.array() - radius) > spec.box.max.array()).any())
                return;
            Eigen::Vector3i lo, hi;
            for (int a = 0; a < 3; ++a) {
                const double block_size = spacing[a] * L.B;
                lo[a] = std::clamp(int(std::floor((p[a] - radius - spec.box.min[a]) / block_size)), 0, L.nb - 1);
                hi[a] = std::clamp(int(std::floor((p[a] + radius - spec.box.min[a]) / block_size)), 0, L.nb - 1);
            }
            for (int bz = lo.z(); bz <= hi.z(); ++bz)
                for (int by = lo.y(); by <= hi.y(); ++by)
                    for (int bx = lo.x(); bx <= hi.x(); ++bx) {
                        const Eigen::Array3i X(bx, by, bz);
                        const Eigen::Array3d bmin = spec.box.min.array() + spacing.array() * (X * L.B).cast<double>();
                        const Eigen::Array3d bmax =
                            spec.box.min.array() + spacing.array() * ((X + 1) * L.B).min(L.R).cast<double>();
                        const Eigen::Array3d gap = (bmin - p.array()).max(p.array() - bmax).max(0.0);
                        if (gap.matrix().norm() > radius) continue;
                        std::uint8_t& m = marked[std::size_t(L.key(bx, by, bz))];
#pragma omp atomic write
                        m = 1;
                    }
        });
    }
    errors.rethrow();
    std::vector<std::int64_t> keys;
    for (std::size_t k = 0; k < marked.size(); ++k)
        if (marked[k]) keys.push_back(std::int64_t(k));
    return keys;
}

/// Blocks not stored that the zero set enters through a face of a stored block: the face's
/// samples have both signs (value < 0 and value >= 0).
std::vector<std::int64_t> growth_candidates(const Builder& G) {
    const Layout& L = G.L;
    std::vector<std::int64_t> found;
#pragma omp parallel
    {
        std::vector<std::int64_t> mine;
#pragma omp for schedule(dynamic, 16) nowait
        for (std::int64_t b = 0; b < std::int64_t(G.keys.size()); ++b) {
            const Eigen::Vector3i X = L.coords(G.keys[b]);
            const Eigen::Vector3i c(L.cells(X.x()), L.cells(X.y()), L.cells(X.z()));
            const float* block = G.values.data() + b * L.S3;
            for (int a = 0; a < 3; ++a)
                for (int side = 0; side < 2; ++side) {
                    Eigen::Vector3i N = X;
                    N[a] += side ? 1 : -1;
                    if (N[a] < 0 || N[a] >= L.nb || G.find(N.x(), N.y(), N.z()) >= 0) continue;
                    const int u = (a + 1) % 3, v = (a + 2) % 3;
                    bool below = false, above = false;
                    Eigen::Vector3i l;
                    l[a] = side ? c[a] : 0;
                    for (l[v] = 0; l[v] <= c[v]; ++l[v])
                        for (l[u] = 0; l[u] <= c[u]; ++l[u]) {
                            const bool in = double(block[L.local_index(l.x(), l.y(), l.z())]) < 0.0;
                            below = below || in;
                            above = above || !in;
                        }
                    if (below && above) mine.push_back(L.key(N.x(), N.y(), N.z()));
                }
        }
#pragma omp critical(pcp_sdf_grid_growth)
        found.insert(found.end(), mine.begin(), mine.end());
    }
    std::sort(found.begin(), found.end());
    found.erase(std::unique(found.begin(), found.end()), found.end());
    return found;
}

void check_options(const SdfBatchFn& sdf, const GridSpec& spec, const SdfGridOptions& options) {
    PCP_CHECK(static_cast<bool>(sdf), "sdf_grid: no SDF function given");
    PCP_CHECK(spec.resolution >= 2 && spec.resolution <= 65536,
              "sdf_grid: resolution " << spec.resolution << " is out of range; use 2..65536 cells per axis");
    PCP_CHECK(spec.box.min.allFinite() && spec.box.max.allFinite() &&
                  (spec.box.max.array() > spec.box.min.array()).all(),
              "sdf_grid: the grid box is empty or not finite (min " << spec.box.min.transpose() << ", max "
                  << spec.box.max.transpose() << "); give every axis a positive extent (add a margin)");
    PCP_CHECK(options.block_cells >= 2 && options.block_cells <= 64,
              "sdf_grid: block_cells " << options.block_cells << " is out of range 2..64");
    PCP_CHECK(options.batch_size >= 1, "sdf_grid: batch_size " << options.batch_size << " must be positive");
    PCP_CHECK(std::isfinite(options.coarse_factor) && options.coarse_factor > 0.0,
              "sdf_grid: coarse_factor " << options.coarse_factor << " must be positive (1 is exact for a true distance)");
    PCP_CHECK(std::isfinite(options.point_band_cells) && options.point_band_cells >= 0.0,
              "sdf_grid: point_band_cells " << options.point_band_cells << " must be >= 0");
    PCP_CHECK(std::isfinite(options.far_factor) && options.far_factor >= 0.0,
              "sdf_grid: far_factor " << options.far_factor << " must be >= 0 (0 = evaluate every sample)");
    PCP_CHECK(options.far_levels >= 1 && options.far_levels <= 7 && options.block_cells % (1 << (options.far_levels - 1)) == 0,
              "sdf_grid: far_levels " << options.far_levels << " must be in 1..7 and halve block_cells "
                  << options.block_cells << " evenly at every level");
}

SdfGrid evaluate_impl(const SdfBatchFn& sdf, const GridSpec& spec, const SdfGridOptions& options,
                      const Eigen::Ref<const PointsF>* band_points) {
    check_options(sdf, spec, options);
    const auto start = std::chrono::steady_clock::now();
    SdfGrid grid;
    grid.spec = spec;
    grid.block_cells = options.block_cells;
    Builder G;
    G.L = make_layout(spec.resolution, options.block_cells);
    grid.blocks_per_axis = G.L.nb;

    switch (options.band) {
    case NarrowBand::Dense:
        G.keys.resize(std::size_t(G.L.nb) * G.L.nb * G.L.nb);
        for (std::size_t k = 0; k < G.keys.size(); ++k) G.keys[k] = std::int64_t(k);
        break;
    case NarrowBand::Coarse:
        G.keys = coarse_band(sdf, spec, G.L, options, grid.stats);
        break;
    case NarrowBand::NearPoints:
        PCP_CHECK(band_points != nullptr,
                  "sdf_grid: NarrowBand::NearPoints needs band points; call the overload that takes them");
        PCP_CHECK(band_points->rows() > 0, "sdf_grid: NarrowBand::NearPoints was given no band points");
        G.keys = near_point_band(spec, G.L, *band_points, options);
        break;
    }

    G.values.assign(G.keys.size() * std::size_t(G.L.S3), std::numeric_limits<float>::quiet_NaN());
    G.rebuild_lookup();
    // Blocks [first, K): refined where far cells may be interpolated, else evaluated whole.
    const auto evaluate_from = [&](std::size_t first) {
        if (options.far_factor > 0)
            GridRefinement(sdf, spec, G, first, options, grid.stats, start).run();
        else
            evaluate_blocks(sdf, spec, G, first, options, grid.stats, start);
    };
    evaluate_from(0);
    canonicalize(G);

    while (options.grow) {
        const std::vector<std::int64_t> added = growth_candidates(G);
        if (added.empty()) break;
        const std::size_t old = G.keys.size();
        G.keys.insert(G.keys.end(), added.begin(), added.end());
        G.values.resize(G.keys.size() * std::size_t(G.L.S3), std::numeric_limits<float>::quiet_NaN());
        G.rebuild_lookup();
        evaluate_from(old);
        canonicalize(G);
        grid.stats.grown_blocks += std::int64_t(added.size());
        ++grid.stats.growth_rounds;
    }

    // Store the blocks in key order (find_block is then a binary search on block_keys).
    grid.block_keys.resize(G.keys.size());
    grid.values.resize(G.values.size());
    for (std::size_t n = 0; n < G.lookup.size(); ++n) {
        grid.block_keys[n] = G.lookup[n].first;
        std::copy_n(G.values.begin() + std::int64_t(G.lookup[n].second) * G.L.S3, G.L.S3,
                    grid.values.begin() + std::int64_t(n) * G.L.S3);
    }
    return grid;
}

}  // namespace

GridSpec make_grid_spec(const Aabb& bbox, int resolution, double margin) {
    PCP_CHECK(bbox.min.allFinite() && bbox.max.allFinite() && (bbox.max.array() >= bbox.min.array()).all(),
              "sdf_grid: bounding box is empty or not finite (min " << bbox.min.transpose() << ", max "
                  << bbox.max.transpose() << ")");
    PCP_CHECK(std::isfinite(margin) && margin >= 0.0, "sdf_grid: margin " << margin << " must be >= 0");
    GridSpec spec;
    spec.resolution = resolution;
    spec.box.min = bbox.min.array() - margin;
    spec.box.max = bbox.max.array() + margin;
    return spec;
}

int SdfGrid::find_block(int bx, int by, int bz) const {
    if (bx < 0 || by < 0 || bz < 0 || bx >= blocks_per_axis || by >= blocks_per_axis || bz >= blocks_per_axis)
        return -1;
    const std::int64_t k = (std::int64_t(bz) * blocks_per_axis + by) * blocks_per_axis + bx;
    auto it = std::lower_bound(block_keys.begin(), block_keys.end(), k);
    return (it != block_keys.end() && *it == k) ? int(it - block_keys.begin()) : -1;
}

float SdfGrid::value(int i, int j, int k) const {
    const int R = spec.resolution, B = block_cells, S = B + 1;
    if (i < 0 || j < 0 || k < 0 || i > R || j > R || k > R) return std::numeric_limits<float>::quiet_NaN();
    // Candidate blocks along each axis: the one starting at or before the sample, then the one
    // ending at it (all stored copies are equal, see canonicalize).
    const Eigen::Vector3i g(i, j, k);
    for (int c = 0; c < 8; ++c) {
        Eigen::Vector3i X;
        bool valid = true;
        for (int a = 0; a < 3; ++a) {
            X[a] = std::min(g[a] / B, blocks_per_axis - 1);
            if ((c >> a) & 1) {
                valid = valid && g[a] % B == 0 && g[a] / B - 1 >= 0 && g[a] / B - 1 != X[a];
                X[a] = g[a] / B - 1;
            }
        }
        const int b = valid ? find_block(X.x(), X.y(), X.z()) : -1;
        if (b < 0) continue;
        const Eigen::Vector3i l = g - X * B;
        return values[std::size_t(std::int64_t(b) * S * S * S + (std::int64_t(l.z()) * S + l.y()) * S + l.x())];
    }
    return std::numeric_limits<float>::quiet_NaN();
}

SdfGrid evaluate_sdf_grid(const SdfBatchFn& sdf, const GridSpec& spec, const SdfGridOptions& options) {
    return evaluate_impl(sdf, spec, options, nullptr);
}

SdfGrid evaluate_sdf_grid(const SdfBatchFn& sdf, const GridSpec& spec, const SdfGridOptions& options,
                          const Eigen::Ref<const PointsF>& band_points) {
    return evaluate_impl(sdf, spec, options, &band_points);
}

}  // namespace pcp
