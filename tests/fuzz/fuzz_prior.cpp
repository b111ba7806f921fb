// libFuzzer target: prior files (".pcpm": a network file whose metadata holds the prior's settings,
// read by `pcp_reconstruct --prior`). The checksum is recomputed as in fuzz_netfile.cpp.
// Seeds: tests/fuzz/corpus/prior.
#include "pcp/core/error.hpp"
#include "pcp/nn/checkpoint.hpp"
#include "train/prior_io.hpp"

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    std::string bytes(reinterpret_cast<const char*>(data), size);
    if (bytes.size() >= 16) {
        const std::uint64_t sum = pcp::nn::fnv1a64(bytes.data(), bytes.size() - 8);
        std::memcpy(&bytes[bytes.size() - 8], &sum, 8);
    }
    try {
        (void)pcp::detail::prior_from_net_file("fuzz.pcpm", pcp::nn::parse_net_file<float>("fuzz.pcpm", bytes));
    } catch (const pcp::Error&) {
    }
    return 0;
}
