// Generated training shapes for the built-in prior (pcp/train/training_shapes.hpp). Each shape is
// a small tree of signed-distance primitives combined by CSG, drawn from the RNG stream
// (seed, index); its surface is sampled through a marching-cubes mesh of the distance (uniform by
// area) and Newton projection onto the zero set.
#include "pcp/train/training_shapes.hpp"

#include "pcp/core/error.hpp"
#include "pcp/core/rng.hpp"
#include "pcp/mesh/grid/marching_cubes.hpp"
#include "pcp/mesh/grid/sdf_grid.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace pcp {

namespace {

using Sdf = std::function<double(const Eigen::Vector3d&)>;
using V3 = Eigen::Vector3d;

double uniform(Rng& rng, double lo, double hi) { return lo + (hi - lo) * rng.uniform(); }

// ---- primitives, centred at the origin ------------------------------------------------------

Sdf box(const V3& half) {
    return [half](const V3& p) {
        const V3 q = p.cwiseAbs() - half;
        return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
    };
}

Sdf rounded_box(const V3& half, double radius) {
    const Sdf inner = box((half.array() - radius).cwiseMax(1e-3).matrix());
    return [inner, radius](const V3& p) { return inner(p) - radius; };
}

/// Capped cylinder along z: radius r, half height h.
Sdf cylinder(double r, double h) {
    return [r, h](const V3& p) {
        const double dx = std::hypot(p.x(), p.y()) - r, dz = std::abs(p.z()) - h;
        return std::min(std::max(dx, dz), 0.0) + std::hypot(std::max(dx, 0.0), std::max(dz, 0.0));
    };
}

/// Frustum along z from radius r0 (z = -h) to r1 (z = +h); the side distance is measured across
/// the slanted wall (exact on the wall, a bound near the rims).
Sdf frustum(double r0, double r1, double h) {
    const double slope = (r1 - r0) / (2.0 * h), c = 1.0 / std::sqrt(1.0 + slope * slope);
    return [=](const V3& p) {
        const double r = r0 + slope * (p.z() + h);
        const double side = (std::hypot(p.x(), p.y()) - r) * c, cap = std::abs(p.z()) - h;
        return std::min(std::max(side, cap), 0.0) + std::hypot(std::max(side, 0.0), std::max(cap, 0.0));
    };
}

/// Ellipsoid with radii `a` (a distance bound, exact on the surface's sign).
Sdf ellipsoid(const V3& a) {
    return [a](const V3& p) {
        const double k0 = p.cwiseQuotient(a).norm(), k1 = p.cwiseQuotient(a.cwiseProduct(a)).norm();
        return k1 > 1e-12 ? k0 * (k0 - 1.0) / k1 : -a.minCoeff();
    };
}

Sdf torus(double major, double minor) {
    return [major, minor](const V3& p) { return std::hypot(std::hypot(p.x(), p.y()) - major, p.z()) - minor; };
}

/// Segment from -h to +h along z, radius r.
Sdf capsule(double r, double h) {
    return [r, h](const V3& p) {
        const double z = std::clamp(p.z(), -h, h);
        return (p - V3(0, 0, z)).norm() - r;
    };
}

/// An open shell: a hollow sphere of radius r and wall half-thickness t, cut by the plane z = c.
Sdf open_shell(double r, double t, double c) {
    return [=](const V3& p) { return std::max(std::abs(p.norm() - r) - t, p.z() - c); };
}

// ---- placement and operations -------------------------------------------------------------------

/// A rotation: the identity half of the time (CAD parts are mostly axis-aligned), else uniform.
Eigen::Matrix3d random_rotation(Rng& rng) {
    if (rng.uniform() < 0.5) return Eigen::Matrix3d::Identity();
    Eigen::Quaterniond q(rng.normal(), rng.normal(), rng.normal(), rng.normal());
    if (q.norm() < 1e-9) return Eigen::Matrix3d::Identity();
    return q.normalized().toRotationMatrix();
}

Sdf placed(Sdf f, const Eigen::Matrix3d& rotation, const V3& offset) {
    const Eigen::Matrix3d inverse = rotation.transpose();
    return [f = std::move(f), inverse, offset](const V3& p) { return f(inverse * (p - offset)); };
}

/// A random primitive about `size` across; its kind is appended to `name`.
Sdf random_primitive(Rng& rng, double size, std::string& name) {
    const double s = 0.5 * size;
    switch (rng.below(9)) {
    case 0: name += "box"; return box(V3(uniform(rng, 0.3, 1.0), uniform(rng, 0.3, 1.0), uniform(rng, 0.3, 1.0)) * s);
    case 1: {
        name += "roundbox";
        const V3 h = V3(uniform(rng, 0.4, 1.0), uniform(rng, 0.4, 1.0), uniform(rng, 0.4, 1.0)) * s;
        return rounded_box(h, uniform(rng, 0.05, 0.3) * h.minCoeff());
    }
    case 2: name += "cylinder"; return cylinder(uniform(rng, 0.25, 0.8) * s, uniform(rng, 0.3, 1.0) * s);
    case 3: name += "cone"; return frustum(uniform(rng, 0.4, 0.9) * s, uniform(rng, 0.0, 0.4) * s, uniform(rng, 0.4, 1.0) * s);
    case 4: name += "ellipsoid"; return ellipsoid(V3(uniform(rng, 0.4, 1.0), uniform(rng, 0.4, 1.0), uniform(rng, 0.4, 1.0)) * s);
    case 5: {
        name += "torus";
        const double major = uniform(rng, 0.5, 0.8) * s;
        return torus(major, uniform(rng, 0.15, 0.45) * major);
    }
    case 6: name += "capsule"; return capsule(uniform(rng, 0.15, 0.4) * s, uniform(rng, 0.3, 0.8) * s);
    case 7: {  // a thin plate: thin parts
        name += "plate";
        return box(V3(uniform(rng, 0.5, 1.0) * s, uniform(rng, 0.5, 1.0) * s, uniform(rng, 0.015, 0.03)));
    }
    default: {  // an open shell: a thin wall with a rim
        name += "shell";
        const double r = uniform(rng, 0.6, 1.0) * s;
        return open_shell(r, uniform(rng, 0.012, 0.025), uniform(rng, -0.3, 0.5) * r);
    }
    }
}

Sdf smooth_union(Sdf a, Sdf b, double k) {
    return [a = std::move(a), b = std::move(b), k](const V3& p) {
        const double da = a(p), db = b(p);
        const double h = std::clamp(0.5 + 0.5 * (db - da) / k, 0.0, 1.0);
        return db + (da - db) * h - k * h * (1.0 - h);
    };
}

V3 random_direction(Rng& rng) {
    V3 d(rng.normal(), rng.normal(), rng.normal());
    while (d.norm() < 1e-9) d = V3(rng.normal(), rng.normal(), rng.normal());
    return d.normalized();
}

/// The bounding box of {sdf <= 0} from a coarse grid over [-1.5, 1.5]^3, grown by two coarse cells.
Aabb inside_box(const Sdf& sdf) {
    constexpr int n = 64;
    const double lo = -1.5, step = 3.0 / n;
    V3 mn = V3::Constant(1e9), mx = V3::Constant(-1e9);
    for (int i = 0; i <= n; ++i)
        for (int j = 0; j <= n; ++j)
            for (int k = 0; k <= n; ++k) {
                const V3 p(lo + i * step, lo + j * step, lo + k * step);
                if (sdf(p) <= step) {
                    mn = mn.cwiseMin(p);
                    mx = mx.cwiseMax(p);
                }
            }
    PCP_CHECK((mx.array() >= mn.array()).all(), "training shape: empty");
    Aabb b;
    b.min = mn.array() - 2.0 * step;
    b.max = mx.array() + 2.0 * step;
    return b;
}

}  // namespace

