// Tests for pcp/eval/defects.hpp: on a sphere, every class has its size, is seeded and finite, and
// has its defect: the clean points on the surface, 2 % outliers off it, a density 1:20 along the
// axis, no point on the far side of a one-sided scan, a patch with no point, only the stripes, half
// the points shifted, the heavy noise's spread; bad input throws.
#include "pcp/core/error.hpp"
#include "pcp/eval/defects.hpp"
#include "pcp/eval/eval.hpp"
#include "test_meshes.hpp"

#include <catch2/catch.hpp>

#include <cmath>

namespace {

const pcp::Mesh& sphere() {
    static const pcp::Mesh m = pcp::test::uv_sphere(1.0, 96, 192);
    return m;
}

/// Distances of the points to the sphere's mesh.
Eigen::VectorXd off_surface(const pcp::Points& p) { return pcp::point_to_mesh_distance(sphere(), p); }

pcp::Points make(pcp::Defect d, Eigen::Index n = 4000, std::uint64_t seed = 3) {
    pcp::DefectOptions o;
    o.points = n;
    o.seed = seed;
    o.axis = 2;
    return pcp::make_defect_cloud(sphere(), d, o);
}

}  // namespace

TEST_CASE("defects: every class has its size, is seeded and finite", "[defects]") {
    for (pcp::Defect d : pcp::all_defects()) {
        INFO(pcp::to_string(d));
        CHECK(pcp::parse_defect(pcp::to_string(d)) == d);
        const pcp::Points a = make(d), b = make(d), c = make(d, 4000, 4);
        CHECK(a.allFinite());
        CHECK(a == b);
        CHECK_FALSE(a == c);
        if (d == pcp::Defect::OneSided) {
            CHECK(a.rows() <= 4000);
            CHECK(a.rows() > 2000);
        } else {
            CHECK(a.rows() == (d == pcp::Defect::Sparse ? 3000 : 4000));
        }
    }
    CHECK_THROWS_WITH(pcp::parse_defect("dusty"), Catch::Contains("unknown defect class 'dusty'"));
    CHECK_THROWS_AS(pcp::make_defect_cloud(pcp::Mesh{}, pcp::Defect::Clean), pcp::Error);
}

TEST_CASE("defects: each class has its defect", "[defects]") {
    const double diag = (sphere().vertices.colwise().maxCoeff() - sphere().vertices.colwise().minCoeff()).norm();
    CHECK(off_surface(make(pcp::Defect::Clean)).maxCoeff() < 1e-9);
    // 2 % uniform in the grown box: most of them well off the surface.
    const Eigen::VectorXd out = off_surface(make(pcp::Defect::Outliers));
    CHECK((out.array() > 0.05).count() >= 40);
    CHECK((out.array() > 1e-9).count() <= 80);
    // 1:20 along z; the sphere's area is the same in every slab of equal height (Archimedes).
    const pcp::Points dense = make(pcp::Defect::Density, 20000);
    const auto top = (dense.col(2).array() > 0.8).count(), bottom = (dense.col(2).array() < -0.8).count();
    INFO("top " << top << ", bottom " << bottom);
    CHECK(top > 10 * bottom);  // 20^0.9 = 14.8 expected
    // Three cameras within 35 degrees of +z: nothing below -0.6, most above 0.
    const pcp::Points seen = make(pcp::Defect::OneSided);
    CHECK(seen.col(2).minCoeff() > -0.6);
    CHECK((seen.col(2).array() > 0).count() > seen.rows() / 2);
    CHECK(off_surface(seen).maxCoeff() < 0.01 * diag);  // noise 0.1 % of the diagonal, 4 sigma and more
    // A patch with no point: some clean point has none of the holed cloud's points near it.
    const pcp::Points clean = make(pcp::Defect::Clean), holed = make(pcp::Defect::Hole);
    double gap = 0;
    for (Eigen::Index i = 0; i < clean.rows(); ++i) gap = std::max(gap, (holed.rowwise() - clean.row(i)).rowwise().norm().minCoeff());
    CHECK(gap > 0.15);  // 3.6 % of a unit sphere is a cap of radius about 0.38
    // Stripes: 60 periods across z, 40 % of each kept.
    const pcp::Points striped = make(pcp::Defect::Stripes);
    const double period = (sphere().vertices.col(2).maxCoeff() - sphere().vertices.col(2).minCoeff()) / 60.0;
    int outside = 0;
    for (Eigen::Index i = 0; i < striped.rows(); ++i) {
        const double t = (striped(i, 2) - sphere().vertices.col(2).minCoeff()) / period;
        outside += t - std::floor(t) >= 0.4;
    }
    CHECK(outside == 0);
    // Half the points shifted by 0.3 % of the diagonal.
    const Eigen::VectorXd shifted = off_surface(make(pcp::Defect::Misregistered));
    CHECK(shifted.head(2000).maxCoeff() < 1e-9);
    CHECK(shifted.tail(2000).maxCoeff() <= 0.003 * diag + 1e-6);
    CHECK(shifted.tail(2000).mean() > 0.001 * diag);
    // Heavy noise: 1 % of the diagonal per axis, so about 0.8 x that from the surface on average.
    const Eigen::VectorXd noisy = off_surface(make(pcp::Defect::HeavyNoise));
    CHECK(noisy.mean() > 0.005 * diag);
    CHECK(noisy.mean() < 0.012 * diag);
}
