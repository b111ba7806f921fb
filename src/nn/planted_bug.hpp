// Test-only switch, outside the public headers: the planted bug that the stage-1 gradient check
// must reject (STYLE.md habit 8). While a PlantedTangentDrop lives on a thread,
// nn::decoder_double_backward on that thread drops the tangent (u) terms of the double backprop.
// The library never sets it.
#pragma once

namespace pcp::nn::detail {

bool& tangent_dropped();  ///< this thread's switch (false unless a test sets it)

struct PlantedTangentDrop {
    PlantedTangentDrop() { tangent_dropped() = true; }
    ~PlantedTangentDrop() { tangent_dropped() = false; }
    PlantedTangentDrop(const PlantedTangentDrop&) = delete;
    PlantedTangentDrop& operator=(const PlantedTangentDrop&) = delete;
};

}  // namespace pcp::nn::detail
