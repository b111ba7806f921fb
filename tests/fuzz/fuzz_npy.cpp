// libFuzzer target: the .npy point reader. Seeds: tests/fuzz/corpus/npy.
#include "fuzz_common.hpp"
#include "io/io_detail.hpp"
#include "pcp/core/error.hpp"

#include <cstddef>
#include <cstdint>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string bytes(reinterpret_cast<const char*>(data), size);
    try {
        pcp::fuzz::check_cloud(pcp::io_detail::read_npy("fuzz.npy", bytes));
    } catch (const pcp::Error&) {
    }
    return 0;
}
