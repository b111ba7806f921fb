// Tests for pcp/cloud/visibility.hpp: inside / outside labels by visibility through the dilated
// cloud, checked against exact signed distances of analytic shapes.
#include "pcp/cloud/prepared_cloud.hpp"
#include "pcp/cloud/shapes.hpp"
#include "pcp/cloud/visibility.hpp"
#include "pcp/core/error.hpp"
#include "pcp/core/rng.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <functional>
#include <vector>

namespace {

pcp::Aabb grown_box(const pcp::PointsF& unit, double margin) {
    pcp::Aabb box;
    box.min = unit.colwise().minCoeff().transpose().cast<double>().array() - margin;
    box.max = unit.colwise().maxCoeff().transpose().cast<double>().array() + margin;
    return box;
}

/// The labelled cells whose centre, mapped back to the cloud's frame, satisfies pred(p, label).
int count_cells(const pcp::VisibilityLabels& l, const pcp::PreparedCloud& cloud,
                const std::function<bool(const Eigen::Vector3d&, int)>& pred) {
    int n = 0;
    for (int k = 0; k < l.dims.z(); ++k)
        for (int j = 0; j < l.dims.y(); ++j)
            for (int i = 0; i < l.dims.x(); ++i) {
                pcp::Points c(1, 3);
                c.row(0) = l.center(i, j, k).transpose();
                if (pred(cloud.normalization().from_unit(c).row(0).transpose(), l.label[l.index(i, j, k)])) ++n;
            }
    return n;
}

struct Agreement {
    int inside = 0, outside = 0, wrong = 0;
};

/// Every labelled cell's centre, mapped back to the shape's frame, against the exact SDF.
Agreement check_labels(const pcp::VisibilityLabels& l, const pcp::PreparedCloud& cloud,
                       const std::function<double(const Eigen::Vector3d&)>& sdf) {
    Agreement a;
    a.inside = count_cells(l, cloud, [](const Eigen::Vector3d&, int label) { return label < 0; });
    a.outside = count_cells(l, cloud, [](const Eigen::Vector3d&, int label) { return label > 0; });
    a.wrong = count_cells(l, cloud, [&](const Eigen::Vector3d& p, int label) { return label != 0 && (label < 0) != (sdf(p) < 0); });
    return a;
}

/// Of the lines along `dirs` through p, those whose distance to every one of `points` exceeds
/// `radius` (brute force).
int free_lines_exact(const pcp::PointsF& points, const Eigen::Vector3d& p, const std::vector<Eigen::Vector3d>& dirs, double radius) {
    int n = 0;
    for (const Eigen::Vector3d& d : dirs) {
        bool free = true;
        for (Eigen::Index i = 0; i < points.rows() && free; ++i) {
            const Eigen::Vector3d w = points.row(i).transpose().cast<double>() - p;
            free = (w - w.dot(d) * d).norm() > radius;
        }
        n += free;
    }
    return n;
}

/// ThroughLines::count at p between the brute-force counts at the balls' radius (a line its bitmap
/// finds free is free) and a stamp's slack beyond it (a stamp covers the disc and at most an eighth
/// of a pixel diagonal more, beyond the pixel itself).
void check_count_bounds(const pcp::ThroughLines& lines, const pcp::PointsF& points, int directions, const Eigen::Vector3d& p) {
    const std::vector<Eigen::Vector3d> dirs = pcp::line_directions(directions);
    const double r = lines.radius(), slack = 1.125 * std::sqrt(2.0) * lines.voxel();
    const int n = lines.count(p, directions);
    INFO("at " << p.transpose() << ": " << n << " free lines");
    CHECK(n <= free_lines_exact(points, p, dirs, r));
    CHECK(n >= free_lines_exact(points, p, dirs, r + slack));
}

}  // namespace

TEST_CASE("visibility: a sphere's inside and outside are labelled, and nothing wrongly", "[visibility][heavy]") {
    const pcp::PointCloud s = pcp::sample_sphere(6000, 0.4, Eigen::Vector3d::Zero(), 3);
    const pcp::PreparedCloud cloud(s.points, "sphere", 2);
    const pcp::VisibilityLabels l = pcp::label_by_visibility(cloud.tree(), grown_box(cloud.unit(), 0.05));
    const Agreement a = check_labels(l, cloud, [](const Eigen::Vector3d& p) { return p.norm() - 0.4; });
    CHECK(a.wrong == 0);
    CHECK(a.inside > 100);
    CHECK(a.outside > 1000);
    CHECK(l.stats.inside == a.inside);
    CHECK(l.stats.inside + l.stats.outside + l.stats.unknown + l.stats.near == std::int64_t(l.label.size()));
    CHECK(l.inside_cells.size() == std::size_t(a.inside));
}

