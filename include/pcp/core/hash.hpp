// A byte hash for fingerprints and checksums (checkpoint files, prepared clouds, fit settings).
#pragma once

#include <cstddef>
#include <cstdint>

namespace pcp {

/// FNV-1a 64-bit hash of `size` bytes, continuing from `h`.
inline std::uint64_t fnv1a64(const void* data, std::size_t size, std::uint64_t h = 0xcbf29ce484222325ull) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < size; ++i) {
        h ^= p[i];
        h *= 0x100000001b3ull;
    }
    return h;
}

}  // namespace pcp
