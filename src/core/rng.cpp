// xoshiro256** with splitmix64 seeding, and Box-Muller normals (see pcp/rng.hpp). Written from
// the published algorithm descriptions (Blackman & Vigna; Steele et al.).
#include "pcp/core/rng.hpp"

#include "pcp/core/error.hpp"

#include <cmath>

namespace pcp {

std::uint64_t splitmix64(std::uint64_t& x) {
    x += 0x9E3779B97F4A7C15ull;
    std::uint64_t z = x;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

namespace {
inline std::uint64_t rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
}  // namespace

Rng::Rng(std::uint64_t seed, std::uint64_t stream) {
    // Mix seed and stream separately, then combine, so (seed, stream) and (stream, seed) differ.
    std::uint64_t a = seed;
    std::uint64_t b = stream ^ 0xD1B54A32D192ED03ull;
    std::uint64_t x = splitmix64(a) ^ rotl(splitmix64(b), 17);
    for (auto& w : s_) w = splitmix64(x);
    if ((s_[0] | s_[1] | s_[2] | s_[3]) == 0) s_[0] = 1;  // the one forbidden state
}

void Rng::set_state(const State& s) {
    PCP_CHECK((s[0] | s[1] | s[2] | s[3]) != 0, "Rng: the all-zero state is invalid");
    s_ = s;
}

std::uint64_t Rng::next_u64() {
    const std::uint64_t result = rotl(s_[1] * 5, 7) * 9;
    const std::uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0];
    s_[3] ^= s_[1];
    s_[1] ^= s_[2];
    s_[0] ^= s_[3];
    s_[2] ^= t;
    s_[3] = rotl(s_[3], 45);
    return result;
}

double Rng::uniform() { return double(next_u64() >> 11) * 0x1.0p-53; }

double Rng::normal() {
    const double u1 = 1.0 - uniform();  // (0, 1]: log is finite
    const double u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(6.283185307179586476925 * u2);
}

std::uint64_t Rng::below(std::uint64_t n) {
    PCP_CHECK(n >= 1, "Rng::below: n must be >= 1");
    // Rejection sampling for an unbiased result.
    const std::uint64_t limit = ~std::uint64_t(0) - (~std::uint64_t(0) % n);
    std::uint64_t x;
    do x = next_u64();
    while (x >= limit);
    return x % n;
}

}  // namespace pcp
