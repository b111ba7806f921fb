// Inside / outside labels by visibility through the dilated cloud (see pcp/cloud/visibility.hpp).
#include "pcp/cloud/visibility.hpp"

#include "pcp/core/error.hpp"
#include "pcp/core/rng.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <utility>

#include <omp.h>

namespace pcp {

namespace {

constexpr double kPi = 3.14159265358979323846;

/// The blocked voxels: those that meet a ball of radius r around an input point.
struct Occupancy {
    Eigen::Vector3d origin;
    double h = 0;
    Eigen::Vector3i dims;
    std::vector<std::uint8_t> blocked;
    int f = 1;             ///< coarse voxels of the clearance: f x f x f voxels each
    Eigen::Vector3i cdims;  ///< the clearance's grid

    std::size_t index(int i, int j, int k) const {
        return (static_cast<std::size_t>(k) * static_cast<std::size_t>(dims.y()) + static_cast<std::size_t>(j)) *
                   static_cast<std::size_t>(dims.x()) + static_cast<std::size_t>(i);
    }

    /// factor: the clearance (below) on voxels this many times coarser (factor^3 times less work for
    /// a fine grid; the same voxels are tested).
    Occupancy(const PointsF& points, const Aabb& box, int resolution, double r, int factor = 1) : f(factor) {
        const Eigen::Vector3d extent = box.extent();
        h = extent.maxCoeff() / resolution;
        origin = box.min;
        for (int c = 0; c < 3; ++c) dims(c) = std::max(1, static_cast<int>(std::ceil(extent(c) / h)));
        blocked.assign(static_cast<std::size_t>(dims.prod()), 0);
        const double r2 = r * r;
        // Threads own slabs of k: each marks only its own voxels (the same voxels as one thread).
#pragma omp parallel
        {
            const int t = omp_get_thread_num(), T = omp_get_num_threads();
            const int k_first = int(std::int64_t(dims.z()) * t / T), k_last = int(std::int64_t(dims.z()) * (t + 1) / T) - 1;
            for (Eigen::Index p = 0; p < points.rows(); ++p) {
                const Eigen::Vector3d x = points.row(p).transpose().cast<double>();
                Eigen::Vector3i lo, hi;
                for (int c = 0; c < 3; ++c) {
                    lo(c) = std::max(0, static_cast<int>(std::floor((x(c) - r - origin(c)) / h)));
                    hi(c) = std::min(dims(c) - 1, static_cast<int>(std::floor((x(c) + r - origin(c)) / h)));
                }
                lo.z() = std::max(lo.z(), k_first);
                hi.z() = std::min(hi.z(), k_last);
                mark(x, lo, hi, r2);
            }
        }
        compute_clearance();
    }

    /// Marks the voxels in [lo, hi] that meet the ball of squared radius r2 around x.
    void mark(const Eigen::Vector3d& x, const Eigen::Vector3i& lo, const Eigen::Vector3i& hi, double r2) {
        for (int k = lo.z(); k <= hi.z(); ++k)
            for (int j = lo.y(); j <= hi.y(); ++j)
                for (int i = lo.x(); i <= hi.x(); ++i) {
                    // squared distance from x to the voxel's box
                    double d2 = 0.0;
                    const Eigen::Vector3i v(i, j, k);
                    for (int c = 0; c < 3; ++c) {
                        const double a = origin(c) + h * v(c), b = a + h;
                        const double d = x(c) < a ? a - x(c) : (x(c) > b ? x(c) - b : 0.0);
                        d2 += d * d;
                    }
                    if (d2 <= r2) blocked[index(i, j, k)] = 1;
                }
    }

    /// Chessboard distance (in coarse voxels, capped at 255) from each coarse voxel to the nearest
    /// blocked one (a coarse voxel is blocked when one of its voxels is): every coarse voxel u with
    /// |u - v|_inf < clearance[v] is free. Two raster passes of the 26-neighbour chamfer mask with
    /// unit weights compute it exactly.
    std::vector<std::uint8_t> clearance;

