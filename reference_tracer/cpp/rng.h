// A PCG generator (O'Neill 2014): small, fast, with 2^63 selectable streams.
// Each pixel gets its own stream seeded from (render seed, pixel index), so an image is
// bit-identical whatever the thread count or tile order.
#pragma once

#include <cstdint>

namespace rt {

// SplitMix64 finaliser: decorrelates nearby seeds and pixel indices.
inline uint64_t mix64(uint64_t z) {
    z += 0x9E3779B97F4A7C15ull;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

// PCG with 64-bit state and 64-bit output (O'Neill 2014, the "RXS M XS" output function):
// one LCG step per double. PCG32 (XSH RR, 32-bit output) needs two steps per double for 53
// random bits, ~22 instructions a draw and 10-13% of a render's instructions
// (PERFORMANCE.md, Ideas tried). RXS M XS at full state width is a bijection of
// the state, so each 64-bit output occurs once per period (2^64 per stream), which is what
// the PCG paper calls "insecure" and a sampler does not care about; it passes TestU01's
// BigCrush in the paper's tests. Streams are selected by the LCG's increment.
class PCG64 {
public:
    PCG64(uint64_t seed, uint64_t stream) {
        inc_ = (stream << 1u) | 1u;
        state_ = 0;
        step();
        state_ += seed;
        step();
    }

    uint64_t next_u64() {
        const uint64_t old = state_;
        step();
        return output(old);
    }

    // The output function ("RXS M XS") of a state: a uint64_t, or lanes of them (code that
    // steps several generators at once, wavefront.cpp).
    template <typename U>
    static U output(U old) {
        const U word = ((old >> ((old >> 59u) + 5u)) ^ old) * 12605985483714917081ull;
        return (word >> 43u) ^ word;
    }
    // next_double()'s double of an output: a uint64_t, or lanes of them into the vector of
    // doubles D (the conversion is exact either way, the value below 2^53).
    static double to_double(uint64_t word) { return static_cast<double>(word >> 11) * 0x1.0p-53; }
    template <typename D, typename U>
    static D to_double(U words) { return __builtin_convertvector(words >> 11, D) * 0x1.0p-53; }

    // The state and the stream's increment, for code that steps several generators at once:
    // j steps take the state s to kMultiplier^j s + jump_increment(j) inc (mod 2^64).
    static constexpr uint64_t kMultiplier = 6364136223846793005ull;
    uint64_t state() const { return state_; }
    uint64_t increment() const { return inc_; }
    void set_state(uint64_t state) { state_ = state; }
    static constexpr uint64_t jump_multiplier(int j) { return j == 0 ? 1u : kMultiplier * jump_multiplier(j - 1); }
    static constexpr uint64_t jump_increment(int j) { return j == 0 ? 0u : jump_increment(j - 1) * kMultiplier + 1u; }

    // Uniform double in [0, 1) with 53 random bits (the output's top 53).
    // Always inline: a call per draw cost the wavefront integrator 7% of its instructions.
    [[gnu::always_inline]] double next_double() { return to_double(next_u64()); }

private:
    void step() { state_ = state_ * kMultiplier + inc_; }
    uint64_t state_ = 0, inc_ = 0;
};

// The random stream of one pixel.
inline PCG64 pixel_rng(uint64_t seed, uint64_t pixel_index) {
    return PCG64(mix64(seed ^ mix64(pixel_index)), mix64(pixel_index + 0x632BE59BD9B4E019ull * mix64(seed)));
}

}  // namespace rt
