// The prior file's reader below the file level, for the fuzz target of prior files
// (tests/fuzz/fuzz_prior.cpp): the settings and networks of a parsed network file.
#pragma once

#include "pcp/nn/checkpoint.hpp"
#include "pcp/train/prior.hpp"

#include <string>

namespace pcp::detail {

/// The prior held by `file` (read from `path`, which names it in errors); throws pcp::Error when
/// the settings are missing or malformed or the networks do not match them.
LocalPrior prior_from_net_file(const std::string& path, const nn::NetFile<float>& file);

}  // namespace pcp::detail
