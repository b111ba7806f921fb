// Shared by the libFuzzer targets (tests/fuzz/fuzz_*.cpp): the invariants every successful read
// must satisfy. A reader may refuse any input with pcp::Error; anything else (another exception, a
// crash, a sanitizer report, a result that breaks an invariant) is a finding.
#pragma once

#include "pcp/core/types.hpp"

#include <cstdio>
#include <cstdlib>

namespace pcp::fuzz {

[[noreturn]] inline void fail(const char* what) {
    std::fprintf(stderr, "fuzz invariant broken: %s\n", what);
    std::abort();
}

/// A cloud's points are finite, three columns, and every property has one value per point.
inline void check_cloud(const PointCloud& cloud) {
    if (cloud.points.cols() != 3) fail("points do not have 3 columns");
    if (cloud.points.rows() > 0 && !cloud.points.allFinite()) fail("a point is not finite");
    for (const auto& [name, values] : cloud.properties) {
        (void)name;
        if (values.size() != cloud.points.rows()) fail("a property's size differs from the point count");
    }
}

/// A mesh's vertices are three finite columns and every face refers to existing vertices.
inline void check_mesh(const Mesh& mesh) {
    if (mesh.vertices.cols() != 3 || mesh.faces.cols() != 3) fail("vertices or faces do not have 3 columns");
    if (mesh.vertices.rows() > 0 && !mesh.vertices.allFinite()) fail("a vertex is not finite");
    const auto nv = mesh.vertices.rows();
    for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f)
        for (int k = 0; k < 3; ++k)
            if (mesh.faces(f, k) < 0 || mesh.faces(f, k) >= nv) fail("a face refers to a missing vertex");
}

}  // namespace pcp::fuzz
