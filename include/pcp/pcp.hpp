// Umbrella header: everything a user of libpcp needs.
#pragma once

#include "pcp/core/error.hpp"
#include "pcp/eval/eval.hpp"
#include "pcp/core/files.hpp"
#include "pcp/io/io.hpp"
#include "pcp/cloud/kdtree.hpp"
#include "pcp/mesh/marching_cubes.hpp"
#include "pcp/cloud/normalize.hpp"
#include "pcp/cloud/regions.hpp"
#include "pcp/cloud/sampling.hpp"
#include "pcp/mesh/sdf_grid.hpp"
#include "pcp/cloud/shapes.hpp"
#include "pcp/train/prior.hpp"
#include "pcp/core/progress.hpp"
#include "pcp/reconstruct.hpp"
#include "pcp/core/types.hpp"
#include "pcp/version.hpp"
