// Umbrella header: everything a user of libpcp needs.
#pragma once

#include "pcp/error.hpp"
#include "pcp/eval.hpp"
#include "pcp/files.hpp"
#include "pcp/io.hpp"
#include "pcp/kdtree.hpp"
#include "pcp/marching_cubes.hpp"
#include "pcp/normalize.hpp"
#include "pcp/regions.hpp"
#include "pcp/sampling.hpp"
#include "pcp/sdf_grid.hpp"
#include "pcp/shapes.hpp"
#include "pcp/prior.hpp"
#include "pcp/progress.hpp"
#include "pcp/reconstruct.hpp"
#include "pcp/types.hpp"
#include "pcp/version.hpp"