TEST_CASE("visibility: the default shape's through-hole is outside, its block inside", "[visibility][heavy]") {
    const pcp::PointCloud s = pcp::sample_default_shape(20000, 0.0, 5);
    const pcp::PreparedCloud cloud(s.points, "default shape", 2);
    // The middle of the hole sees out through its two ends (about 16 % of the directions): outside
    // at an outside_fraction of 0.1 (without the through-lines of the next test, unknown at the
    // default 0.5); never inside.
    pcp::VisibilityOptions o;
    o.outside_fraction = 0.1;
    o.min_through_lines = 0;
    o.line_directions = 0;
    const pcp::VisibilityLabels l = pcp::label_by_visibility(cloud.tree(), grown_box(cloud.unit(), 0.05), o);
    const Agreement a = check_labels(l, cloud, [](const Eigen::Vector3d& p) { return pcp::default_shape_sdf(p); });
    CHECK(a.wrong == 0);
    CHECK(a.inside > 50);
    pcp::VisibilityOptions half;
    half.min_through_lines = 0;
    half.line_directions = 0;
    const pcp::VisibilityLabels d = pcp::label_by_visibility(cloud.tree(), grown_box(cloud.unit(), 0.05), half);
    CHECK(check_labels(d, cloud, [](const Eigen::Vector3d& p) { return pcp::default_shape_sdf(p); }).wrong == 0);
    CHECK(d.stats.outside < l.stats.outside);
    // Cells on the hole's axis (x = -0.2, y = 0, inside the block's z range) are outside.
    const int hole_outside = count_cells(l, cloud, [](const Eigen::Vector3d& p, int label) {
        return std::hypot(p.x() + 0.2, p.y()) < 0.06 && std::abs(p.z()) < 0.15 && label > 0;
    });
    CHECK(hole_outside >= 3);
}

TEST_CASE("visibility: the middle of a through-hole is outside by its lines that cross no wall", "[visibility][heavy]") {
    // At the default outside_fraction the hole's middle sees out along too few directions; every one
    // of them escapes at both ends, which min_through_lines counts (and the exact count of step 4).
    // No cell is labelled wrongly.
    const pcp::PointCloud s = pcp::sample_default_shape(20000, 0.0, 5);
    const pcp::PreparedCloud cloud(s.points, "default shape", 2);
    const auto sdf = [](const Eigen::Vector3d& p) { return pcp::default_shape_sdf(p); };
    const auto on_axis = [](const Eigen::Vector3d& p, int label) {
        return std::hypot(p.x() + 0.2, p.y()) < 0.06 && std::abs(p.z()) < 0.15 && label > 0;
    };
    const pcp::VisibilityLabels with = pcp::label_by_visibility(cloud.tree(), grown_box(cloud.unit(), 0.05));
    CHECK(check_labels(with, cloud, sdf).wrong == 0);
    CHECK(count_cells(with, cloud, on_axis) >= 3);
    pcp::VisibilityOptions off;
    off.min_through_lines = 0;
    off.line_directions = 0;
    const pcp::VisibilityLabels without = pcp::label_by_visibility(cloud.tree(), grown_box(cloud.unit(), 0.05), off);
    CHECK(count_cells(without, cloud, on_axis) == 0);
    CHECK(without.stats.outside < with.stats.outside);
    CHECK(without.stats.inside == with.stats.inside);  // a cell no ray leaves has no line either
}

TEST_CASE("visibility: from inside an open shell the opening is seen, so nothing there is inside", "[visibility][heavy]") {
    // A sphere with its cap above z = 0.25 cut away: the centre sees out through the cap (about 19 %
    // of the directions), and without the cut it sees nothing.
    const pcp::PointCloud full = pcp::sample_sphere(8000, 0.4, Eigen::Vector3d::Zero(), 4);
    pcp::Points kept(full.points.rows(), 3);
    Eigen::Index n = 0;
    for (Eigen::Index i = 0; i < full.points.rows(); ++i)
        if (full.points(i, 2) < 0.25) kept.row(n++) = full.points.row(i);
    kept.conservativeResize(n, 3);
    const pcp::PreparedCloud open(kept, "open sphere", 2);
    const pcp::VisibilityLabels l = pcp::label_by_visibility(open.tree(), grown_box(open.unit(), 0.05));
    const int inside_near_centre =
        count_cells(l, open, [](const Eigen::Vector3d& p, int label) { return p.norm() < 0.1 && label < 0; });
    CHECK(inside_near_centre == 0);
}

TEST_CASE("visibility: labels are deterministic", "[visibility]") {
    const pcp::PointCloud s = pcp::sample_torus(6000, 0.3, 0.12, 6);
    const pcp::PreparedCloud cloud(s.points, "torus", 2);
    const pcp::Aabb box = grown_box(cloud.unit(), 0.05);
    const pcp::VisibilityLabels a = pcp::label_by_visibility(cloud.tree(), box);
    const pcp::VisibilityLabels b = pcp::label_by_visibility(cloud.tree(), box);
    CHECK(a.label == b.label);
    REQUIRE(!a.inside_cells.empty());
    REQUIRE(!a.outside_cells.empty());
}

