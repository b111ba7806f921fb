// libFuzzer target: the text point readers (.xyz and .txt; .pts with its optional count line).
// Seeds: tests/fuzz/corpus/text.
#include "fuzz_common.hpp"
#include "io/io_detail.hpp"
#include "pcp/core/error.hpp"

#include <cstddef>
#include <cstdint>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string bytes(reinterpret_cast<const char*>(data), size);
    for (const bool pts : {false, true}) {
        try {
            pcp::fuzz::check_cloud(pcp::io_detail::read_xyz(pts ? "fuzz.pts" : "fuzz.xyz", bytes, pts));
        } catch (const pcp::Error&) {
        }
    }
    return 0;
}