    std::size_t cindex(int i, int j, int k) const {
        return (static_cast<std::size_t>(k) * static_cast<std::size_t>(cdims.y()) + static_cast<std::size_t>(j)) *
                   static_cast<std::size_t>(cdims.x()) + static_cast<std::size_t>(i);
    }

    void compute_clearance() {
        for (int c = 0; c < 3; ++c) cdims(c) = (dims(c) + f - 1) / f;
        clearance.assign(static_cast<std::size_t>(cdims.prod()), 255);
        for (int k = 0; k < dims.z(); ++k)
            for (int j = 0; j < dims.y(); ++j)
                for (int i = 0; i < dims.x(); ++i)
                    if (blocked[index(i, j, k)]) clearance[cindex(i / f, j / f, k / f)] = 0;
        auto pass = [&](int sign) {
            const int nx = cdims.x(), ny = cdims.y(), nz = cdims.z();
            for (int kk = 0; kk < nz; ++kk) {
                const int k = sign > 0 ? kk : nz - 1 - kk;
                for (int jj = 0; jj < ny; ++jj) {
                    const int j = sign > 0 ? jj : ny - 1 - jj;
                    for (int ii = 0; ii < nx; ++ii) {
                        const int i = sign > 0 ? ii : nx - 1 - ii;
                        std::uint8_t& d = clearance[cindex(i, j, k)];
                        if (d == 0) continue;
                        // the 13 neighbours already visited in this raster order
                        for (int dk = -1; dk <= 0; ++dk)
                            for (int dj = -1; dj <= 1; ++dj)
                                for (int di = -1; di <= 1; ++di) {
                                    if (dk == 0 && (dj > 0 || (dj == 0 && di >= 0))) continue;
                                    const int a = i + sign * di, b = j + sign * dj, c = k + sign * dk;
                                    if (a < 0 || b < 0 || c < 0 || a >= nx || b >= ny || c >= nz) continue;
                                    const int n = clearance[cindex(a, b, c)] + 1;
                                    if (n < d) d = static_cast<std::uint8_t>(n);
                                }
                    }
                }
            }
        };
        pass(+1);
        pass(-1);
    }

    /// Marches from `from` along unit `dir`, testing the points from + n (h/2) dir, n = 1, 2, ...:
    /// true when they leave the grid before one lies in a blocked voxel. Where the clearance says
    /// the next m points all lie in free voxels, they are skipped (the same points are tested as by
    /// a plain march, only fewer lookups are made).
    bool escapes(const Eigen::Vector3d& from, const Eigen::Vector3d& dir) const {
        const double step = 0.5 * h;
        const double reach = step * dir.cwiseAbs().maxCoeff() / h;  // voxels moved per point, per axis at most
        std::int64_t n = 1;
        for (;;) {
            const Eigen::Vector3d p = from + (static_cast<double>(n) * step) * dir;
            Eigen::Vector3i v;
            for (int c = 0; c < 3; ++c) {
                const double u = (p(c) - origin(c)) / h;
                if (u < 0.0 || u >= dims(c)) return true;
                v(c) = static_cast<int>(u);
            }
            // The coarse clearance first (a smaller array): only a coarse voxel at 0 can hold a blocked voxel.
            const std::uint8_t d = clearance[cindex(v.x() / f, v.y() / f, v.z() / f)];
            if (d == 0 && blocked[index(v.x(), v.y(), v.z())]) return false;
            // Points up to (d - 1) coarse voxels away along every axis lie in free voxels.
            const auto skip = d == 0 ? std::int64_t(0) : static_cast<std::int64_t>(std::floor((d - 1) * f / reach));
            n += std::max<std::int64_t>(1, skip);
        }
    }
};

/// `n` unit directions spread evenly (a Fibonacci sphere).
std::vector<Eigen::Vector3d> fibonacci_sphere(int n) {
    std::vector<Eigen::Vector3d> d(static_cast<std::size_t>(n));
    const double golden = kPi * (3.0 - std::sqrt(5.0));
    for (int i = 0; i < n; ++i) {
        const double z = 1.0 - (2.0 * i + 1.0) / n;
        const double rho = std::sqrt(std::max(0.0, 1.0 - z * z));
        d[static_cast<std::size_t>(i)] = Eigen::Vector3d(rho * std::cos(golden * i), rho * std::sin(golden * i), z);
    }
    return d;
}

/// A uniformly random rotation (from a random unit quaternion).
Eigen::Matrix3d random_rotation(Rng& rng) {
    Eigen::Vector4d q(rng.normal(), rng.normal(), rng.normal(), rng.normal());
    while (q.norm() < 1e-12) q = Eigen::Vector4d(rng.normal(), rng.normal(), rng.normal(), rng.normal());
    q.normalize();
    const double w = q(0), x = q(1), y = q(2), z = q(3);
    Eigen::Matrix3d R;
    R << 1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),
        2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
        2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y);
    return R;
}