TrainingShape make_training_shape(int index, std::uint64_t seed) {
    PCP_CHECK(index >= 0, "training shape: index must be >= 0");
    Rng rng(seed, 1000 + static_cast<std::uint64_t>(index));
    std::string name;
    Sdf shape = placed(random_primitive(rng, 1.0, name), random_rotation(rng), V3::Zero());
    const int operations = 1 + static_cast<int>(rng.below(3));
    for (int op = 0; op < operations; ++op) {
        const double kind = rng.uniform();
        if (kind < 0.30) {  // union with a part attached somewhere near the surface
            name += "+";
            Sdf part = random_primitive(rng, uniform(rng, 0.3, 0.8), name);
            shape = [a = shape, b = placed(std::move(part), random_rotation(rng), 0.35 * random_direction(rng))](const V3& p) {
                return std::min(a(p), b(p));
            };
        } else if (kind < 0.50) {  // a blend
            name += "~";
            Sdf part = random_primitive(rng, uniform(rng, 0.3, 0.8), name);
            shape = smooth_union(shape, placed(std::move(part), random_rotation(rng), 0.35 * random_direction(rng)),
                                 uniform(rng, 0.03, 0.12));
        } else if (kind < 0.85) {  // a hole: a through-cylinder, a pocket or a dent
            const double hole = rng.uniform();
            Sdf cutter;
            if (hole < 0.5) {
                name += "-hole";
                cutter = cylinder(uniform(rng, 0.04, 0.15), 2.0);
            } else if (hole < 0.8) {
                name += "-pocket";
                cutter = box(V3(uniform(rng, 0.05, 0.2), uniform(rng, 0.05, 0.2), uniform(rng, 0.05, 0.3)));
            } else {
                name += "-dent";
                cutter = ellipsoid(V3::Constant(uniform(rng, 0.08, 0.2)));
            }
            const V3 offset = V3(uniform(rng, -0.2, 0.2), uniform(rng, -0.2, 0.2), uniform(rng, -0.2, 0.2));
            shape = [a = shape, b = placed(std::move(cutter), random_rotation(rng), offset)](const V3& p) {
                return std::max(a(p), -b(p));
            };
        } else {  // a sharp planar cut
            name += "/cut";
            const V3 normal = random_direction(rng);
            const double offset = uniform(rng, 0.1, 0.3);
            shape = [a = shape, normal, offset](const V3& p) { return std::max(a(p), normal.dot(p) - offset); };
        }
    }
    std::ostringstream label;
    label << "shape_" << index << " " << name;
    TrainingShape out{label.str(), shape, {}};
    out.box = inside_box(out.sdf);
    return out;
}

