// Small analytic meshes generated in code for tests (no binary fixtures).
#pragma once

#include "pcp/core/types.hpp"

#include <cmath>
#include <vector>

namespace pcp::test {

/// A closed UV sphere (outward-facing triangles) of `rings` latitude bands and `segments` longitudes.
inline Mesh uv_sphere(double radius, int rings, int segments) {
    const double pi = 3.14159265358979323846;
    std::vector<Eigen::RowVector3d> v;
    v.emplace_back(0, 0, radius);
    for (int i = 1; i < rings; ++i) {
        const double theta = pi * i / rings;
        for (int j = 0; j < segments; ++j) {
            const double phi = 2 * pi * j / segments;
            v.emplace_back(radius * std::sin(theta) * std::cos(phi), radius * std::sin(theta) * std::sin(phi),
                           radius * std::cos(theta));
        }
    }
    v.emplace_back(0, 0, -radius);
    const int south = static_cast<int>(v.size()) - 1;
    auto ring = [&](int i, int j) { return 1 + (i - 1) * segments + (j % segments); };
    std::vector<Eigen::RowVector3i> f;
    for (int j = 0; j < segments; ++j) f.emplace_back(0, ring(1, j), ring(1, j + 1));
    for (int i = 1; i < rings - 1; ++i)
        for (int j = 0; j < segments; ++j) {
            f.emplace_back(ring(i, j), ring(i + 1, j), ring(i + 1, j + 1));
            f.emplace_back(ring(i, j), ring(i + 1, j + 1), ring(i, j + 1));
        }
    for (int j = 0; j < segments; ++j) f.emplace_back(ring(rings - 1, j), south, ring(rings - 1, j + 1));
    Mesh m;
    m.vertices.resize(static_cast<Eigen::Index>(v.size()), 3);
    for (std::size_t i = 0; i < v.size(); ++i) m.vertices.row(static_cast<Eigen::Index>(i)) = v[i];
    m.faces.resize(static_cast<Eigen::Index>(f.size()), 3);
    for (std::size_t i = 0; i < f.size(); ++i) m.faces.row(static_cast<Eigen::Index>(i)) = f[i];
    return m;
}

/// A unit square in the z = 0 plane made of two triangles, normal +z.
inline Mesh unit_square() {
    Mesh m;
    m.vertices.resize(4, 3);
    m.vertices << 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0;
    m.faces.resize(2, 3);
    m.faces << 0, 1, 2, 0, 2, 3;
    return m;
}

/// The two meshes as one (b's faces re-indexed after a's vertices).
inline Mesh concat(const Mesh& a, const Mesh& b) {
    Mesh m;
    m.vertices.resize(a.vertices.rows() + b.vertices.rows(), 3);
    m.vertices << a.vertices, b.vertices;
    m.faces.resize(a.faces.rows() + b.faces.rows(), 3);
    m.faces << a.faces, (b.faces.array() + static_cast<std::int32_t>(a.vertices.rows())).matrix();
    return m;
}

}  // namespace pcp::test
