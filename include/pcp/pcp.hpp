// Umbrella header: everything a user of libpcp needs.
#pragma once

#include "pcp/error.hpp"
#include "pcp/files.hpp"
#include "pcp/progress.hpp"
#include "pcp/types.hpp"
#include "pcp/version.hpp"
