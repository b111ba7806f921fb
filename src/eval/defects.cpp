// Clouds with the defects of real scans (see include/pcp/eval/defects.hpp).
#include "pcp/eval/defects.hpp"

#include "pcp/core/error.hpp"
#include "pcp/core/rng.hpp"
#include "pcp/eval/eval.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <numeric>
#include <unordered_map>

namespace pcp {

namespace {

struct Box {
    Eigen::Vector3d lo, hi;
    double diagonal() const { return (hi - lo).norm(); }
};

Box box_of(const Mesh& mesh) {
    PCP_CHECK(mesh.vertices.rows() > 0 && mesh.faces.rows() > 0, "defect cloud: the mesh is empty");
    return Box{mesh.vertices.colwise().minCoeff().transpose(), mesh.vertices.colwise().maxCoeff().transpose()};
}

/// `n` points on the surface that `keep` accepts (each sample's chance of being offered is its area
/// share), drawn in batches until there are enough.
Points sample_kept(const Mesh& mesh, Eigen::Index n, std::uint64_t seed, const std::function<bool(const Eigen::Vector3d&, Rng&)>& keep) {
    Points out(n, 3);
    Eigen::Index have = 0;
    Rng rng(seed, 0xDEFEC7ull);
    for (std::uint64_t batch = 0; have < n; ++batch) {
        PCP_CHECK(batch < 1000, "defect cloud: the filter keeps too few of the mesh's samples");
        const Points s = sample_mesh_surface(mesh, std::max<Eigen::Index>(4 * n, 1000), seed + 7919 * (batch + 1)).points;
        for (Eigen::Index i = 0; i < s.rows() && have < n; ++i)
            if (keep(s.row(i).transpose(), rng)) out.row(have++) = s.row(i);
    }
    return out;
}

void add_noise(Points& points, double sigma, Rng& rng) {
    for (Eigen::Index i = 0; i < points.rows(); ++i)
        for (int c = 0; c < 3; ++c) points(i, c) += rng.normal(0.0, sigma);
}

/// `points` with `count` more, uniform in the box grown by 5 % of its diagonal on every side.
Points with_outliers(const Points& points, Eigen::Index count, const Box& box, Rng& rng) {
    Points out(points.rows() + count, 3);
    out.topRows(points.rows()) = points;
    const Eigen::Vector3d lo = box.lo.array() - 0.05 * box.diagonal(), hi = box.hi.array() + 0.05 * box.diagonal();
    for (Eigen::Index i = 0; i < count; ++i)
        for (int c = 0; c < 3; ++c) out(points.rows() + i, c) = lo(c) + rng.uniform() * (hi(c) - lo(c));
    return out;
}

/// Density `ratio`:1 along `axis`: a sample at coordinate fraction t is kept with chance ratio^(t-1).
Points density_gradient(const Mesh& mesh, Eigen::Index n, std::uint64_t seed, const Box& box, int axis, double ratio) {
    const double lo = box.lo(axis), extent = std::max(box.hi(axis) - box.lo(axis), 1e-12);
    return sample_kept(mesh, n, seed, [&](const Eigen::Vector3d& p, Rng& rng) {
        return rng.uniform() < std::pow(ratio, (p(axis) - lo) / extent - 1.0);
    });
}

/// Unit vectors e1, e2 across `d`.
void basis_across(const Eigen::Vector3d& d, Eigen::Vector3d& e1, Eigen::Vector3d& e2) {
    e1 = (std::abs(d.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY()).cross(d).normalized();
    e2 = d.cross(e1);
}

/// Three cameras within 35 degrees of `axis`: a dense sampling of the surface, each sample kept when
/// it is the nearest to some camera in its pixel (within a tolerance of two sample spacings; pixels
/// two spacings wide, each sample's depth splatted over 3 x 3 of them).
Points one_sided(const Mesh& mesh, Eigen::Index n, std::uint64_t seed, const Box& box, int axis, Rng& rng) {
    const Eigen::Index dense_n = 8 * n;
    const Points dense = sample_mesh_surface(mesh, dense_n, seed + 101).points;
    double area = 0;
    for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
        const Eigen::Vector3d a = mesh.vertices.row(mesh.faces(f, 0)), b = mesh.vertices.row(mesh.faces(f, 1)),
                              c = mesh.vertices.row(mesh.faces(f, 2));
        area += 0.5 * (b - a).cross(c - a).norm();
    }
    const double spacing = std::sqrt(area / static_cast<double>(dense_n));
    const Eigen::Vector3d centre = 0.5 * (box.lo + box.hi);
    const double distance = 2.0 * box.diagonal();
    const double pixel = 2.0 * spacing / distance;  // in tangent-plane units at the object
    Eigen::Vector3d a = Eigen::Vector3d::Zero();
    a(axis) = 1.0;
    Eigen::Vector3d a1, a2;
    basis_across(a, a1, a2);
    std::vector<char> seen(static_cast<std::size_t>(dense_n), 0);
    std::vector<Eigen::Vector3d> seen_from(static_cast<std::size_t>(dense_n));
    const double tilt = 35.0 * 3.14159265358979323846 / 180.0;
    for (int k = 0; k < 3; ++k) {
        const double phi = 2.0 * 3.14159265358979323846 * k / 3.0;
        const Eigen::Vector3d dir = (std::cos(tilt) * a + std::sin(tilt) * (std::cos(phi) * a1 + std::sin(phi) * a2)).normalized();
        const Eigen::Vector3d camera = centre + distance * dir;
        Eigen::Vector3d e1, e2;
        basis_across(-dir, e1, e2);
        std::unordered_map<std::int64_t, double> nearest;
        std::vector<std::int64_t> key(static_cast<std::size_t>(dense_n));
        std::vector<double> depth(static_cast<std::size_t>(dense_n));
        for (Eigen::Index i = 0; i < dense_n; ++i) {
            const Eigen::Vector3d v = dense.row(i).transpose() - camera;
            const double z = v.dot(-dir);
            const auto u = static_cast<std::int64_t>(std::floor(v.dot(e1) / z / pixel)), w = static_cast<std::int64_t>(std::floor(v.dot(e2) / z / pixel));
            key[static_cast<std::size_t>(i)] = (u + (1 << 20)) * (std::int64_t(1) << 21) + (w + (1 << 20));
            depth[static_cast<std::size_t>(i)] = v.norm();
            // Splatted over the 3 x 3 pixels around it, so that the front leaves no pixel empty
            // for a sample behind it to show through.
            for (std::int64_t du = -1; du <= 1; ++du)
                for (std::int64_t dw = -1; dw <= 1; ++dw) {
                    auto [it, fresh] = nearest.emplace(key[static_cast<std::size_t>(i)] + du * (std::int64_t(1) << 21) + dw,
                                                       depth[static_cast<std::size_t>(i)]);
                    if (!fresh) it->second = std::min(it->second, depth[static_cast<std::size_t>(i)]);
                }
        }
        for (Eigen::Index i = 0; i < dense_n; ++i)
            if (depth[static_cast<std::size_t>(i)] <= nearest[key[static_cast<std::size_t>(i)]] + 2.0 * spacing && !seen[static_cast<std::size_t>(i)]) {
                seen[static_cast<std::size_t>(i)] = 1;
                seen_from[static_cast<std::size_t>(i)] = camera;
            }
    }
    std::vector<Eigen::Index> visible;
    for (Eigen::Index i = 0; i < dense_n; ++i)
        if (seen[static_cast<std::size_t>(i)]) visible.push_back(i);
    for (std::size_t i = 0; i + 1 < visible.size(); ++i)  // a seeded shuffle, then the first n
        std::swap(visible[i], visible[i + static_cast<std::size_t>(rng.below(visible.size() - i))]);
    visible.resize(std::min<std::size_t>(visible.size(), static_cast<std::size_t>(n)));
    Points out(static_cast<Eigen::Index>(visible.size()), 3);
    const double sigma = 0.001 * box.diagonal();
    for (std::size_t j = 0; j < visible.size(); ++j) {
        const Eigen::Vector3d p = dense.row(visible[j]).transpose();
        const Eigen::Vector3d ray = (p - seen_from[static_cast<std::size_t>(visible[j])]).normalized();
        out.row(static_cast<Eigen::Index>(j)) = (p + rng.normal(0.0, sigma) * ray).transpose();
    }
    return out;
}

}  // namespace

const std::vector<Defect>& all_defects() {
    static const std::vector<Defect> all = {Defect::Clean,  Defect::Outliers, Defect::Density,       Defect::Sparse,     Defect::OneSided,
                                            Defect::Hole,   Defect::Stripes,  Defect::Misregistered, Defect::HeavyNoise, Defect::Mixed};
    return all;
}

std::string to_string(Defect defect) {
    switch (defect) {
        case Defect::Clean: return "clean";
        case Defect::Outliers: return "outliers";
        case Defect::Density: return "density";
        case Defect::Sparse: return "sparse";
        case Defect::OneSided: return "one-sided";
        case Defect::Hole: return "hole";
        case Defect::Stripes: return "stripes";
        case Defect::Misregistered: return "misregistered";
        case Defect::HeavyNoise: return "heavy-noise";
        case Defect::Mixed: return "mixed";
    }
    return "?";
}

Defect parse_defect(const std::string& name) {
    for (Defect d : all_defects())
        if (to_string(d) == name) return d;
    PCP_FAIL("unknown defect class '" << name
                                      << "' (use clean, outliers, density, sparse, one-sided, hole, stripes, misregistered, heavy-noise or mixed)");
}

Points make_defect_cloud(const Mesh& mesh, Defect defect, const DefectOptions& options) {
    PCP_CHECK(options.points >= 100, "defect cloud: at least 100 points, got " << options.points);
    const Box box = box_of(mesh);
    Rng rng(options.seed, 0xDEFEC70000000000ull + static_cast<std::uint64_t>(defect));
    const int axis = options.axis >= 0 ? options.axis % 3 : static_cast<int>(rng.below(3));
    const double diag = box.diagonal();
    const Eigen::Index n = options.points;
    const auto plain = [&](Eigen::Index count) { return sample_mesh_surface(mesh, count, options.seed).points; };
    switch (defect) {
        case Defect::Clean: return plain(n);
        case Defect::Outliers: {
            const auto out = static_cast<Eigen::Index>(std::llround(0.02 * static_cast<double>(n)));
            return with_outliers(plain(n - out), out, box, rng);
        }
        case Defect::Density: return density_gradient(mesh, n, options.seed, box, axis, 20.0);
        case Defect::Sparse: return plain(std::min<Eigen::Index>(n, 3000));
        case Defect::OneSided: return one_sided(mesh, n, options.seed, box, axis, rng);
        case Defect::Hole: {
            const auto cut = static_cast<Eigen::Index>(std::llround(0.036 * static_cast<double>(n)));
            const Points all = plain(n + cut);
            const Eigen::Vector3d centre = all.row(static_cast<Eigen::Index>(rng.below(static_cast<std::uint64_t>(all.rows())))).transpose();
            std::vector<Eigen::Index> order(static_cast<std::size_t>(all.rows()));
            std::iota(order.begin(), order.end(), 0);
            const Eigen::VectorXd d = (all.rowwise() - centre.transpose()).rowwise().norm();
            std::stable_sort(order.begin(), order.end(), [&](Eigen::Index a, Eigen::Index b) { return d(a) < d(b); });
            std::sort(order.begin() + cut, order.end());
            Points out(n, 3);
            for (Eigen::Index i = 0; i < n; ++i) out.row(i) = all.row(order[static_cast<std::size_t>(cut + i)]);
            return out;
        }
        case Defect::Stripes: {
            const double lo = box.lo(axis), period = std::max(box.hi(axis) - box.lo(axis), 1e-12) / 60.0;
            return sample_kept(mesh, n, options.seed, [&](const Eigen::Vector3d& p, Rng&) {
                const double t = (p(axis) - lo) / period;
                return t - std::floor(t) < 0.4;
            });
        }
        case Defect::Misregistered: {
            Points out = plain(n);
            Eigen::Vector3d shift(rng.normal(), rng.normal(), rng.normal());
            shift = 0.003 * diag * shift.normalized();
            out.bottomRows(n / 2).rowwise() += shift.transpose();
            return out;
        }
        case Defect::HeavyNoise: {
            Points out = plain(n);
            add_noise(out, 0.01 * diag, rng);
            return out;
        }
        case Defect::Mixed: {
            const auto out = static_cast<Eigen::Index>(std::llround(0.01 * static_cast<double>(n)));
            Points p = density_gradient(mesh, n - out, options.seed, box, axis, 5.0);
            add_noise(p, 0.003 * diag, rng);
            return with_outliers(p, out, box, rng);
        }
    }
    return plain(n);
}

}  // namespace pcp