/// The checks of the cloud and the box that the labels and the through lines make; the cloud's
/// sampling scale (`what` names the caller in the messages).
double checked_scale(const KdTree& tree, const Aabb& box, const char* what) {
    PCP_CHECK(tree.size() >= 2, what << ": needs at least 2 points, got " << tree.size());
    const Eigen::Vector3d extent = box.extent();
    PCP_CHECK(extent.allFinite() && extent.minCoeff() > 0.0, what << ": the box must have a positive extent on every axis");
    const double scale = sampling_scale(tree);
    PCP_CHECK(scale > 0.0, what << ": the cloud has no spread (all points coincide)");
    return scale;
}

}  // namespace

VisibilityLabels label_by_visibility(const KdTree& tree, const Aabb& box, const VisibilityOptions& o) {
    const auto t0 = std::chrono::steady_clock::now();
    PCP_CHECK(o.resolution >= 4 && o.resolution <= 256, "visibility: resolution must be in 4..256, got " << o.resolution);
    PCP_CHECK(o.occupancy_resolution >= 8 && o.occupancy_resolution <= 1024,
              "visibility: occupancy_resolution must be in 8..1024, got " << o.occupancy_resolution);
    PCP_CHECK(o.rays >= 8 && o.rays <= 1024, "visibility: rays must be in 8..1024, got " << o.rays);
    PCP_CHECK(o.min_through_lines >= 0 && o.min_through_lines <= o.rays,
              "visibility: min_through_lines must be in 0..rays, got " << o.min_through_lines);
    PCP_CHECK(o.line_directions == 0 || (o.line_directions >= 8 && o.line_directions <= 4096),
              "visibility: line_directions must be 0 or in 8..4096, got " << o.line_directions);
    PCP_CHECK(o.line_directions == 0 || (o.min_free_lines >= 1 && o.min_free_lines <= o.line_directions),
              "visibility: min_free_lines must be in 1..line_directions, got " << o.min_free_lines);
    PCP_CHECK(std::isfinite(o.dilation) && o.dilation > 0.0, "visibility: dilation must be > 0");
    PCP_CHECK(std::isfinite(o.min_distance) && o.min_distance >= 0.0, "visibility: min_distance must be >= 0");
    PCP_CHECK(o.outside_fraction > 0.0 && o.outside_fraction <= 1.0, "visibility: outside_fraction must be in (0, 1]");
    const double scale = checked_scale(tree, box, "visibility");
    const Eigen::Vector3d extent = box.extent();
    VisibilityLabels out;
    out.stats.radius = o.dilation * scale;
    out.origin = box.min;
    out.cell = extent.maxCoeff() / o.resolution;
    for (int c = 0; c < 3; ++c) out.dims(c) = std::max(1, static_cast<int>(std::ceil(extent(c) / out.cell)));
    const std::size_t cells = static_cast<std::size_t>(out.dims.prod());
    out.label.assign(cells, 0);

    // Which cells are far enough from the data to label.
    PointsF centers(static_cast<Eigen::Index>(cells), 3);
    for (int k = 0; k < out.dims.z(); ++k)
        for (int j = 0; j < out.dims.y(); ++j)
            for (int i = 0; i < out.dims.x(); ++i)
                centers.row(static_cast<Eigen::Index>(out.index(i, j, k))) = out.center(i, j, k).cast<float>().transpose();
    const Eigen::VectorXf dist = tree.kth_distance(centers, 1);
    const double far = o.min_distance * scale + 0.5 * std::sqrt(3.0) * out.cell;
    // Rays start at cell centres outside every ball, so never inside a blocked voxel's ball; they
    // also need the dilation radius itself to be clear.
    const double clear = std::max(far, out.stats.radius + 0.5 * std::sqrt(3.0) * extent.maxCoeff() / o.occupancy_resolution);

    const Occupancy occ(tree.points(), box, o.occupancy_resolution, out.stats.radius);
    const std::vector<Eigen::Vector3d> dirs = fibonacci_sphere(o.rays);
    const int needed = std::max(1, static_cast<int>(std::ceil(o.outside_fraction * o.rays - 1e-9)));
    const auto n_cells = static_cast<std::int64_t>(cells);
#pragma omp parallel for schedule(dynamic, 64)
    for (std::int64_t c = 0; c < n_cells; ++c) {
        if (dist(c) < clear) continue;
        Rng rng(o.seed, 0x7151B1E0000000ull + static_cast<std::uint64_t>(c));
        const Eigen::Matrix3d R = random_rotation(rng);
        const Eigen::Vector3d from = centers.row(c).transpose().cast<double>();
        int escaped = 0, through = 0;
        std::int8_t label = 0;
        for (int r = 0; r < o.rays; ++r) {
            const Eigen::Vector3d d = R * dirs[static_cast<std::size_t>(r)];
            if (occ.escapes(from, d)) {
                ++escaped;
                // A line through the cell that escapes at both ends crosses no wall: no closed
                // surface of the data can hold the cell (the middle of a through-hole).
                if (o.min_through_lines > 0 && occ.escapes(from, -d)) ++through;
            }
            if (escaped >= needed || (o.min_through_lines > 0 && through >= o.min_through_lines)) {
                label = 1;
                break;
            }
            const int left = o.rays - r - 1;
            if (escaped > 0 && escaped + left < needed && (o.min_through_lines == 0 || through + left < o.min_through_lines))
                break;  // neither inside nor outside
        }
        if (label == 0 && escaped == 0) label = -1;
        out.label[static_cast<std::size_t>(c)] = label;
    }
    // 4. The cells not outside yet, their lines counted exactly (a narrow bore's middle).
    if (o.line_directions > 0) {
        const ThroughLines lines(tree, box, o.occupancy_resolution, o.dilation, o.line_directions);
#pragma omp parallel for schedule(dynamic, 256)
        for (std::int64_t c = 0; c < n_cells; ++c) {
            if (dist(c) < clear || out.label[static_cast<std::size_t>(c)] > 0) continue;
            const Eigen::Vector3d from = centers.row(c).transpose().cast<double>();
            if (lines.count(from, o.min_free_lines) >= o.min_free_lines) out.label[static_cast<std::size_t>(c)] = 1;
        }
    }
    for (std::size_t c = 0; c < cells; ++c) {
        if (dist(static_cast<Eigen::Index>(c)) < clear) {
            ++out.stats.near;
        } else if (out.label[c] < 0) {
            ++out.stats.inside;
            out.inside_cells.push_back(static_cast<std::int32_t>(c));
        } else if (out.label[c] > 0) {
            ++out.stats.outside;
            out.outside_cells.push_back(static_cast<std::int32_t>(c));
        } else {
            ++out.stats.unknown;
        }
    }
    out.stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return out;
}

