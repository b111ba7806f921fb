// libFuzzer target: the OBJ and OFF mesh readers (the same bytes through both).
// Seeds: tests/fuzz/corpus/mesh_text.
#include "fuzz_common.hpp"
#include "io/io_detail.hpp"
#include "pcp/core/error.hpp"

#include <cstddef>
#include <cstdint>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string bytes(reinterpret_cast<const char*>(data), size);
    try {
        pcp::fuzz::check_mesh(pcp::io_detail::read_obj("fuzz.obj", bytes));
    } catch (const pcp::Error&) {
    }
    try {
        pcp::fuzz::check_mesh(pcp::io_detail::read_off("fuzz.off", bytes));
    } catch (const pcp::Error&) {
    }
    return 0;
}
