// The evaluation frame and the mesh checks shared by evaluate() (eval.cpp) and diagnose()
// (diagnose.cpp), so that both report distances in the same units. Private to src/eval/.
#pragma once

#include "pcp/cloud/normalize.hpp"
#include "pcp/core/types.hpp"
#include "pcp/eval/eval.hpp"

namespace pcp::detail {

/// The evaluation frame of `protocol`: for P2S / ShapeNet, the GT's bbox centre goes to the origin
/// and its longest edge to 1 (`gt_points` N x 3: GT vertices or GT points); for Scene, identity.
Normalization eval_frame(const Points& gt_points, EvalProtocol protocol);

/// `mesh` with its vertices mapped into `frame` (faces unchanged).
Mesh to_frame(const Mesh& mesh, const Normalization& frame);

/// Throws pcp::Error naming `which` ("predicted", "ground-truth", ...) if `mesh` is empty, has
/// non-finite vertices or face indices out of range.
void check_mesh(const Mesh& mesh, const char* which);

}  // namespace pcp::detail