namespace {

/// One direction's bitmap: the plane across d (axes u, v), its pixels from `lo`, set where a disc
/// of the dilated cloud meets them.
struct LineBitmap {
    Eigen::Vector3d u, v;
    Eigen::Vector2d lo;
    std::int64_t width = 0, height = 0;
    std::vector<std::uint64_t> bits;

    bool blocked(const Eigen::Vector3d& x, double pixel) const {
        const double a = (u.dot(x) - lo.x()) / pixel, c = (v.dot(x) - lo.y()) / pixel;
        if (!(a >= 0.0 && c >= 0.0 && a < double(width) && c < double(height))) return false;
        const std::int64_t k = static_cast<std::int64_t>(c) * width + static_cast<std::int64_t>(a);
        return (bits[static_cast<std::size_t>(k >> 6)] >> (k & 63)) & 1u;
    }
};

/// The plane across direction d over `box`, wider on every side by `margin` pixels (a disc's stamp,
/// DiscStamps::reach, and one more), so that every stamp of a ball in the box lies in it; no bits yet.
LineBitmap line_plane(const Eigen::Vector3d& d, const Aabb& box, int margin_pixels, double pixel) {
    Eigen::Index least = 0;
    d.cwiseAbs().minCoeff(&least);
    LineBitmap b;
    b.u = d.cross(Eigen::Vector3d::Unit(least)).normalized();
    b.v = d.cross(b.u);
    Eigen::Vector2d lo = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
    for (int c = 0; c < 8; ++c) {
        const Eigen::Vector3d corner((c & 1) ? box.max.x() : box.min.x(), (c & 2) ? box.max.y() : box.min.y(),
                                     (c & 4) ? box.max.z() : box.min.z());
        const Eigen::Vector2d q(b.u.dot(corner), b.v.dot(corner));
        lo = lo.cwiseMin(q);
        hi = hi.cwiseMax(q);
    }
    const double margin = margin_pixels * pixel;
    b.lo = lo.array() - margin;
    b.width = static_cast<std::int64_t>(std::ceil((hi.x() - lo.x() + 2 * margin) / pixel));
    b.height = static_cast<std::int64_t>(std::ceil((hi.y() - lo.y() + 2 * margin) / pixel));
    return b;
}

/// The pixels a disc of radius r (in pixels) may meet, by where its centre lies in its pixel: the
/// pixel is cut into kSub x kSub parts, and part (qa, qb) lists the offsets (di, dj) of the pixels
/// within r of some point of that part (rectangle to rectangle distance), at most reach = ceil(r)
/// + 1 away: a stamp then sets a few bits without a distance per pixel, at most a part's diagonal
/// (1 / kSub of a pixel x sqrt 2) more than the disc.
struct DiscStamps {
    static constexpr int kSub = 8;
    int reach = 0;
    std::vector<std::vector<std::pair<int, int>>> offsets;

