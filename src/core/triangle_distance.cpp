// The only file of the library that includes CGAL: an AABB tree over the mesh's triangles for
// exact nearest-triangle distances (the 3D Scene "error" metric of METHOD.md section 6).
#include "core/triangle_distance.hpp"

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Simple_cartesian.h>

#include <vector>

namespace pcp::detail {

namespace {
using Kernel = CGAL::Simple_cartesian<double>;
using Triangle = Kernel::Triangle_3;
using Iterator = std::vector<Triangle>::const_iterator;
using Primitive = CGAL::AABB_triangle_primitive<Kernel, Iterator>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, Primitive>>;
}  // namespace

class TriangleDistance::Impl {
public:
    std::vector<Triangle> triangles;
    std::vector<int> face_of;  ///< the mesh face of each kept triangle
    Tree tree;
};

TriangleDistance::TriangleDistance(const Mesh& mesh) : impl_(std::make_unique<Impl>()) {
    auto vertex = [&](std::int32_t i) {
        return Kernel::Point_3(mesh.vertices(i, 0), mesh.vertices(i, 1), mesh.vertices(i, 2));
    };
    impl_->triangles.reserve(static_cast<std::size_t>(mesh.faces.rows()));
    for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
        Triangle t(vertex(mesh.faces(f, 0)), vertex(mesh.faces(f, 1)), vertex(mesh.faces(f, 2)));
        if (!t.is_degenerate()) {
            impl_->triangles.push_back(t);
            impl_->face_of.push_back(static_cast<int>(f));
        }
    }
    if (impl_->triangles.empty()) {  // all faces degenerate: fall back to the vertices as points
        for (Eigen::Index i = 0; i < mesh.vertices.rows(); ++i)
            impl_->triangles.emplace_back(vertex(static_cast<std::int32_t>(i)), vertex(static_cast<std::int32_t>(i)),
                                          vertex(static_cast<std::int32_t>(i)));
        impl_->face_of.assign(impl_->triangles.size(), -1);
    }
    impl_->tree.insert(impl_->triangles.cbegin(), impl_->triangles.cend());
    impl_->tree.build();
    impl_->tree.accelerate_distance_queries();
}

TriangleDistance::~TriangleDistance() = default;

Eigen::VectorXd TriangleDistance::distances(const Eigen::Ref<const Points>& points) const {
    Eigen::VectorXd d(points.rows());
    const Tree& tree = impl_->tree;
#pragma omp parallel for schedule(dynamic, 256)
    for (Eigen::Index i = 0; i < points.rows(); ++i)
        d(i) = std::sqrt(tree.squared_distance(Kernel::Point_3(points(i, 0), points(i, 1), points(i, 2))));
    return d;
}

Points TriangleDistance::nearest_face_normals(const Eigen::Ref<const Points>& points) const {
    Points normals(points.rows(), 3);
    const Tree& tree = impl_->tree;
#pragma omp parallel for schedule(dynamic, 256)
    for (Eigen::Index i = 0; i < points.rows(); ++i) {
        const auto hit = tree.closest_point_and_primitive(Kernel::Point_3(points(i, 0), points(i, 1), points(i, 2)));
        const Triangle& t = *hit.second;
        const Kernel::Vector_3 n = CGAL::cross_product(t[1] - t[0], t[2] - t[0]);
        const double len = std::sqrt(n.squared_length());
        if (len > 0) normals.row(i) << n.x() / len, n.y() / len, n.z() / len;
        else normals.row(i).setZero();  // the vertex fallback of an all-degenerate mesh
    }
    return normals;
}

Eigen::VectorXi TriangleDistance::nearest_faces(const Eigen::Ref<const Points>& points, Points& closest) const {
    Eigen::VectorXi faces(points.rows());
    closest.resize(points.rows(), 3);
    const Tree& tree = impl_->tree;
#pragma omp parallel for schedule(dynamic, 256)
    for (Eigen::Index i = 0; i < points.rows(); ++i) {
        const auto hit = tree.closest_point_and_primitive(Kernel::Point_3(points(i, 0), points(i, 1), points(i, 2)));
        faces(i) = impl_->face_of[static_cast<std::size_t>(hit.second - impl_->triangles.cbegin())];
        closest.row(i) << hit.first.x(), hit.first.y(), hit.first.z();
    }
    return faces;
}

}  // namespace pcp::detail