TEST_CASE("visibility: bad options and degenerate input are refused", "[visibility]") {
    const pcp::PointCloud s = pcp::sample_sphere(500, 0.4, Eigen::Vector3d::Zero(), 3);
    const pcp::PreparedCloud cloud(s.points, "sphere", 2);
    const pcp::Aabb box = grown_box(cloud.unit(), 0.05);
    pcp::VisibilityOptions o;
    o.resolution = 2;
    CHECK_THROWS_AS(pcp::label_by_visibility(cloud.tree(), box, o), pcp::Error);
    o = {};
    o.rays = 0;
    CHECK_THROWS_AS(pcp::label_by_visibility(cloud.tree(), box, o), pcp::Error);
    o = {};
    o.dilation = 0;
    CHECK_THROWS_AS(pcp::label_by_visibility(cloud.tree(), box, o), pcp::Error);
    o = {};
    o.outside_fraction = 1.5;
    CHECK_THROWS_AS(pcp::label_by_visibility(cloud.tree(), box, o), pcp::Error);
    o = {};
    o.min_through_lines = -1;
    CHECK_THROWS_AS(pcp::label_by_visibility(cloud.tree(), box, o), pcp::Error);
    o.min_through_lines = o.rays + 1;
    CHECK_THROWS_AS(pcp::label_by_visibility(cloud.tree(), box, o), pcp::Error);
    pcp::Aabb flat = box;
    flat.max.z() = flat.min.z();
    CHECK_THROWS_AS(pcp::label_by_visibility(cloud.tree(), flat, {}), pcp::Error);
}

TEST_CASE("visibility: through lines at points: none from a sphere's centre, many beside it", "[visibility]") {
    const pcp::KdTree tree(pcp::sample_sphere(4000, 0.3, Eigen::Vector3d::Zero(), 4).points.cast<float>());
    pcp::Aabb box;
    box.min = Eigen::Vector3d::Constant(-0.5);
    box.max = Eigen::Vector3d::Constant(0.5);
    const pcp::ThroughLines lines(tree, box, 128, 0.5, 256);
    CHECK(lines.voxel() == Approx(1.0 / 128));
    CHECK(lines.radius() == Approx(0.5 * pcp::sampling_scale(tree)));
    CHECK(lines.clearance(Eigen::Vector3d::Zero()) > 0);
    CHECK(lines.clearance(Eigen::Vector3d(0.3, 0, 0)) == 0);  // on the surface: blocked
    CHECK(lines.clearance(Eigen::Vector3d(2, 0, 0)) == 255);  // outside the grid
    // The centre: every line meets the sphere; a corner of the box: most lines pass it by.
    CHECK(lines.count(Eigen::Vector3d::Zero(), 256) == 0);
    const int corner = lines.count(Eigen::Vector3d(0.42, 0.42, 0), 256);
    CHECK(corner > 128);
    CHECK(corner < 256);
    CHECK(lines.count(Eigen::Vector3d(0.42, 0.42, 0), 3) == 3);  // stops at enough
    CHECK_THROWS_AS(pcp::ThroughLines(tree, box, 4, 0.5, 64), pcp::Error);
    CHECK_THROWS_AS(pcp::ThroughLines(tree, box, 128, 0.0, 64), pcp::Error);
    CHECK_THROWS_AS(pcp::ThroughLines(tree, box, 128, 0.5, 0), pcp::Error);
    CHECK_THROWS_AS(pcp::ThroughLines(tree, box, 128, 0.5, 4097), pcp::Error);
    CHECK_THROWS_AS(lines.count(Eigen::Vector3d::Zero(), 0), pcp::Error);
}

