// Vector types of the core (GCC/Clang vector extensions): they compile to AVX2 / AVX-512
// registers where the build machine has them and to narrower ones (or scalar code)
// elsewhere, so no code path depends on an instruction set.
#pragma once

#include <cstdint>

#ifdef __AVX__
#include <immintrin.h>
#endif

namespace rt {

using V8f = float __attribute__((vector_size(32)));
using V8i = int32_t __attribute__((vector_size(32)));
using V4f = float __attribute__((vector_size(16)));
using V4d = double __attribute__((vector_size(32)));
using V4l = int64_t __attribute__((vector_size(32)));  // lane masks of V4d comparisons (0 / -1)

// Four rays in structure-of-arrays form: one lane per ray, so that a primitive's test
// runs on all four with the same instructions.
struct RayPack4 {
    V4d ox, oy, oz, dx, dy, dz;
};

// Lane-wise square root (IEEE, as std::sqrt on each lane).
inline V4d sqrt4(V4d x) {
#ifdef __AVX__
    return reinterpret_cast<V4d>(_mm256_sqrt_pd(reinterpret_cast<__m256d>(x)));
#else
    for (int i = 0; i < 4; ++i) x[i] = __builtin_sqrt(x[i]);
    return x;
#endif
}

// Lane-wise std::copysign(magnitude, sign).
inline V4d copysign4(V4d magnitude, V4d sign) {
    const V4l sign_bit = V4l{} + INT64_MIN;
    return reinterpret_cast<V4d>((reinterpret_cast<V4l>(magnitude) & ~sign_bit) |
                                 (reinterpret_cast<V4l>(sign) & sign_bit));
}

// Bit i set where lane i of a V4d comparison is true.
inline unsigned lane_mask4(V4l lanes) {
#ifdef __AVX__
    return static_cast<unsigned>(_mm256_movemask_pd(reinterpret_cast<__m256d>(lanes)));
#else
    unsigned mask = 0;
    for (int i = 0; i < 4; ++i) mask |= (lanes[i] != 0 ? 1u : 0u) << i;
    return mask;
#endif
}

}  // namespace rt