    explicit DiscStamps(double r) : reach(static_cast<int>(std::ceil(r)) + 1), offsets(kSub * kSub) {
        const auto gap = [](double a0, double a1, double b0, double b1) { return a1 < b0 ? b0 - a1 : (b1 < a0 ? a0 - b1 : 0.0); };
        for (int qa = 0; qa < kSub; ++qa)
            for (int qb = 0; qb < kSub; ++qb)
                for (int dj = -reach; dj <= reach; ++dj)
                    for (int di = -reach; di <= reach; ++di) {
                        const double dx = gap(double(qa) / kSub, double(qa + 1) / kSub, double(di), double(di + 1));
                        const double dy = gap(double(qb) / kSub, double(qb + 1) / kSub, double(dj), double(dj + 1));
                        if (dx * dx + dy * dy <= r * r) offsets[static_cast<std::size_t>(qa * kSub + qb)].emplace_back(di, dj);
                    }
    }
};

/// Sets the pixels of `b` that the disc of each ball (centres `points`) may meet (DiscStamps). The
/// plane's margin (line_plane) keeps every stamp of a ball in the box inside the bitmap; a ball
/// outside the box is drawn pixel by pixel, clipped.
void draw_discs(LineBitmap& b, const PointsF& points, const DiscStamps& stamps, double pixel) {
    b.bits.assign(static_cast<std::size_t>((b.width * b.height + 63) / 64), 0);
    const auto set = [&](std::int64_t bit) { b.bits[static_cast<std::size_t>(bit >> 6)] |= std::uint64_t(1) << (bit & 63); };
    constexpr int kParts = DiscStamps::kSub * DiscStamps::kSub;
    // The stamps as offsets in the bitmap's row-major order, for this width.
    std::array<std::vector<std::int64_t>, kParts> linear;
    for (int q = 0; q < kParts; ++q)
        for (const auto& [di, dj] : stamps.offsets[static_cast<std::size_t>(q)]) linear[static_cast<std::size_t>(q)].push_back(dj * b.width + di);
    const Eigen::Vector3f u = (b.u / pixel).cast<float>(), v = (b.v / pixel).cast<float>();
    const auto u0 = static_cast<float>(b.lo.x() / pixel), v0 = static_cast<float>(b.lo.y() / pixel);
    for (Eigen::Index i = 0; i < points.rows(); ++i) {
        const Eigen::Vector3f x = points.row(i).transpose();
        const float a = u.dot(x) - u0, c = v.dot(x) - v0;
        const float fa = std::floor(a), fc = std::floor(c);
        const auto far = float(stamps.reach + 1);
        if (!(fa > -far && fc > -far && fa < float(b.width) + far && fc < float(b.height) + far)) continue;  // misses the plane
        const auto ia = static_cast<std::int64_t>(fa), ic = static_cast<std::int64_t>(fc);
        const int qa = std::min(DiscStamps::kSub - 1, static_cast<int>((a - fa) * DiscStamps::kSub));
        const int qc = std::min(DiscStamps::kSub - 1, static_cast<int>((c - fc) * DiscStamps::kSub));
        const std::size_t part = static_cast<std::size_t>(qa * DiscStamps::kSub + qc);
        if (!(fa >= float(stamps.reach) && fc >= float(stamps.reach) && fa + float(stamps.reach) < float(b.width) &&
              fc + float(stamps.reach) < float(b.height))) {
            for (const auto& [di, dj] : stamps.offsets[part]) {
                const std::int64_t i2 = ia + di, j2 = ic + dj;
                if (i2 >= 0 && j2 >= 0 && i2 < b.width && j2 < b.height) set(j2 * b.width + i2);
            }
            continue;
        }
        const std::int64_t base = ic * b.width + ia;
        for (const std::int64_t off : linear[part]) set(base + off);
    }
}

}  // namespace