Points sample_training_shape(const TrainingShape& shape, Eigen::Index n, double noise, std::uint64_t seed,
                             int mesh_resolution) {
    PCP_CHECK(n >= 1 && noise >= 0.0 && mesh_resolution >= 8, "training shape: need n >= 1, noise >= 0, resolution >= 8");
    const GridSpec spec = make_grid_spec(shape.box, mesh_resolution, 0.0);
    SdfGridOptions grid_options;
    grid_options.band = NarrowBand::Dense;
    const SdfGrid grid = evaluate_sdf_grid(
        [&shape](const Eigen::Ref<const PointsF>& points, Eigen::Ref<Eigen::VectorXf> values) {
            for (Eigen::Index i = 0; i < points.rows(); ++i)
                values(i) = static_cast<float>(shape.sdf(points.row(i).transpose().cast<double>()));
        },
        spec, grid_options);
    const Mesh mesh = marching_cubes(grid);
    PCP_CHECK(mesh.faces.rows() > 0, shape.name << ": no surface");

    // Triangles by cumulative area.
    std::vector<double> cumulative(static_cast<std::size_t>(mesh.faces.rows()));
    double total = 0.0;
    for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
        const V3 a = mesh.vertices.row(mesh.faces(f, 0)), b = mesh.vertices.row(mesh.faces(f, 1)),
                 c = mesh.vertices.row(mesh.faces(f, 2));
        total += 0.5 * (b - a).cross(c - a).norm();
        cumulative[static_cast<std::size_t>(f)] = total;
    }
    Rng rng(seed, 7);
    const double diagonal = shape.box.extent().norm(), h = 1e-6 * diagonal;
    Points out(n, 3);
    for (Eigen::Index i = 0; i < n; ++i) {
        const double u = rng.uniform() * total;
        const auto f = static_cast<Eigen::Index>(std::min<std::ptrdiff_t>(
            std::lower_bound(cumulative.begin(), cumulative.end(), u) - cumulative.begin(), mesh.faces.rows() - 1));
        double r1 = rng.uniform(), r2 = rng.uniform();
        if (r1 + r2 > 1.0) {
            r1 = 1.0 - r1;
            r2 = 1.0 - r2;
        }
        const V3 a = mesh.vertices.row(mesh.faces(f, 0)), b = mesh.vertices.row(mesh.faces(f, 1)),
                 c = mesh.vertices.row(mesh.faces(f, 2));
        V3 p = a + r1 * (b - a) + r2 * (c - a);
        for (int it = 0; it < 4; ++it) {  // Newton steps onto the zero set
            const double d = shape.sdf(p);
            V3 g;
            for (int k = 0; k < 3; ++k) {
                V3 e = V3::Zero();
                e(k) = h;
                g(k) = (shape.sdf(p + e) - shape.sdf(p - e)) / (2.0 * h);
            }
            const double g2 = g.squaredNorm();
            if (g2 < 1e-12) break;
            p -= d * g / g2;
        }
        out.row(i) = p.transpose();
    }
    if (noise > 0.0)
        for (Eigen::Index i = 0; i < n; ++i)
            for (int k = 0; k < 3; ++k) out(i, k) += noise * rng.normal();
    return out;
}

std::vector<TrainingCloud> generate_training_clouds(const TrainingShapeOptions& options) {
    PCP_CHECK(options.count >= 1 && !options.points.empty() && !options.noise.empty(),
              "training shapes: need count >= 1 and non-empty point and noise lists");
    std::vector<TrainingCloud> clouds(static_cast<std::size_t>(options.count));
    std::vector<std::string> errors(static_cast<std::size_t>(options.count));
#pragma omp parallel for schedule(dynamic, 1)
    for (int i = 0; i < options.count; ++i) try {
        const TrainingShape shape = make_training_shape(i, options.seed);
        const std::size_t np = options.points.size();
        const Eigen::Index n = options.points[static_cast<std::size_t>(i) % np];
        const double noise = options.noise[(static_cast<std::size_t>(i) / np) % options.noise.size()];
        std::ostringstream name;
        name << shape.name << " (" << n << " points, noise " << noise << ")";
        clouds[static_cast<std::size_t>(i)] =
            TrainingCloud{name.str(), sample_training_shape(shape, n, noise * shape.box.extent().norm(),
                                                            options.seed * 1000003u + static_cast<std::uint64_t>(i),
                                                            options.mesh_resolution)};
    } catch (const std::exception& e) {
        errors[static_cast<std::size_t>(i)] = e.what();
    }
    for (const std::string& e : errors) PCP_CHECK(e.empty(), "training shapes: " << e);
    return clouds;
}

}  // namespace pcp
