// The one random number generator of libpcp: xoshiro256** seeded through splitmix64, with streams
// derived from (seed, stream id) -- never from a thread id or the clock -- so that results are the
// same whatever the thread count. Normals by Box-Muller, one value per call, so the whole state is
// four 64-bit words (stored in network checkpoints). Written from the published algorithm
// descriptions (Blackman & Vigna; Steele et al.).
#pragma once

#include <array>
#include <cstdint>

namespace pcp {

class Rng {
public:
    using State = std::array<std::uint64_t, 4>;

    /// Stream `stream` of seed `seed`: different (seed, stream) pairs give independent-looking
    /// sequences; the same pair always gives the same sequence.
    explicit Rng(std::uint64_t seed = 0, std::uint64_t stream = 0);

    std::uint64_t next_u64();
    /// Uniform in [0, 1), 53 random bits.
    double uniform();
    /// Standard normal.
    double normal();
    double normal(double mean, double stddev) { return mean + stddev * normal(); }
    /// Uniform integer in [0, n), n >= 1 (unbiased).
    std::uint64_t below(std::uint64_t n);

    State state() const { return s_; }
    void set_state(const State& s);  ///< throws pcp::Error for the all-zero state

private:
    State s_;
};

/// One splitmix64 step (the mixing function used for seeding).
std::uint64_t splitmix64(std::uint64_t& x);

}  // namespace pcp