std::vector<Eigen::Vector3d> line_directions(int n) {
    PCP_CHECK(n >= 1, "line directions: n must be >= 1, got " << n);
    const double golden = kPi * (3.0 - std::sqrt(5.0));
    std::vector<Eigen::Vector3d> d(static_cast<std::size_t>(n));
    for (int t = 0; t < n; ++t) {
        const double z = 1.0 - (t + 0.5) / n;
        const double rho = std::sqrt(std::max(0.0, 1.0 - z * z));
        d[static_cast<std::size_t>(t)] = Eigen::Vector3d(rho * std::cos(golden * t), rho * std::sin(golden * t), z);
    }
    return d;
}

struct ThroughLines::Impl {
    Occupancy occ;
    double radius;
    double pixel;
    std::vector<LineBitmap> lines;
    Impl(const PointsF& points, const Aabb& box, int resolution, double r, int directions, int factor)
        : occ(points, box, resolution, r, factor), radius(r), pixel(occ.h) {
        // The bitmaps within 64 MiB: pixels larger if need be (a line then counts as blocked
        // farther from a disc).
        const double budget_bits = 64.0 * 8 * 1024 * 1024;
        const double worst = std::sqrt(3.0) * box.extent().maxCoeff() + 2 * (r + pixel);
        while (double(directions) * (worst / pixel + 1) * (worst / pixel + 1) > budget_bits) pixel *= 1.25;
        const std::vector<Eigen::Vector3d> dirs = line_directions(directions);
        const DiscStamps stamps(r / pixel);
        lines.resize(static_cast<std::size_t>(directions));
#pragma omp parallel for schedule(dynamic, 1)
        for (int t = 0; t < directions; ++t) {
            LineBitmap& b = lines[static_cast<std::size_t>(t)];
            b = line_plane(dirs[static_cast<std::size_t>(t)], box, stamps.reach + 1, pixel);
            draw_discs(b, points, stamps, pixel);
        }
    }
};

