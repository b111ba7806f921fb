// libFuzzer target: the PLY reader (ascii and binary, both endiannesses), as a point cloud and as
// a mesh. Seeds: tests/fuzz/corpus/ply.
#include "fuzz_common.hpp"
#include "io/io_detail.hpp"
#include "pcp/core/error.hpp"

#include <cstddef>
#include <cstdint>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string bytes(reinterpret_cast<const char*>(data), size);
    try {
        pcp::fuzz::check_cloud(pcp::io_detail::read_ply_point_cloud("fuzz.ply", bytes));
    } catch (const pcp::Error&) {
    }
    try {
        pcp::fuzz::check_mesh(pcp::io_detail::read_ply_mesh("fuzz.ply", bytes));
    } catch (const pcp::Error&) {
    }
    return 0;
}
