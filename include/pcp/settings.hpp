// The settings of pcp::reconstruct that a user sets by name: one table (name, help, range, the
// value of any ReconstructOptions as text) and one validator, shared by the library, the command
// line (pcp_reconstruct --NAME VALUE or --set NAME=VALUE; --list-settings prints the table) and
// Python (pcp.reconstruct(..., settings={NAME: VALUE})). Defaults are the ReconstructOptions' own
// (ReconstructOptions{} is the "default" preset).
#pragma once

#include "pcp/reconstruct.hpp"

#include <functional>
#include <string>
#include <vector>

namespace pcp {

struct Setting {
    std::string name;    ///< as the command line spells it: "resolution", "winding-near"
    std::string group;   ///< "Prior", "Query network", "Sign", "Grid", "Surface", ...
    std::string help;    ///< one or two sentences
    std::string range;   ///< what the value may be: "[8, 2048]", "on | off", ...
    /// Listed as its own option by pcp_reconstruct --help (the others through --list-settings).
    bool listed = false;
    std::function<std::string(const ReconstructOptions&)> get;            ///< the current value as text
    std::function<void(ReconstructOptions&, const std::string&)> set;    ///< parse and store (no range check)
    std::function<bool(const ReconstructOptions&)> valid;                 ///< the value lies in `range`
};

/// Every setting, grouped, in the order the help lists them.
const std::vector<Setting>& reconstruct_settings();

/// The setting called `name`, or null.
const Setting* find_setting(const std::string& name);

/// Sets `name` to `value` (text, as on the command line) and checks it. Throws pcp::Error naming
/// the setting and the problem ("winding-near must be in [0, 100] (got '-3')"; "unknown setting").
void set_option(ReconstructOptions& options, const std::string& name, const std::string& value);

/// The one validator: every setting in its range, and the dependencies between options that the
/// table cannot see (max-points against the query spread's neighbours, the thin levels). Throws
/// pcp::Error naming the first setting out of range. pcp::reconstruct calls it first.
void check_options(const ReconstructOptions& options);

}  // namespace pcp
