// libFuzzer target: network files (priors' and checkpoints' container, nn/checkpoint.hpp), read as
// float and as double, then every record turned into its network and the metadata parsed, as
// --resume and --prior do. The checksum (the last 8 bytes) is recomputed before parsing, so the
// fuzzer reaches the parser behind it; the checksum check itself is covered by the unit tests.
// Seeds: tests/fuzz/corpus/netfile.
#include "pcp/core/error.hpp"
#include "pcp/nn/checkpoint.hpp"
#include "pcp/nn/metadata.hpp"

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>

namespace {

template <class S>
void parse(const std::string& bytes) {
    try {
        const pcp::nn::NetFile<S> file = pcp::nn::parse_net_file<S>("fuzz.pcpn", bytes);
        const pcp::nn::Metadata meta(file.metadata, "fuzz.pcpn: the checkpoint");
        (void)meta.has("fingerprint");
        for (const pcp::nn::NetRecord<S>& rec : file.nets) {
            try {
                if (rec.kind == pcp::nn::NetKind::BranchMlp) (void)pcp::nn::to_branch_mlp(rec);
                else (void)pcp::nn::to_pointnet(rec);
            } catch (const pcp::Error&) {
            }
        }
    } catch (const pcp::Error&) {
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    std::string bytes(reinterpret_cast<const char*>(data), size);
    if (bytes.size() >= 16) {
        const std::uint64_t sum = pcp::nn::fnv1a64(bytes.data(), bytes.size() - 8);
        std::memcpy(&bytes[bytes.size() - 8], &sum, 8);
    }
    parse<float>(bytes);
    parse<double>(bytes);
    return 0;
}
