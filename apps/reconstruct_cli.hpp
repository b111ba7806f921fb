// pcp_reconstruct's pieces other than its main: the options from the command line (the settings
// table of pcp/settings.hpp), the report of a run, and the memory check before one.
#pragma once

#include "cli_common.hpp"

#include "pcp/reconstruct.hpp"

#include <string>
#include <vector>

namespace pcp::cli {

/// A number for the report (%.6g).
std::string fmt(double v);

/// What the fit uses as its prior, for the parameter table.
std::string prior_description(const ReconstructOptions& o, const std::string& prior_path, bool several);

/// The stage table's name of the prior stage.
std::string prior_stage(const ReconstructOptions& o, const std::string& prior_path, const ReconstructReport& r);

/// What the field stage did (the winding sign, the visibility labels, the sign repair) and then
/// each pass that changed something, one line each.
void report_passes(const Log& log, const ReconstructReport& r);

/// Refused up front where a run cannot fit, rather than left to the OOM killer (see the .cpp).
void check_fit_memory(const std::string& what, double fitted, double total, const ReconstructOptions& o, const std::string& hint);

/// The command line with every setting that --help does not list, given as --NAME VALUE or
/// --NAME=VALUE, rewritten as --set NAME=VALUE.
std::vector<std::string> settings_as_set(int argc, char** argv);

/// The preset, then every setting given (listed options and --set), in the table's order; checked.
/// Throws UsageError naming the option.
ReconstructOptions options_from(const cxxopts::ParseResult& args);

/// --list-settings: every setting with its value in `o`, its range and its help.
void list_settings(const ReconstructOptions& o);

}  // namespace pcp::cli
