// Progress reporting from long-running library calls. The library never prints: it calls the
// ProgressCallback in its options, and the apps decide what the terminal shows. Returning false
// from the callback asks the running stage to stop cleanly at the next step.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

namespace pcp {

struct Progress {
    std::string stage;          ///< "sampling", "prior", "query-net", "sdf-grid", "meshing", ...
    std::int64_t step = 0;      ///< steps done in this stage
    std::int64_t total = 0;     ///< steps planned in this stage (0 if unknown)
    double loss = 0.0;          ///< latest loss, if the stage has one (has_loss)
    bool has_loss = false;      ///< the stage trains something and `loss` is its recent mean
    double elapsed_s = 0.0;     ///< wall seconds since the stage started (in this run)
    std::int64_t step_offset = 0;  ///< steps already done when this run started (resumed runs)
};

/// Called every so often by long-running calls; return false to cancel.
using ProgressCallback = std::function<bool(const Progress&)>;

}  // namespace pcp
