// Umbrella header: everything a user of libpcp needs, in the order of the data flow.
#pragma once

#include "pcp/core/error.hpp"
#include "pcp/core/files.hpp"
#include "pcp/core/progress.hpp"
#include "pcp/core/types.hpp"
#include "pcp/version.hpp"

#include "pcp/io/io.hpp"

#include "pcp/cloud/denoise.hpp"
#include "pcp/cloud/kdtree.hpp"
#include "pcp/cloud/normalize.hpp"
#include "pcp/cloud/prepared_cloud.hpp"
#include "pcp/cloud/regions.hpp"
#include "pcp/cloud/sampling.hpp"
#include "pcp/cloud/room.hpp"
#include "pcp/cloud/shapes.hpp"

#include "pcp/train/prior.hpp"
#include "pcp/train/query_fit.hpp"
#include "pcp/train/schedule.hpp"

#include "pcp/mesh/repair/cavity_fill.hpp"
#include "pcp/mesh/repair/fine_repair.hpp"
#include "pcp/mesh/repair/tunnel_fill.hpp"
#include "pcp/mesh/grid/marching_cubes.hpp"
#include "pcp/mesh/grid/mesh_check.hpp"
#include "pcp/mesh/grid/sdf_grid.hpp"
#include "pcp/mesh/sign/sign_repair.hpp"
#include "pcp/mesh/surface/smooth.hpp"
#include "pcp/mesh/surface/surface_fit.hpp"
#include "pcp/mesh/sign/winding_sign.hpp"

#include "pcp/reconstruct.hpp"
#include "pcp/settings.hpp"

#include "pcp/eval/diagnose.hpp"
#include "pcp/eval/eval.hpp"

#include "pcp/render/render.hpp"

#include "pcp/demo/demo2d.hpp"
