// PCG32 (O'Neill 2014): a small, fast generator with 2^63 selectable streams.
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

class PCG32 {
public:
    PCG32(uint64_t seed, uint64_t stream) {
        inc_ = (stream << 1u) | 1u;
        state_ = 0;
        next_u32();
        state_ += seed;
        next_u32();
    }

    uint32_t next_u32() {
        const uint64_t old = state_;
        state_ = old * 6364136223846793005ull + inc_;
        const uint32_t xorshifted = static_cast<uint32_t>(((old >> 18u) ^ old) >> 27u);
        const uint32_t rot = static_cast<uint32_t>(old >> 59u);
        return (xorshifted >> rot) | (xorshift_left(xorshifted, rot));
    }

    // Uniform double in [0, 1) with 53 random bits (two draws).
    // Always inline: a call per draw cost the wavefront integrator 7% of its instructions.
    [[gnu::always_inline]] double next_double() {
        const uint64_t hi = next_u32(), lo = next_u32();
        return static_cast<double>(((hi << 32) | lo) >> 11) * 0x1.0p-53;
    }

private:
    static uint32_t xorshift_left(uint32_t x, uint32_t rot) { return x << ((32u - rot) & 31u); }
    uint64_t state_ = 0, inc_ = 0;
};

// The random stream of one pixel.
inline PCG32 pixel_rng(uint64_t seed, uint64_t pixel_index) {
    return PCG32(mix64(seed ^ mix64(pixel_index)), mix64(pixel_index + 0x632BE59BD9B4E019ull * mix64(seed)));
}

}  // namespace rt
