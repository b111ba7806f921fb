// Bilateral normal filtering of a mesh (see include/pcp/mesh/surface/smooth.hpp).
#include "pcp/mesh/surface/smooth.hpp"

#include "pcp/core/error.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

namespace pcp {

namespace {

/// Compressed rows: for each vertex the faces that use it.
void vertex_faces(const Mesh& mesh, std::vector<std::int64_t>& start, std::vector<std::int32_t>& faces) {
    const Eigen::Index nv = mesh.vertices.rows();
    start.assign(static_cast<std::size_t>(nv) + 1, 0);
    for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f)
        for (int c = 0; c < 3; ++c) ++start[static_cast<std::size_t>(mesh.faces(f, c)) + 1];
    for (Eigen::Index v = 0; v < nv; ++v) start[static_cast<std::size_t>(v) + 1] += start[static_cast<std::size_t>(v)];
    faces.resize(static_cast<std::size_t>(start.back()));
    std::vector<std::int64_t> fill(start.begin(), start.end() - 1);
    for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f)
        for (int c = 0; c < 3; ++c) faces[static_cast<std::size_t>(fill[static_cast<std::size_t>(mesh.faces(f, c))]++)] = static_cast<std::int32_t>(f);
}

}  // namespace

Mesh bilateral_smooth(const Mesh& mesh, const BilateralOptions& o) {
    PCP_CHECK(o.normal_iterations >= 0 && o.vertex_iterations >= 0, "bilateral smoothing: iterations must be >= 0");
    PCP_CHECK(o.sigma_r > 0 && o.spatial > 0, "bilateral smoothing: sigma_r and spatial must be > 0");
    const Eigen::Index nv = mesh.vertices.rows(), nf = mesh.faces.rows();
    for (Eigen::Index f = 0; f < nf; ++f)
        for (int c = 0; c < 3; ++c)
            PCP_CHECK(mesh.faces(f, c) >= 0 && mesh.faces(f, c) < nv,
                      "bilateral smoothing: face " << f << " has vertex index " << mesh.faces(f, c) << " out of range");
    Mesh out = mesh;
    if (nf == 0 || (o.normal_iterations == 0 && o.vertex_iterations == 0)) return out;
    std::vector<std::int64_t> vstart;
    std::vector<std::int32_t> vfaces;
    vertex_faces(mesh, vstart, vfaces);
    // Face neighbourhoods: the faces sharing a vertex with f (f included), each once.
    std::vector<std::int64_t> fstart(static_cast<std::size_t>(nf) + 1, 0);
    std::vector<std::int32_t> fnbr;
    {
        std::vector<std::vector<std::int32_t>> lists(static_cast<std::size_t>(nf));
#pragma omp parallel for schedule(static)
        for (Eigen::Index f = 0; f < nf; ++f) {
            std::vector<std::int32_t>& l = lists[static_cast<std::size_t>(f)];
            for (int c = 0; c < 3; ++c) {
                const auto v = static_cast<std::size_t>(mesh.faces(f, c));
                l.insert(l.end(), vfaces.begin() + vstart[v], vfaces.begin() + vstart[v + 1]);
            }
            std::sort(l.begin(), l.end());
            l.erase(std::unique(l.begin(), l.end()), l.end());
        }
        for (Eigen::Index f = 0; f < nf; ++f) fstart[static_cast<std::size_t>(f) + 1] = fstart[static_cast<std::size_t>(f)] + static_cast<std::int64_t>(lists[static_cast<std::size_t>(f)].size());
        fnbr.reserve(static_cast<std::size_t>(fstart.back()));
        for (const auto& l : lists) fnbr.insert(fnbr.end(), l.begin(), l.end());
    }
    Points normals(nf, 3), centres(nf, 3);
    Eigen::VectorXd areas(nf);
    auto face_geometry = [&]() {
#pragma omp parallel for schedule(static)
        for (Eigen::Index f = 0; f < nf; ++f) {
            const Eigen::RowVector3d a = out.vertices.row(mesh.faces(f, 0)), b = out.vertices.row(mesh.faces(f, 1)),
                                     c = out.vertices.row(mesh.faces(f, 2));
            const Eigen::RowVector3d cr = (b - a).cross(c - a);
            const double len = cr.norm();
            areas(f) = 0.5 * len;
            normals.row(f) = len > 0 ? Eigen::RowVector3d(cr / len) : Eigen::RowVector3d::Zero();
            centres.row(f) = (a + b + c) / 3.0;
        }
    };
    face_geometry();
    double mean_d = 0;
    std::int64_t count = 0;
    for (Eigen::Index f = 0; f < nf; ++f)
        for (std::int64_t i = fstart[static_cast<std::size_t>(f)]; i < fstart[static_cast<std::size_t>(f) + 1]; ++i)
            if (fnbr[static_cast<std::size_t>(i)] != f) {
                mean_d += (centres.row(f) - centres.row(fnbr[static_cast<std::size_t>(i)])).norm();
                ++count;
            }
    const double sigma_s = o.spatial * (count > 0 ? mean_d / double(count) : 1.0);
    const double inv_s = 1.0 / (2.0 * sigma_s * sigma_s), inv_r = 1.0 / (2.0 * o.sigma_r * o.sigma_r);
    Points filtered = normals;
    for (int it = 0; it < o.normal_iterations; ++it) {
#pragma omp parallel for schedule(static)
        for (Eigen::Index f = 0; f < nf; ++f) {
            Eigen::RowVector3d sum = Eigen::RowVector3d::Zero();
            for (std::int64_t i = fstart[static_cast<std::size_t>(f)]; i < fstart[static_cast<std::size_t>(f) + 1]; ++i) {
                const std::int32_t g = fnbr[static_cast<std::size_t>(i)];
                const double ds = (centres.row(f) - centres.row(g)).squaredNorm();
                const double dr = (normals.row(f) - normals.row(g)).squaredNorm();
                sum += areas(g) * std::exp(-ds * inv_s - dr * inv_r) * normals.row(g);
            }
            const double len = sum.norm();
            filtered.row(f) = len > 0 ? Eigen::RowVector3d(sum / len) : normals.row(f);
        }
        normals.swap(filtered);
    }
    // Vertices onto the planes of their faces (Sun et al.): x += mean over faces of n (n . (c - x)).
    Points next(nv, 3);
    for (int it = 0; it < o.vertex_iterations; ++it) {
#pragma omp parallel for schedule(static)
        for (Eigen::Index v = 0; v < nv; ++v) {
            const std::int64_t b = vstart[static_cast<std::size_t>(v)], e = vstart[static_cast<std::size_t>(v) + 1];
            Eigen::RowVector3d move = Eigen::RowVector3d::Zero();
            for (std::int64_t i = b; i < e; ++i) {
                const std::int32_t f = vfaces[static_cast<std::size_t>(i)];
                move += normals.row(f) * normals.row(f).dot(centres.row(f) - out.vertices.row(v));
            }
            next.row(v) = out.vertices.row(v) + (e > b ? Eigen::RowVector3d(move / double(e - b)) : Eigen::RowVector3d::Zero());
        }
        out.vertices.swap(next);
        // New centroids; the filtered normals stay.
#pragma omp parallel for schedule(static)
        for (Eigen::Index f = 0; f < nf; ++f)
            centres.row(f) = (out.vertices.row(mesh.faces(f, 0)) + out.vertices.row(mesh.faces(f, 1)) + out.vertices.row(mesh.faces(f, 2))) / 3.0;
    }
    return out;
}

}  // namespace pcp
