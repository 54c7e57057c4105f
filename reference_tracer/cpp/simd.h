// Vector types of the core (GCC/Clang vector extensions): they compile to AVX2 / AVX-512
// registers where the build machine has them and to narrower ones (or scalar code)
// elsewhere, so no code path depends on an instruction set.
#pragma once

#include <cmath>
#include <cstdint>

#ifdef __AVX__
#include <immintrin.h>
#endif

namespace rt {

using V8f = float __attribute__((vector_size(32)));
using V8i = int32_t __attribute__((vector_size(32)));
using V4f = float __attribute__((vector_size(16)));
using V4i = int32_t __attribute__((vector_size(16)));
using V4d = double __attribute__((vector_size(32)));
// Lane masks of V4d comparisons (0 / -1): the comparison's own result type, whose element
// is `long` under GCC and `long long` under Clang (int64_t, a `long`, would make the two a
// distinct pair of types under Clang, and calls taking masks ambiguous).
using V4l = decltype(V4d{} < V4d{});

// Rays per pack of the batched scene queries (Scene::intersect_batch): eight doubles, one
// AVX-512 register, where the build machine has AVX-512; four (one AVX2 register, two
// SSE2 ones, or scalar code) elsewhere. RT_PACK_WIDTH overrides it (tests build 8 on AVX2).
// (512-bit vectors without AVX-512 are two 256-bit halves, 256-bit ones without AVX two SSE
// halves: CMakeLists.txt silences GCC's ABI notes about passing them.)
#if defined(RT_PACK_WIDTH)
#define RT_PACK RT_PACK_WIDTH
#elif defined(__AVX512F__)
#define RT_PACK 8
#else
#define RT_PACK 4
#endif

constexpr int kPackWidth = RT_PACK;
static_assert(kPackWidth == 4 || kPackWidth == 8, "RT_PACK_WIDTH must be 4 or 8");
// Packs of a batch that one step works on before it stores any of their results
// (Scene::intersect_batch, WavefrontIntegrator::next_events): their chains of divisions
// and square roots then overlap, where a pack's stores would keep the next pack out of
// reach of out-of-order execution. Four, for packs of eight and of four alike
// (PERFORMANCE.md, Ideas tried).
constexpr int kOverlapPacks = 4;

// Lanes of doubles by width, the lane type F of the core's routines written once for a
// scalar and a pack (pbrt-v4's and Dr.Jit's Float): double for one lane, V4d (one AVX2
// register) and V8d (one AVX-512 register; two AVX ones, or four SSE ones, elsewhere) for
// packs. A routine over F runs on any width; the helpers below (sqrt_of, mul_add,
// lane_mask, ...) have one overload per width, each lane doing what the double one does.
// A new width is a new DoubleLanes line and the helpers' overloads, never a new routine.
using V8d = double __attribute__((vector_size(64)));
using V8l = decltype(V8d{} < V8d{});
template <int N> struct DoubleLanes;
template <> struct DoubleLanes<1> { using type = double; };
template <> struct DoubleLanes<4> { using type = V4d; };
template <> struct DoubleLanes<8> { using type = V8d; };
template <int N> using Vd = typename DoubleLanes<N>::type;
// The widths the lane-width probes compile (bindings.cpp: LANE_WIDTHS): every width a
// build may use (one lane for the scalar integrator, kPackWidth for the wavefront one).
constexpr int kLaneWidths[] = {1, 4, 8};

// A comparison's result on lanes of type F: bool for double, a vector of 0 / -1 for packs.
template <typename F> using MaskOf = decltype(F{} < F{});
template <typename F> constexpr int kLanesOf = sizeof(F) / sizeof(double);

using VPd = Vd<kPackWidth>;
using VPl = MaskOf<VPd>;  // lane masks of VPd comparisons (0 / -1), as V4l

// kPackWidth rays in structure-of-arrays form: one lane per ray, so that a primitive's
// test runs on all of them with the same instructions.
struct RayPack {
    VPd ox, oy, oz, dx, dy, dz;
};

// Square root: std::sqrt for double, lane-wise (IEEE, as std::sqrt on each lane) for packs.
inline double sqrt_of(double x) { return __builtin_sqrt(x); }
inline V4d sqrt_of(V4d x) {
#if defined(__AVX__)
    return reinterpret_cast<V4d>(_mm256_sqrt_pd(reinterpret_cast<__m256d>(x)));
#else
    for (int i = 0; i < 4; ++i) x[i] = __builtin_sqrt(x[i]);
    return x;
#endif
}
inline V8d sqrt_of(V8d x) {
#if defined(__AVX512F__)
    return reinterpret_cast<V8d>(_mm512_sqrt_pd(reinterpret_cast<__m512d>(x)));
#else
    for (int i = 0; i < 8; ++i) x[i] = __builtin_sqrt(x[i]);
    return x;
#endif
}

// Lane-wise std::floor and safe_sqrt (math.h: the square root of max(0, x), NaN -> 0).
inline double floor_of(double x) { return __builtin_floor(x); }
inline V4d floor_of(V4d x) {
#if defined(__AVX__)
    return reinterpret_cast<V4d>(_mm256_floor_pd(reinterpret_cast<__m256d>(x)));
#else
    for (int i = 0; i < 4; ++i) x[i] = __builtin_floor(x[i]);
    return x;
#endif
}
inline V8d floor_of(V8d x) {
#if defined(__AVX512F__)
    // Round toward -inf, the precision exception suppressed (imm8 0x09): floor, exactly.
    return reinterpret_cast<V8d>(_mm512_roundscale_pd(reinterpret_cast<__m512d>(x), 0x09));
#else
    for (int i = 0; i < 8; ++i) x[i] = __builtin_floor(x[i]);
    return x;
#endif
}
template <typename F> inline F safe_sqrt_of(F x) { return sqrt_of(0.0 < x ? x : F{}); }

// 1 / x lane-wise within a relative error of 2^-14 (kReciprocalEstimateError), with its
// sign, and +-inf for +-0: AVX-512's estimate instruction for packs of eight, a division
// elsewhere. For tests that only need bounds (PackSlabs), where eight exact divisions cost
// as much as a primitive's test.
constexpr double kReciprocalEstimateError = 0x1.0p-14;
inline VPd reciprocal_estimate(VPd x) {
#if RT_PACK == 8 && defined(__AVX512F__)
    return reinterpret_cast<VPd>(_mm512_rcp14_pd(reinterpret_cast<__m512d>(x)));
#else
    return 1.0 / x;
#endif
}

// x in every lane of F (itself for double). F{} + x would add a zero first (IEEE has
// -0 + 0 = +0, so the compiler must); x - 0 is x for every x, so the subtraction folds away
// into a broadcast.
template <typename F> inline F broadcast(double x) { return x - F{}; }
template <> inline double broadcast<double>(double x) { return x; }
inline VPd splat(double x) { return broadcast<VPd>(x); }
inline V8f splat8(float x) { return x - V8f{}; }

// The pack of doubles at p[0..kPackWidth) (any alignment).
inline VPd load_pack(const double* p) {
    VPd v;
    __builtin_memcpy(&v, p, sizeof v);
    return v;
}

inline void store_pack(double* p, VPd v) { __builtin_memcpy(p, &v, sizeof v); }

// p[0..m) as a pack (m <= kPackWidth), absent lanes 0.
inline VPd load_partial(const double* p, int m) {
#if RT_PACK == 8 && defined(__AVX512F__)
    return reinterpret_cast<VPd>(_mm512_maskz_loadu_pd(static_cast<__mmask8>((1u << m) - 1u), p));
#else
    VPd v = {};
    for (int l = 0; l < m; ++l) v[l] = p[l];
    return v;
#endif
}

// The N consecutive doubles that get(obj) points to (a member of every object, at the same
// place), read from each of objs[0..m) (m <= kPackWidth) as packs out[0..N); absent lanes
// repeat objs[0]. On AVX-512 a gather a double at the objects' distances from objs[0]:
// packs written lane by lane go through the stack as narrow stores that their wide reloads
// wait for (store forwarding fails; PERFORMANCE.md, Ideas tried). Elsewhere one pass over the
// objects.
template <int N, typename T, typename Get>
inline void gather_members(const T* const* objs, int m, Get&& get, VPd (&out)[N]) {
#if RT_PACK == 8 && defined(__AVX512F__)
    const __m512i base = _mm512_set1_epi64(reinterpret_cast<long long>(objs[0]));
    const __m512i at = _mm512_sub_epi64(
        _mm512_mask_loadu_epi64(base, static_cast<__mmask8>((1u << m) - 1u), objs), base);
    const double* first = get(*objs[0]);
    for (int i = 0; i < N; ++i) out[i] = reinterpret_cast<VPd>(_mm512_i64gather_pd(at, first + i, 1));
#else
    for (int l = 0; l < kPackWidth; ++l) {
        const double* v = get(*objs[l < m ? l : 0]);
        for (int i = 0; i < N; ++i) out[i][l] = v[i];
    }
#endif
}

// v as the type of `like`: itself for double, in every lane for a pack (code written once
// for a scalar and a pack).
template <typename F> inline F as_lanes(double v, F) { return broadcast<F>(v); }

// Lane-wise mul_add (math.h): fused where the target has FMA, as the scalar one is.
inline V4d mul_add(V4d a, V4d b, V4d c) {
#if defined(__FMA__)
    return reinterpret_cast<V4d>(_mm256_fmadd_pd(reinterpret_cast<__m256d>(a), reinterpret_cast<__m256d>(b),
                                                  reinterpret_cast<__m256d>(c)));
#else
    return a * b + c;
#endif
}
inline V8d mul_add(V8d a, V8d b, V8d c) {
#if defined(__AVX512F__)
    return reinterpret_cast<V8d>(_mm512_fmadd_pd(reinterpret_cast<__m512d>(a), reinterpret_cast<__m512d>(b),
                                                  reinterpret_cast<__m512d>(c)));
#elif defined(__FMA__)
    for (int i = 0; i < 8; ++i) a[i] = __builtin_fma(a[i], b[i], c[i]);
    return a;
#else
    return a * b + c;
#endif
}

// Lane-wise std::isfinite: x - x is 0 for a finite x and NaN for an infinity or NaN.
inline bool finite_lanes(double x) { return std::isfinite(x); }
template <typename F>
inline MaskOf<F> finite_lanes(F x) {
    return (x - x) == 0.0;
}

// Lane-wise std::copysign(magnitude, sign).
inline double copysign_lanes(double magnitude, double sign) { return __builtin_copysign(magnitude, sign); }
template <typename F>
inline F copysign_lanes(F magnitude, F sign) {
    using Bits = MaskOf<F>;
    const Bits sign_bit = Bits{} + INT64_MIN;
    return reinterpret_cast<F>((reinterpret_cast<Bits>(magnitude) & ~sign_bit) |
                               (reinterpret_cast<Bits>(sign) & sign_bit));
}

// Bit i set where lane i of a comparison result (0 / all ones) is true, lane by lane: the
// portable form of the movemask instructions below.
template <typename Lanes>
inline unsigned lane_bits(const Lanes& lanes) {
    constexpr int kLanes = sizeof(Lanes) / sizeof(lanes[0]);
    unsigned mask = 0;
    for (int i = 0; i < kLanes; ++i) mask |= (lanes[i] != 0 ? 1u : 0u) << i;
    return mask;
}

// Bit 0 set where a double comparison is true: lane_mask of one lane.
inline unsigned lane_mask(bool lane) { return lane ? 1u : 0u; }
// Bit i set where lane i of a V4d comparison is true.
inline unsigned lane_mask(V4l lanes) {
#ifdef __AVX__
    return static_cast<unsigned>(_mm256_movemask_pd(reinterpret_cast<__m256d>(lanes)));
#else
    return lane_bits(lanes);
#endif
}
// The same for a pack of eight (one AVX-512 register, or two AVX ones). One instruction
// with AVX-512 (a comparison's mask register, read back): lane_bits' portable loop
// compiled to ~50 lane extractions there, as many as the quad test it follows
// (PERFORMANCE.md, Ideas tried).
inline unsigned lane_mask(V8l lanes) {
#if defined(__AVX512F__)
    const __m512i v = reinterpret_cast<__m512i>(lanes);
    return static_cast<unsigned>(_mm512_test_epi64_mask(v, v));
#elif defined(__AVX__)
    V4l low, high;
    __builtin_memcpy(&low, &lanes, sizeof low);
    __builtin_memcpy(&high, reinterpret_cast<const char*>(&lanes) + sizeof low, sizeof high);
    return lane_mask(low) | (lane_mask(high) << 4);
#else
    return lane_bits(lanes);
#endif
}

// Lane i true where bit i of `bits` is set: lane_mask's inverse, for selections by a mask
// of bits (one instruction with AVX-512), as a mask of lanes of type F.
template <typename F> inline MaskOf<F> lanes_of_bits(unsigned bits);
template <> inline bool lanes_of_bits<double>(unsigned bits) { return (bits & 1u) != 0; }
template <> inline V4l lanes_of_bits<V4d>(unsigned bits) {
    const V4l bit = {1, 2, 4, 8};
    return (bit & static_cast<int64_t>(bits)) != 0;
}
template <> inline V8l lanes_of_bits<V8d>(unsigned bits) {
#if defined(__AVX512F__)
    return reinterpret_cast<V8l>(_mm512_maskz_mov_epi64(static_cast<__mmask8>(bits), _mm512_set1_epi64(-1)));
#else
    const V8l bit = {1, 2, 4, 8, 16, 32, 64, 128};
    return (bit & static_cast<int64_t>(bits)) != 0;
#endif
}
inline VPl lanes_of_bits(unsigned bits) { return lanes_of_bits<VPd>(bits); }

// Lane l of a pack, or the double itself (l = 0): how a routine over F hands one lane back.
inline double lane_of(double v, int) { return v; }
template <typename F> inline double lane_of(const F& v, int l) { return v[l]; }
inline void set_lane(double& v, int, double x) { v = x; }
template <typename F> inline void set_lane(F& v, int l, double x) { v[l] = x; }

// Bit i set where lane i of a V8f comparison is true.
inline unsigned lane_mask(V8i lanes) {
#ifdef __AVX__
    return static_cast<unsigned>(_mm256_movemask_ps(reinterpret_cast<__m256>(lanes)));
#else
    return lane_bits(lanes);
#endif
}

// The smallest and the largest of eight floats (no NaN among them).
inline float min_lane(V8f v) {
#ifdef __AVX__
    __m256 x = reinterpret_cast<__m256>(v);
    x = _mm256_min_ps(x, _mm256_permute2f128_ps(x, x, 1));
    x = _mm256_min_ps(x, _mm256_shuffle_ps(x, x, 0x4E));
    x = _mm256_min_ps(x, _mm256_shuffle_ps(x, x, 0xB1));
    return _mm256_cvtss_f32(x);
#else
    float m = v[0];
    for (int i = 1; i < 8; ++i) m = v[i] < m ? v[i] : m;
    return m;
#endif
}
inline float max_lane(V8f v) { return -min_lane(-v); }

// Sixteen floats and their comparison masks: the lanes of a packet of sixteen rays
// (wide_bvh.h), one AVX-512 register, two AVX ones elsewhere.
using V16f = float __attribute__((vector_size(64)));
using V16i = int32_t __attribute__((vector_size(64)));

// Bit i set where lane i of a V16f comparison is true.
inline unsigned lane_mask(V16i lanes) {
#if defined(__AVX512F__)
    const __m512i v = reinterpret_cast<__m512i>(lanes);
    return static_cast<unsigned>(_mm512_test_epi32_mask(v, v));
#else
    V8i low, high;
    __builtin_memcpy(&low, &lanes, sizeof low);
    __builtin_memcpy(&high, reinterpret_cast<const char*>(&lanes) + sizeof low, sizeof high);
    return lane_mask(low) | (lane_mask(high) << 8);
#endif
}

// The smallest and the largest of sixteen floats (no NaN among them).
inline float min_lane(V16f v) {
    V8f low, high;
    __builtin_memcpy(&low, &v, sizeof low);
    __builtin_memcpy(&high, reinterpret_cast<const char*>(&v) + sizeof low, sizeof high);
    return min_lane(low < high ? low : high);
}
inline float max_lane(V16f v) { return -min_lane(-v); }

// The smallest of one double: itself.
inline double min_lane(double v) { return v; }
// The smallest of four doubles (no NaN among them).
inline double min_lane(V4d v) {
#ifdef __AVX__
    __m256d x = reinterpret_cast<__m256d>(v);
    x = _mm256_min_pd(x, _mm256_permute2f128_pd(x, x, 1));
    x = _mm256_min_pd(x, _mm256_shuffle_pd(x, x, 0x5));
    return _mm256_cvtsd_f64(x);
#else
    const double a = v[0] < v[1] ? v[0] : v[1], b = v[2] < v[3] ? v[2] : v[3];
    return a < b ? a : b;
#endif
}

}  // namespace rt
