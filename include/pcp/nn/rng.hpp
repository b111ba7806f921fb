// The neural core uses libpcp's one generator (pcp/rng.hpp); this header keeps the nn:: names.
#pragma once

#include "pcp/core/rng.hpp"

namespace pcp::nn {

using Rng = pcp::Rng;
using pcp::splitmix64;

}  // namespace pcp::nn