TEST_CASE("visibility: through lines counted within a pixel of each line's distance to the balls, and a bore's few lines found", "[visibility]") {
    // The wall of a tube of radius 0.06 along x, 0.6 long: from its middle the lines that leave at
    // both ends lie in a cone of about 10 degrees, some 2 % of the directions.
    pcp::Rng rng(3);
    pcp::PointsF tube(6000, 3);
    for (Eigen::Index i = 0; i < tube.rows(); ++i) {
        const double x = -0.3 + 0.6 * rng.uniform(), a = 2 * 3.14159265358979 * rng.uniform();
        tube.row(i) = Eigen::RowVector3f(float(x), float(0.06 * std::cos(a)), float(0.06 * std::sin(a)));
    }
    const pcp::KdTree tree(tube);
    pcp::Aabb box;
    box.min = Eigen::Vector3d::Constant(-0.5);
    box.max = Eigen::Vector3d::Constant(0.5);
    const int n_dirs = 1024;
    const pcp::ThroughLines lines(tree, box, 256, 0.5, n_dirs);
    const std::vector<Eigen::Vector3d> dirs = pcp::line_directions(n_dirs);
    REQUIRE(dirs.size() == std::size_t(n_dirs));
    for (const Eigen::Vector3d& d : dirs) CHECK(d.z() > 0);
    for (const Eigen::Vector3d& p : {Eigen::Vector3d(0.05, 0.0, 0.01), Eigen::Vector3d(0.0, 0.2, 0.1), Eigen::Vector3d(-0.2, 0.03, -0.02)})
        check_count_bounds(lines, tube, n_dirs, p);
    const int bore = lines.count(Eigen::Vector3d(0.05, 0.0, 0.01), n_dirs);
    CHECK(bore >= 6);
    CHECK(bore <= 40);
}

TEST_CASE("visibility: a narrow bore's middle is labelled outside by its exact lines, not by 64 random rays", "[visibility]") {
    // A cube 0.6 across with a bore of radius 0.07 along x through it: points on the cube's faces
    // but the bore's mouths, and on the bore's wall. From the bore's middle a cone of about 13
    // degrees leaves at both ends: under 3 % of the directions.
    pcp::Rng rng(21);
    std::vector<Eigen::RowVector3f> kept;
    const double h = 0.3, radius = 0.07;
    while (kept.size() < 30000) {
        Eigen::Vector3d x(2 * rng.uniform() - 1, 2 * rng.uniform() - 1, 2 * rng.uniform() - 1);
        const int axis = int(rng.below(3));
        x(axis) = rng.uniform() < 0.5 ? -1.0 : 1.0;
        x *= h;
        if (axis == 0 && std::hypot(x.y(), x.z()) < radius) continue;  // a mouth
        kept.emplace_back(x.cast<float>().transpose());
    }
    for (int i = 0; i < 6000; ++i) {
        const double x = -h + 2 * h * rng.uniform(), a = 2 * 3.14159265358979 * rng.uniform();
        kept.emplace_back(float(x), float(radius * std::cos(a)), float(radius * std::sin(a)));
    }
    pcp::PointsF points(static_cast<Eigen::Index>(kept.size()), 3);
    for (std::size_t i = 0; i < kept.size(); ++i) points.row(static_cast<Eigen::Index>(i)) = kept[i];
    const pcp::KdTree tree(points);
    pcp::Aabb box;
    box.min = Eigen::Vector3d::Constant(-0.5);
    box.max = Eigen::Vector3d::Constant(0.5);
    const Eigen::Vector3d middle(0.01, 0.005, -0.003), body(0.0, 0.19, 0.0);
    const pcp::VisibilityLabels exact = pcp::label_by_visibility(tree, box, {});
    CHECK(exact.label_at(middle) == 1);
    CHECK(exact.label_at(body) == -1);  // the solid between the bore and a face
    pcp::VisibilityOptions rays_only;
    rays_only.line_directions = 0;
    const pcp::VisibilityLabels marched = pcp::label_by_visibility(tree, box, rays_only);
    CHECK(marched.label_at(middle) != 1);
    CHECK(marched.label_at(body) == -1);
    CHECK(exact.stats.outside > marched.stats.outside);
    pcp::VisibilityOptions bad;
    bad.line_directions = 4;
    CHECK_THROWS_AS(pcp::label_by_visibility(tree, box, bad), pcp::Error);
    bad = {};
    bad.min_free_lines = 0;
    CHECK_THROWS_AS(pcp::label_by_visibility(tree, box, bad), pcp::Error);
}

TEST_CASE("visibility: through lines with points outside the box are drawn clipped, counts still bounded", "[visibility]") {
    // A sphere of radius 0.3 centred at x = 0.45: half of it lies beyond the box's face x = 0.5.
    const pcp::PointsF far_points = pcp::sample_sphere(4000, 0.3, Eigen::Vector3d(0.45, 0, 0), 7).points.cast<float>();
    const pcp::KdTree tree(far_points);
    pcp::Aabb box;
    box.min = Eigen::Vector3d::Constant(-0.5);
    box.max = Eigen::Vector3d::Constant(0.5);
    const pcp::ThroughLines lines(tree, box, 128, 0.5, 256);
    for (const Eigen::Vector3d& p : {Eigen::Vector3d(0.45, 0, 0), Eigen::Vector3d(-0.3, 0.2, 0.1), Eigen::Vector3d(0.4, 0.4, 0.4)})
        check_count_bounds(lines, far_points, 256, p);
    CHECK(lines.count(Eigen::Vector3d(0.45, 0, 0), 256) == 0);  // the sphere's centre
}
