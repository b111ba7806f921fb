// A small, fast, seedable random number generator with independent streams. Every random draw in
// libpcp comes from a stream derived from (seed, stream id) -- never from a thread id -- so results
// are the same whatever the thread count. xoshiro256** seeded through splitmix64; normal variates
// by the Box-Muller transform (written here so that results do not depend on the standard
// library's distribution implementations).
#pragma once

#include <cmath>
#include <cstdint>

namespace pcp {

/// splitmix64 step: a good 64-bit mixer, used to expand seeds.
inline std::uint64_t splitmix64(std::uint64_t& state) {
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

class Rng {
public:
    /// The stream `stream` of generator `seed`; distinct (seed, stream) pairs are independent.
    explicit Rng(std::uint64_t seed = 1, std::uint64_t stream = 0) {
        std::uint64_t sm = seed ^ (0xD1B54A32D192ED03ull * (stream + 1));
        for (auto& word : s_) word = splitmix64(sm);
    }

    /// Uniform 64-bit integer (xoshiro256**).
    std::uint64_t next_u64() {
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

    /// Uniform double in [0, 1).
    double uniform() { return static_cast<double>(next_u64() >> 11) * 0x1.0p-53; }

    /// Uniform integer in [0, n), n > 0 (modulo bias below 2^-32 for n < 2^32).
    std::uint64_t below(std::uint64_t n) { return next_u64() % n; }

    /// Standard normal variate (Box-Muller; the second value of each pair is kept for the next call).
    double normal() {
        if (has_spare_) {
            has_spare_ = false;
            return spare_;
        }
        double u1 = uniform();
        while (u1 <= 0.0) u1 = uniform();
        const double u2 = uniform();
        const double r = std::sqrt(-2.0 * std::log(u1));
        const double angle = 6.283185307179586476925 * u2;
        spare_ = r * std::sin(angle);
        has_spare_ = true;
        return r * std::cos(angle);
    }

    /// The full state, for checkpoints.
    struct State {
        std::uint64_t s[4];
        double spare;
        bool has_spare;
    };
    State state() const { return {{s_[0], s_[1], s_[2], s_[3]}, spare_, has_spare_}; }
    void set_state(const State& st) {
        for (int i = 0; i < 4; ++i) s_[i] = st.s[i];
        spare_ = st.spare;
        has_spare_ = st.has_spare;
    }

private:
    static std::uint64_t rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
    std::uint64_t s_[4];
    double spare_ = 0.0;
    bool has_spare_ = false;
};

}  // namespace pcp