ThroughLines::ThroughLines(const KdTree& tree, const Aabb& box, int occupancy_resolution, double dilation, int directions,
                           int clearance_factor) {
    PCP_CHECK(occupancy_resolution >= 8 && occupancy_resolution <= 1024,
              "through lines: occupancy_resolution must be in 8..1024, got " << occupancy_resolution);
    PCP_CHECK(std::isfinite(dilation) && dilation > 0.0, "through lines: dilation must be > 0");
    PCP_CHECK(directions >= 1 && directions <= 4096, "through lines: directions must be in 1..4096, got " << directions);
    PCP_CHECK(clearance_factor >= 1 && clearance_factor <= 4, "through lines: clearance_factor must be in 1..4, got " << clearance_factor);
    const double scale = checked_scale(tree, box, "through lines");
    impl_ = std::make_unique<Impl>(tree.points(), box, occupancy_resolution, dilation * scale, directions, clearance_factor);
}

ThroughLines::~ThroughLines() = default;
ThroughLines::ThroughLines(ThroughLines&&) noexcept = default;
ThroughLines& ThroughLines::operator=(ThroughLines&&) noexcept = default;

double ThroughLines::voxel() const { return impl_->occ.h; }
double ThroughLines::radius() const { return impl_->radius; }

int ThroughLines::clearance(const Eigen::Vector3d& p) const {
    const Occupancy& occ = impl_->occ;
    Eigen::Vector3i v;
    for (int c = 0; c < 3; ++c) {
        const double u = (p(c) - occ.origin(c)) / occ.h;
        if (!(u >= 0.0 && u < occ.dims(c))) return 255;
        v(c) = static_cast<int>(u);
    }
    if (occ.blocked[occ.index(v.x(), v.y(), v.z())]) return 0;
    return std::clamp(occ.f * occ.clearance[occ.cindex(v.x() / occ.f, v.y() / occ.f, v.z() / occ.f)], 1, 255);
}

int ThroughLines::count(const Eigen::Vector3d& p, int enough) const {
    PCP_CHECK(enough >= 1, "through lines: enough must be >= 1");
    int through = 0;
    for (const LineBitmap& b : impl_->lines) {
        if (!b.blocked(p, impl_->pixel)) ++through;
        if (through >= enough) break;
    }
    return through;
}

VisibilityLabels label_by_visibility(const KdTree& tree, const VisibilityOptions& o) {
    PCP_CHECK(std::isfinite(o.margin) && o.margin >= 0.0, "visibility: margin must be >= 0");
    PCP_CHECK(tree.size() >= 2, "visibility: needs at least 2 points, got " << tree.size());
    const PointsF& p = tree.points();
    Aabb box;
    box.min = p.colwise().minCoeff().transpose().cast<double>().array() - o.margin;
    box.max = p.colwise().maxCoeff().transpose().cast<double>().array() + o.margin;
    return label_by_visibility(tree, box, o);
}

}  // namespace pcp
