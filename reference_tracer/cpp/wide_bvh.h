// An 8-wide BVH collapsed from the binary SAH tree (the wide nodes chosen to minimise the
// summed areas of the nodes a ray visits; wide_bvh.cpp): each node holds the boxes of up to
// eight children as float, rounded outward (boxes only grow), in structure-of-arrays
// form, so that one node visit tests eight boxes with 8-lane single-precision vector
// instructions. Twice the fan-out of a 4-wide tree halves the levels a ray descends,
// and on large meshes each level is a cache miss: the latency chain is what the width
// shortens. Single precision stays conservative (never a missed box) by rounding the
// ray's origin towards the near and far planes and widening the far distances by more
// than the arithmetic's relative error; see RaySlabs.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <initializer_list>
#include <limits>
#include <vector>

#ifdef __AVX__
#include <immintrin.h>
#endif

#include "bvh.h"
#include "simd.h"

namespace rt {

constexpr int kWidth = 8;

// Lane i all ones where bit i of mask is set.
inline V8i mask_lanes(unsigned mask) {
    const V8i bits = {1, 2, 4, 8, 16, 32, 64, 128};
    return (bits & static_cast<int32_t>(mask)) != 0;
}

// Rays per packet of coherent rays (WideBVH::traverse_packet): sixteen where the build
// targets AVX-512, so that a node's child is tested against sixteen camera rays with one
// vector instruction a step, and the node fetch, the ordering of the hit children and the
// stack serve sixteen rays (against eight, paired, 1 thread, camera rays: 1.05-1.10x at
// 100k triangles, 0.99-1.04x at 1M; PERFORMANCE.md, Ideas tried). Eight elsewhere: GCC
// compiles the 16-lane code for AVX2 into slow sequences (2.5x slower queries).
// RT_PACKET_RAYS overrides it.
#if defined(RT_PACKET_RAYS)
#define RT_PACKET RT_PACKET_RAYS
#elif defined(__AVX512F__)
#define RT_PACKET 16
#else
#define RT_PACKET 8
#endif
constexpr int kPacketRays = RT_PACKET;
static_assert(kPacketRays == 8 || kPacketRays == 16, "RT_PACKET_RAYS must be 8 or 16");
// A packet's lanes, one per ray, and their comparison masks.
using VRf = float __attribute__((vector_size(4 * kPacketRays)));
using VRi = int32_t __attribute__((vector_size(4 * kPacketRays)));
constexpr unsigned kAllPacketRays = (1u << kPacketRays) - 1u;

inline VRf splat_rays(float x) { return x - VRf{}; }
// Lane r all ones where bit r of mask is set.
inline VRi packet_lanes(unsigned mask) {
#if RT_PACKET == 8
    return mask_lanes(mask);
#else
    const VRi bits = {1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1024, 2048, 4096, 8192, 16384, 32768};
    return (bits & static_cast<int32_t>(mask)) != 0;
#endif
}

struct alignas(64) WideNode {
    float lo[3][kWidth];
    float hi[3][kWidth];
    int32_t child[kWidth];   // >= 0: interior node; < 0: leaf (see count)
    uint16_t count[kWidth];  // leaf: primitives, | kBlockLeaf for a packed block; 0: interior or empty
};

// A leaf child whose primitives the scene packs into one block tested at once (four
// triangles in SoA form): ~child is the block index, not an index into order().
constexpr uint16_t kBlockLeaf = 0x8000;

// Float bounds of a double value: the nearest float at or below / at or above it.
inline float round_down_float(double x) {
    const float f = static_cast<float>(x);
    return static_cast<double>(f) > x ? std::nextafter(f, -std::numeric_limits<float>::infinity()) : f;
}
inline float round_up_float(double x) {
    const float f = static_cast<float>(x);
    return static_cast<double>(f) < x ? std::nextafter(f, std::numeric_limits<float>::infinity()) : f;
}

// Per-ray constants of the conservative single-precision slab test, and the test of
// the eight child boxes of a node.
//
// Why the float test never misses a box the ray touches: the near distance
// (plane - o) * inv is computed with o rounded (as a float) towards the near plane's
// side and the far distance with o rounded away from it, so the exact distances from
// the rounded origins bound the true ones from below and above. The subtraction, the
// product and the rounding of 1/d to float each add at most u = 2^-24 relative error
// (3u in all, sign preserved), so scaling the far distances by 1 + 2^-20
// (> (1 + 3u) / (1 - 3u), even after its own rounding) keeps computed near <= computed
// far whenever the exact ones are ordered (pbrt-v4 widens by 1 + 2 gamma_3 for the same
// reason). t_max is rounded up likewise (max_float).
struct RaySlabs {
    static constexpr float kWiden = 1.0f + 0x1p-20f;
    static constexpr double kWidenD = 1.0 + 0x1p-20;

    // Four slab constants computed at once, without a branch: the three axes of one ray
    // (Scalars), or one axis of four rays (PacketSlabs). The reciprocals with one vector
    // division; the origin rounded up and down to float with a slack of 2^-23 |o| (plus
    // 2^-140 for zero and subnormals), more than the half ulp that rounding to nearest can
    // move, and no libm call (nextafter per axis cost ~20% on small scenes). The choices
    // by sign are lane selections: as branches on the signs of a random direction they
    // would be a mispredicted branch per ray. Lane for lane the same operations
    // whichever way the four values are grouped, so both groupings give the same bits.
    struct Lanes {
        V4f o_near, o_far, inv_near, inv_far;
        V4i neg;  // all ones where 1/d < 0: the near plane is hi, the far plane lo

        [[gnu::always_inline]] Lanes(const V4d& o4, const V4d& d4) {
            const V4d inv_d = V4d{1.0, 1.0, 1.0, 1.0} / d4;
            const V4d slack = (o4 < 0.0 ? -o4 : o4) * 0x1p-23 + 0x1p-140;
            const V4f o_up = __builtin_convertvector(o4 + slack, V4f);
            const V4f o_down = __builtin_convertvector(o4 - slack, V4f);
            // d = -0 gives -inf: negative, as it should.
            neg = __builtin_convertvector(inv_d < 0.0, V4i);
            // The near plane is lo (d > 0) or hi (d < 0): (plane - o) * inv is smallest
            // with o rounded up for d > 0 and down for d < 0; the far plane the other way.
            o_near = neg ? o_down : o_up;
            o_far = neg ? o_up : o_down;
            // 1/d beyond the float range (|d| < 2.9e-39, or d = 0): the near factor is
            // clamped to the largest float (a smaller near distance: conservative), the far
            // one may become infinite (a larger far distance: conservative too). A clamp
            // that keeps NaN, as std::clamp does.
            constexpr double kMaxFloat = std::numeric_limits<float>::max();
            V4d clamped = inv_d < -kMaxFloat ? V4d{} - kMaxFloat : inv_d;
            clamped = kMaxFloat < clamped ? V4d{} + kMaxFloat : clamped;
            inv_near = __builtin_convertvector(clamped, V4f);
            inv_far = __builtin_convertvector(inv_d, V4f) * kWiden;
        }
    };

    // The per-ray scalars, one per axis (lane 3 unused): what a single-ray traversal
    // broadcasts to the eight lanes of its node tests.
    struct Scalars {
        float o_near[4], o_far[4], inv_near[4], inv_far[4];
        int near_row[4], far_row[4];

        Scalars() = default;
        // Always inline: with a traversal per query kind (closest hit, shadow ray, the
        // wavefront's mesh tree) GCC left it out of line, 8% of all instructions.
        [[gnu::always_inline]] explicit Scalars(const Ray& ray) {
            const Lanes l(V4d{ray.o.x, ray.o.y, ray.o.z, 0.0}, V4d{ray.d.x, ray.d.y, ray.d.z, 1.0});
            const V4i axis_row = {0, kWidth, 2 * kWidth, 0};
            const V4i near_r = (l.neg & (3 * kWidth)) + axis_row;
            const V4i far_r = (~l.neg & (3 * kWidth)) + axis_row;
            __builtin_memcpy(o_near, &l.o_near, sizeof(l.o_near));
            __builtin_memcpy(o_far, &l.o_far, sizeof(l.o_far));
            __builtin_memcpy(inv_near, &l.inv_near, sizeof(l.inv_near));
            __builtin_memcpy(inv_far, &l.inv_far, sizeof(l.inv_far));
            __builtin_memcpy(near_row, &near_r, sizeof(near_r));
            __builtin_memcpy(far_row, &far_r, sizeof(far_r));
        }
    };

    V8f o_near[3], o_far[3], inv_near[3], inv_far[3];
    // Offsets (in floats) of the near and far rows of axis a inside a WideNode: chosen
    // once per ray rather than per node.
    int near_row[3], far_row[3];

    RaySlabs() = default;
    [[gnu::always_inline]] explicit RaySlabs(const Ray& ray) : RaySlabs(Scalars(ray)) {}
    [[gnu::always_inline]] explicit RaySlabs(const Scalars& s) {
        for (int a = 0; a < 3; ++a) {
            o_near[a] = splat8(s.o_near[a]);
            o_far[a] = splat8(s.o_far[a]);
            inv_near[a] = splat8(s.inv_near[a]);
            inv_far[a] = splat8(s.inv_far[a]);
            near_row[a] = s.near_row[a];
            far_row[a] = s.far_row[a];
        }
    }

    // A float never below t_max.
    static float max_float(double t_max) { return static_cast<float>(t_max * kWidenD); }

    // Eight slab tests at once (GCC/Clang vector extensions: one AVX instruction per
    // operation with -march=native, pairs of SSE operations otherwise). Returns the
    // mask of children whose box the ray meets within [0, t_max_f]; `tn` receives the
    // entry distances. Empty slots hold inverted boxes (lo = +inf, hi = -inf) and never
    // pass.
    unsigned test(const WideNode& n, float t_max_f, V8f& tn) const { return lane_mask(test_lanes(n, t_max_f, tn)); }
    // The same as lanes: all ones for a child met.
    V8i test_lanes(const WideNode& n, float t_max_f, V8f& tn) const {
        const float* rows = &n.lo[0][0];
        tn = V8f{};
        V8f tf = splat8(t_max_f);
        for (int a = 0; a < 3; ++a) {
            V8f near_plane, far_plane;
            __builtin_memcpy(&near_plane, rows + near_row[a], sizeof(V8f));
            __builtin_memcpy(&far_plane, rows + far_row[a], sizeof(V8f));
            const V8f t0 = (near_plane - o_near[a]) * inv_near[a];
            const V8f t1 = (far_plane - o_far[a]) * inv_far[a];
            // NaN (origin on a slab plane of a parallel ray) keeps the bound:
            // conservative (the primitive test decides), never a missed hit.
            tn = t0 > tn ? t0 : tn;
            tf = t1 < tf ? t1 : tf;
        }
        return tn <= tf;
    }
};

// kPacketRays rays in structure-of-arrays form, four to a vector: o[axis][q] holds the
// origins' `axis` components of rays 4 q .. 4 q + 3. What a packet's set-up reads: the
// coherence test, the slab and the watertight constants, each a few vector operations
// over all its rays.
struct RayPacket {
    static constexpr int kQuads = kPacketRays / 4;
    V4d o[3][kQuads], d[3][kQuads];

    RayPacket() = default;
    [[gnu::always_inline]] explicit RayPacket(const Ray (&rays)[kPacketRays]) {
        for (int a = 0; a < 3; ++a)
            for (int q = 0; q < kQuads; ++q) {
                const Ray* r = rays + 4 * q;
                o[a][q] = V4d{r[0].o[a], r[1].o[a], r[2].o[a], r[3].o[a]};
                d[a][q] = V4d{r[0].d[a], r[1].d[a], r[2].d[a], r[3].d[a]};
            }
    }
};

// The slab constants of a packet, lane r for ray r, computed four rays at a time
// (RaySlabs::Lanes on one axis of four rays) straight into the vectors the packet
// traversal tests: per ray, a RaySlabs::Scalars and its transposition into the lanes
// cost ~70 instructions a camera ray. Each lane holds the very bits
// Scalars(rays[r]) holds. The rays share an octant, so ray 0's signs choose the rows.
struct PacketSlabs {
    VRf o_near[3], o_far[3], inv_near[3], inv_far[3];
    int near_row[3], far_row[3];

    [[gnu::always_inline]] explicit PacketSlabs(const RayPacket& rays) {
        for (int a = 0; a < 3; ++a) {
            const RaySlabs::Lanes l0(rays.o[a][0], rays.d[a][0]);
            const RaySlabs::Lanes l1(rays.o[a][1], rays.d[a][1]);
            auto join = [](const V4f& x, const V4f& y) { return __builtin_shufflevector(x, y, 0, 1, 2, 3, 4, 5, 6, 7); };
#if RT_PACKET == 8
            o_near[a] = join(l0.o_near, l1.o_near);
            o_far[a] = join(l0.o_far, l1.o_far);
            inv_near[a] = join(l0.inv_near, l1.inv_near);
            inv_far[a] = join(l0.inv_far, l1.inv_far);
#else
            const RaySlabs::Lanes l2(rays.o[a][2], rays.d[a][2]);
            const RaySlabs::Lanes l3(rays.o[a][3], rays.d[a][3]);
            auto join4 = [&](const V4f& x0, const V4f& x1, const V4f& x2, const V4f& x3) {
                return __builtin_shufflevector(join(x0, x1), join(x2, x3), 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13,
                                               14, 15);
            };
            o_near[a] = join4(l0.o_near, l1.o_near, l2.o_near, l3.o_near);
            o_far[a] = join4(l0.o_far, l1.o_far, l2.o_far, l3.o_far);
            inv_near[a] = join4(l0.inv_near, l1.inv_near, l2.inv_near, l3.inv_near);
            inv_far[a] = join4(l0.inv_far, l1.inv_far, l2.inv_far, l3.inv_far);
#endif
            near_row[a] = a * kWidth + (l0.neg[0] ? 3 * kWidth : 0);
            far_row[a] = a * kWidth + (l0.neg[0] ? 0 : 3 * kWidth);
        }
    }
};

// The order in which a ray visits the children of a node that it meets: nearest first by
// an order key, the entry distance's bits (tn >= +0, never NaN: its bits order as
// integers) with the lowest three replaced by the child's slot. Keys are distinct, and two
// entry distances within 8 ulps (2^-21 relative) of each other go by slot. The single-ray
// traversal (insertion sort on the keys) and the interleaved one (a sorting network on
// them) share this order, so each finds exactly what the other finds, ties included.
inline int32_t child_order_key(float tn, int slot) {
    int32_t bits;
    __builtin_memcpy(&bits, &tn, sizeof bits);
    return (bits & ~7) | slot;
}

// The children of a node that a ray meets, nearest first (insertion sort on the order
// keys: usually one to three children, whose branches predict well for one ray at a time).
inline int sorted_hits(unsigned mask, const V8f& tn, int (&idx)[kWidth]) {
    // None or one child (most nodes a random ray visits low in the tree): nothing to sort.
    if (mask == 0) return 0;
    idx[0] = __builtin_ctz(mask);
    mask &= mask - 1;
    if (mask == 0) return 1;
    int k = 1;
    for (; mask != 0; mask &= mask - 1) idx[k++] = __builtin_ctz(mask);
    int32_t key[kWidth];
    for (int i = 0; i < k; ++i) key[i] = child_order_key(tn[idx[i]], idx[i]);
    for (int i = 1; i < k; ++i)
        for (int j = i; j > 0 && key[j] < key[j - 1]; --j) {
            std::swap(idx[j], idx[j - 1]);
            std::swap(key[j], key[j - 1]);
        }
    return k;
}

#ifdef __AVX2__
// One compare-exchange step of a sorting network: lane i keeps the larger of v[i] and
// partner[i] where bit i of kTakeMax is set, the smaller elsewhere.
template <int kTakeMax>
inline __m256i bitonic_step(__m256i v, __m256i partner) {
    return _mm256_blend_epi32(_mm256_min_epi32(v, partner), _mm256_max_epi32(v, partner), kTakeMax);
}
#endif

// The children of node n that a ray meets (`met`: all ones for a child met; tn: the entry
// distances), farthest first, written without a data-dependent branch into ref[0..8),
// count[0..8) and t_near[0..8) (all eight written; those from k on are not children met);
// returns k, their number: the nearest is at k - 1. The interleaved traversal's order. There,
// a branch on how many children a random ray meets is one the predictor cannot know, and
// each misprediction discards the other lanes' work in flight too: an insertion sort costs
// 5.1 of 8.8 mispredictions a random ray (PERFORMANCE.md, Ideas tried). A sorting network
// of the order keys (24 vector instructions) gives the same order as sorted_hits without
// one.
inline int far_to_near_hits(const WideNode& n, const V8i& met, const V8f& tn, int32_t* ref, int32_t* count,
                            float* t_near) {
#ifdef __AVX2__
    const __m256i slot = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    __m256i key = _mm256_or_si256(_mm256_and_si256(_mm256_castps_si256(reinterpret_cast<__m256>(tn)),
                                                   _mm256_set1_epi32(~7)),
                                  slot);
    // Children not met sort last: -1 is below every key.
    key = _mm256_blendv_epi8(_mm256_set1_epi32(-1), key, reinterpret_cast<__m256i>(met));
    // Bitonic network, descending (Batcher): each step compares lane i with lane i ^ d.
    key = bitonic_step<0x99>(key, _mm256_shuffle_epi32(key, 0xB1));  // pairs: down, up, down, up
    key = bitonic_step<0xC3>(key, _mm256_shuffle_epi32(key, 0x4E));  // fours: down, up
    key = bitonic_step<0xA5>(key, _mm256_shuffle_epi32(key, 0xB1));
    key = bitonic_step<0x0F>(key, _mm256_permute4x64_epi64(key, 0x4E));  // eight: down
    key = bitonic_step<0x33>(key, _mm256_shuffle_epi32(key, 0x4E));
    key = bitonic_step<0x55>(key, _mm256_shuffle_epi32(key, 0xB1));
    const __m256i order = _mm256_and_si256(key, _mm256_set1_epi32(7));
    __m256i child, counts;
    __builtin_memcpy(&child, n.child, sizeof child);
    __m128i count16;
    __builtin_memcpy(&count16, n.count, sizeof count16);
    child = _mm256_permutevar8x32_epi32(child, order);
    counts = _mm256_permutevar8x32_epi32(_mm256_cvtepu16_epi32(count16), order);
    const __m256 t = _mm256_permutevar8x32_ps(reinterpret_cast<__m256>(tn), order);
    __builtin_memcpy(ref, &child, sizeof child);
    __builtin_memcpy(count, &counts, sizeof counts);
    __builtin_memcpy(t_near, &t, sizeof t);
    return __builtin_popcount(lane_mask(met));
#else
    int idx[kWidth];
    const int k = sorted_hits(lane_mask(met), tn, idx);
    for (int j = 0; j < k; ++j) {
        const int c = idx[k - 1 - j];
        ref[j] = n.child[c];
        count[j] = n.count[c];
        t_near[j] = tn[c];
    }
    return k;
#endif
}

constexpr float kInfF = std::numeric_limits<float>::infinity();

// A packet's slab constants as intervals over its rays, per axis, and the test of a
// node's eight child boxes against all of them at once: a lower bound of every ray's
// near distance and an upper bound of every ray's far distance per child, so that a
// child no ray of the packet meets is (nearly always) rejected by one 8-wide test
// instead of its own test against the eight rays. On camera rays most children of a
// node are missed by the whole packet, and testing them one by one was a third of
// the instructions.
//
// Why it never rejects a child that a ray's own test (WideBVH::traverse_packet) passes:
// that test computes t0 = fl(fl(P - o) * inv) and t1 likewise for each ray. Rounding is
// monotone, the rays share an octant (inv has one sign per axis), and (P - o) * inv is
// monotone in o and linear in inv: over the box of (o, inv) its minimum lies at the
// corner with o at the bound that makes P - o smallest (inv > 0) or largest (inv < 0)
// and inv at either end. So the smallest of the two corner values, computed with the
// same float operations, is at most every ray's computed t0; the largest far corner is
// at least every ray's t1; and the pass condition max(0, t0) <= min(t_max, t1) of any
// ray implies it for the bounds (t_max: the largest over the packet). NaN would break
// the argument (0 * inf): the bounds are used only when every factor is finite and
// non-zero, which excludes it (a plane at infinity times a finite factor is infinite,
// not NaN).
struct PacketBounds {
    bool valid = true;
    float o_near[3], o_far[3];          // the corner origin of the near / far distances
    float inv_near[2][3], inv_far[2][3];  // [smallest, largest] factor

    PacketBounds(const VRf (&on)[3], const VRf (&of)[3], const VRf (&in)[3], const VRf (&inf)[3], unsigned active) {
        // Whole-vector reductions, with the absent lanes replaced by the first ray's.
        const VRi present = packet_lanes(active);
        const int first = __builtin_ctz(active);
        auto fill = [&](const VRf& v) { return present ? v : splat_rays(v[first]); };
        auto finite_nonzero = [&](const VRf& v) {
            const VRf mag = v < 0.0f ? -v : v;  // NaN fails both comparisons below
            return lane_mask((mag <= std::numeric_limits<float>::max()) & (mag > 0.0f)) == kAllPacketRays;
        };
        auto finite = [&](const VRf& v) { return lane_mask(v - v == 0.0f) == kAllPacketRays; };  // inf - inf is NaN
        for (int a = 0; a < 3; ++a) {
            const VRf o_n = fill(on[a]), o_f = fill(of[a]), i_n = fill(in[a]), i_f = fill(inf[a]);
            valid = valid && finite_nonzero(i_n) && finite_nonzero(i_f) && finite(o_n) && finite(o_f);
            const bool pos = i_n[first] > 0.0f;  // one sign for the packet (one octant)
            o_near[a] = pos ? max_lane(o_n) : min_lane(o_n);
            o_far[a] = pos ? min_lane(o_f) : max_lane(o_f);
            inv_near[0][a] = min_lane(i_n); inv_near[1][a] = max_lane(i_n);
            inv_far[0][a] = min_lane(i_f); inv_far[1][a] = max_lane(i_f);
        }
    }

    // Mask of the children of n that some ray may meet within [0, t_max_f].
    unsigned test(const WideNode& n, const int* near_row, const int* far_row, float t_max_f) const {
        const float* rows = &n.lo[0][0];
        V8f tn = V8f{};
        V8f tf = splat8(t_max_f);
        for (int a = 0; a < 3; ++a) {
            V8f near_plane, far_plane;
            __builtin_memcpy(&near_plane, rows + near_row[a], sizeof(V8f));
            __builtin_memcpy(&far_plane, rows + far_row[a], sizeof(V8f));
            const V8f dn = near_plane - o_near[a];
            const V8f n0 = dn * inv_near[0][a], n1 = dn * inv_near[1][a];
            const V8f df = far_plane - o_far[a];
            const V8f f0 = df * inv_far[0][a], f1 = df * inv_far[1][a];
            const V8f t0 = n0 < n1 ? n0 : n1;
            const V8f t1 = f0 > f1 ? f0 : f1;
            tn = t0 > tn ? t0 : tn;
            tf = t1 < tf ? t1 : tf;
        }
        return lane_mask(tn <= tf);
    }
};

class WideBVH {
public:
    // A leaf the scene packs into a block: its primitives are order()[first, first + count).
    struct BlockLeaf { uint32_t first, count; };

    WideBVH() = default;
    // `packable(prim)` says whether a primitive may go into a block; leaves whose
    // primitives all are become block leaves, numbered in the order of blocks().
    template <typename Packable>
    WideBVH(const BVH& binary, Packable&& packable) : order_(binary.order()) {
        build(binary, [&](uint32_t p) { return bool(packable(p)); });
    }

    size_t node_count() const { return nodes_.size(); }
    int depth() const { return depth_; }
    const std::vector<uint32_t>& order() const { return order_; }
    bool empty() const { return nodes_.empty(); }
    const std::vector<BlockLeaf>& blocks() const { return blocks_; }

    // Closest-hit (AnyHit = false) or any-hit traversal. `test(prim, t_max)` and
    // `test_block(block, t_max)` return true on a hit closer than t_max and lower t_max
    // (closest-hit). Children are visited nearest first; entries are culled when a
    // closer hit was found meanwhile. Primitive tests are exact (double); only the box
    // tests are in float, and they are conservative (RaySlabs), so the hits found are
    // the ones a double-precision box test would find. `prefetch_block(block)` is called
    // for block leaves put on the stack: it may start loading the block, which a large
    // mesh would otherwise miss in cache when popped.
    template <bool AnyHit, typename Test, typename TestBlock, typename PrefetchBlock>
    bool traverse(const Ray& ray, double& t_max, Test&& test, TestBlock&& test_block,
                  PrefetchBlock&& prefetch_block) const {
        if (nodes_.empty()) return false;
        const RaySlabs slabs(ray);
        // t_max (double, lowered by hits) as a float that is never below it; refreshed
        // after every leaf, the only place t_max changes.
        float t_max_f = RaySlabs::max_float(t_max);
        Entry stack[kStackSize];
        int top = 0;
        bool hit = false;
        // Returns true when an any-hit query is answered.
        auto visit_leaf = [&](int32_t ref, uint32_t count) {
            if (!test_leaf<AnyHit>(ref, count, t_max, test, test_block)) return false;
            hit = true;
            t_max_f = RaySlabs::max_float(t_max);
            return AnyHit;
        };
        int32_t node = 0;  // the interior node visited next
        for (;;) {
            const WideNode& n = nodes_[node];
            V8f tn;
            const unsigned mask = slabs.test(n, t_max_f, tn);
            int idx[kWidth], k;
            if (AnyHit) {
                // An any-hit query takes the first occluder in any order, and the sort's
                // data-dependent branches cost more than the order saves on small trees.
                k = 0;
                for (unsigned m = mask; m != 0; m &= m - 1) idx[k++] = __builtin_ctz(m);
            } else {
                // Nearest first: a near hit culls the farther entries.
                k = sorted_hits(mask, tn, idx);
            }
            // Push all but the nearest, farthest first; the nearest is visited now, with
            // no round trip through the stack.
            for (int j = k - 1; j > 0; --j) push(stack, top, n, idx[j], tn, prefetch_block);
            bool descend = false;
            if (k > 0) {
                const int c = idx[0];
                if (n.child[c] >= 0) {
                    node = n.child[c];
                    descend = true;
                } else if (visit_leaf(n.child[c], n.count[c])) {
                    return true;
                }
            }
            // Otherwise pop: leaves are tested in place, the first interior node still
            // nearer than the closest hit is visited next. The cull compares against
            // t_max rounded up, and t_near is never above its exact value by more than
            // the widening: only entries wholly beyond t_max are dropped.
            while (!descend && top > 0) {
                const Entry e = stack[--top];
                if (e.t_near > t_max_f) continue;
                if (e.ref >= 0) {
                    node = e.ref;
                    descend = true;
                } else if (visit_leaf(e.ref, e.count)) {
                    return true;
                }
            }
            if (!descend) return hit;
        }
    }

    // Closest hits (or, kAnyHit, any hits) of many rays, traversed kLanes at a time in round robin. Each step of
    // a ray visits one node or one leaf and prefetches what it visits next, so the cache
    // miss of one ray's next step is served while the other rays take theirs: on large
    // meshes single-ray traversal waits on one miss after another, and this keeps
    // several in flight (what packets do for coherent rays, for incoherent ones too).
    // Each ray's result is exactly what traverse<false> returns for it.
    //
    // `query` provides: begin(slot, i) -> ray i, called before its traversal in slot;
    // t_start(i), the distance below which ray i's hits count (kInf, or a closest hit
    // found outside this tree); test(slot, prim, t_max), test_block(slot, block, t_max) as
    // for traverse; prefetch_block(block); finish(slot, i, hit, t).
    //
    // `kPrefetchPushed`: whether the children pushed on a lane's stack are prefetched when
    // pushed, as well as when popped (the next item of a lane is prefetched either way,
    // a round of the lanes before its visit). Worth it for a tree held in the caches; for
    // one that is not, a pushed child is a memory transfer that holds a line fill buffer
    // (a core has about 16) for the ~150 ns of a DRAM access, and 40% of them are culled
    // unvisited: 1M triangles (67 MB of tree), random rays, 1 thread, paired: without them
    // 1.08-1.22x while the host's memory was busy, 1.01-1.06x when it was quieter; 300k
    // triangles 1.17x; 100k triangles (6.5 MB) 0.95x and 0.98x (PERFORMANCE.md, Ideas tried).
    // A template parameter: as a run-time flag tested in the push loop, the build lost the
    // gain (0.84x of the build without the prefetches).
    //
    // `kAnyHit`: a ray's traversal ends at its first hit (shadow rays): whether it hits is
    // traverse<true>'s answer, the distance reported may be another hit's.
    template <int kLanes, bool kPrefetchPushed, bool kAnyHit = false, typename Query>
    void traverse_interleaved(size_t count, Query& query) const {
        struct Lane {
            RaySlabs slabs;
            double t_max;
            float t_max_f;
            bool hit;
            size_t ray;
            int top;
            int32_t ref;     // what the next step visits: a node (>= 0) or a leaf
            uint32_t leaf_count;
            bool active;
        };
        if (nodes_.empty()) {
            for (size_t i = 0; i < count; ++i) { query.begin(0, i); query.finish(0, i, false, kInf); }
            return;
        }
        // One stack per lane, as deep as this tree can need, in structure-of-arrays form
        // (far_to_near_hits writes eight entries at once: kWidth more of headroom).
        // On the call's own stack where they fit (trees up to depth 12), as they do for the
        // wavefront integrator's small batches, which would otherwise allocate every bounce.
        const int stack_size = (depth_ + 1) * (kWidth - 1) + 1 + kWidth;
        constexpr int kInlineStack = 13 * (kWidth - 1) + 1 + kWidth;
        const bool inline_stack = stack_size <= kInlineStack;
        const size_t heap_size = inline_stack ? 0 : static_cast<size_t>(stack_size) * kLanes;
        std::vector<int32_t> heap_refs(heap_size), heap_counts(heap_size);
        std::vector<float> heap_t(heap_size);
        int32_t inline_refs[kInlineStack * kLanes], inline_counts[kInlineStack * kLanes];
        float inline_t[kInlineStack * kLanes];
        int32_t* const stack_refs = inline_stack ? inline_refs : heap_refs.data();
        int32_t* const stack_counts = inline_stack ? inline_counts : heap_counts.data();
        float* const stack_t = inline_stack ? inline_t : heap_t.data();
        Lane lanes[kLanes];
        size_t next_ray = 0;
        auto prefetch_block = [&](uint32_t block) { query.prefetch_block(block); };
        auto start = [&](int s) {
            Lane& l = lanes[s];
            if (next_ray == count) { l.active = false; return; }
            l.ray = next_ray++;
            l.slabs = RaySlabs(query.begin(s, l.ray));
            l.t_max = query.t_start(l.ray);
            l.t_max_f = RaySlabs::max_float(l.t_max);
            l.hit = false;
            l.top = 0;
            l.ref = 0;
            l.leaf_count = 0;
            l.active = true;
        };
        int active = 0;
        for (int s = 0; s < kLanes; ++s) {
            start(s);
            active += lanes[s].active;
        }
        while (active > 0) {
            for (int s = 0; s < kLanes; ++s) {
                Lane& l = lanes[s];
                if (!l.active) continue;
                const size_t base = static_cast<size_t>(s) * stack_size;
                int32_t* refs = stack_refs + base;
                int32_t* counts = stack_counts + base;
                float* t_near = stack_t + base;
                bool have_next = false;
                if (l.ref >= 0) {
                    // The children met go on the stack, the nearest on top, and the pop
                    // below takes it: no branch on how many there are.
                    const WideNode& n = nodes_[l.ref];
                    V8f tn;
                    const V8i met = l.slabs.test_lanes(n, l.t_max_f, tn);
                    const int k = far_to_near_hits(n, met, tn, refs + l.top, counts + l.top, t_near + l.top);
                    if (kPrefetchPushed)
                        for (int j = l.top; j < l.top + k - 1; ++j) prefetch_child(refs[j], counts[j], prefetch_block);
                    l.top += k;
                } else {
                    auto test = [&](uint32_t prim, double& t) { return query.test(s, prim, t); };
                    auto test_block = [&](uint32_t block, double& t) { return query.test_block(s, block, t); };
                    if (test_leaf<kAnyHit>(l.ref, l.leaf_count, l.t_max, test, test_block)) {
                        l.hit = true;
                        l.t_max_f = RaySlabs::max_float(l.t_max);
                        if (kAnyHit) l.top = 0;  // answered: nothing left to visit
                    }
                }
                while (l.top > 0) {
                    --l.top;
                    if (t_near[l.top] > l.t_max_f) continue;
                    l.ref = refs[l.top];
                    l.leaf_count = static_cast<uint32_t>(counts[l.top]);
                    have_next = true;
                    break;
                }
                if (have_next) {
                    prefetch_child(l.ref, l.leaf_count, prefetch_block);
                } else {
                    query.finish(s, l.ray, l.hit, l.t_max);
                    start(s);
                    active -= !l.active;
                }
            }
        }
    }

    // Closest hits of a packet of up to kPacketRays rays that share one octant of
    // directions (so the same box rows are near and far planes for all of them), lane r
    // for ray r, `active` the mask of rays present. Each node's children are tested one at
    // a time against all the rays at once, and the packet descends into a child if any ray
    // meets its box: for coherent rays (camera rays through neighbouring pixels) one
    // node fetch, one sort and one push serve up to sixteen rays, where traversing them
    // one by one repeats that branchy work per ray. Every ray's result is the one
    // traverse<false> gives it: it is tested against every leaf whose box it meets
    // (per ray), and an entry is dropped for a ray only when the ray's own closest hit
    // is nearer than the entry's distance (the smallest over the packet's rays).
    // `query` provides test(lane, prim, t_max), test_block(lane, block, t_max) (as for
    // traverse) and prefetch_block(block); t_max[r] in, closest t out; hit[r] set on a hit.
    template <typename Query>
    void traverse_packet(const PacketSlabs& slabs, unsigned active, double (&t_max)[kPacketRays],
                         bool (&hit)[kPacketRays], Query& query) const {
        if (nodes_.empty() || active == 0) return;
        // Lane r of each vector: ray r's slab constants.
        const auto& o_near = slabs.o_near;
        const auto& o_far = slabs.o_far;
        const auto& inv_near = slabs.inv_near;
        const auto& inv_far = slabs.inv_far;
        const int* near_row = slabs.near_row;
        const int* far_row = slabs.far_row;
        // Absent rays get t_max -inf: no box passes for them.
        VRf t_max_f;
        for (int r = 0; r < kPacketRays; ++r)
            t_max_f[r] = (active >> r) & 1u ? RaySlabs::max_float(t_max[r]) : -std::numeric_limits<float>::infinity();
        const PacketBounds bounds(o_near, o_far, inv_near, inv_far, active);
        struct PacketEntry { int32_t ref; uint16_t count; uint16_t mask; float t_near; };
        PacketEntry stack[kStackSize];
        int top = 0;
        int32_t ref = 0;     // the item visited next: the root, for all rays present
        uint32_t count = 0;
        unsigned mask = active;
        for (;;) {
            if (ref >= 0) {
                const WideNode& n = nodes_[ref];
                const float* rows = &n.lo[0][0];
                const VRi in_packet = packet_lanes(mask);
                int idx[kWidth], k = 0;
                unsigned child_mask[kWidth];
                float dist[kWidth];
                // The children some ray of the packet may meet (all, without bounds):
                // the others would fail every ray's test below.
                const unsigned candidates =
                    bounds.valid ? bounds.test(n, near_row, far_row, max_lane(in_packet ? t_max_f : VRf{} - kInfF))
                                 : (1u << kWidth) - 1u;
                for (unsigned cm = candidates; cm != 0; cm &= cm - 1) {
                    const int c = __builtin_ctz(cm);
                    if (n.child[c] == 0 && n.count[c] == 0) break;  // empty slots come last
                    VRf tn = VRf{};
                    VRf tf = t_max_f;
                    for (int a = 0; a < 3; ++a) {
                        const VRf t0 = (rows[near_row[a] + c] - o_near[a]) * inv_near[a];
                        const VRf t1 = (rows[far_row[a] + c] - o_far[a]) * inv_far[a];
                        tn = t0 > tn ? t0 : tn;  // NaN keeps the bound, as in RaySlabs::test
                        tf = t1 < tf ? t1 : tf;
                    }
                    const VRi pass = (tn <= tf) & in_packet;
                    const unsigned m = lane_mask(pass);
                    if (m == 0) continue;
                    idx[k] = c;
                    child_mask[c] = m;
                    dist[c] = min_lane(pass ? tn : VRf{} + std::numeric_limits<float>::infinity());
                    ++k;
                }
                for (int i = 1; i < k; ++i)
                    for (int j = i; j > 0 && dist[idx[j]] < dist[idx[j - 1]]; --j) std::swap(idx[j], idx[j - 1]);
                for (int j = k - 1; j > 0; --j) {
                    const int c = idx[j];
                    prefetch_child(n.child[c], n.count[c], [&](uint32_t block) { query.prefetch_block(block); });
                    stack[top++] = {n.child[c], n.count[c], static_cast<uint16_t>(child_mask[c]), dist[c]};
                }
                if (k > 0) {
                    ref = n.child[idx[0]];
                    count = n.count[idx[0]];
                    mask = child_mask[idx[0]];
                    continue;
                }
            } else {
                for (unsigned m = mask; m != 0; m &= m - 1) {
                    const int r = __builtin_ctz(m);
                    auto test = [&](uint32_t prim, double& t) { return query.test(r, prim, t); };
                    auto test_block = [&](uint32_t block, double& t) { return query.test_block(r, block, t); };
                    if (test_leaf<false>(ref, count, t_max[r], test, test_block)) {
                        hit[r] = true;
                        t_max_f[r] = RaySlabs::max_float(t_max[r]);
                    }
                }
            }
            // Pop: the rays whose closest hit is nearer than the entry leave it.
            bool next = false;
            while (top > 0) {
                const PacketEntry e = stack[--top];
                const unsigned m = e.mask & lane_mask(t_max_f >= e.t_near);
                if (m == 0) continue;
                ref = e.ref;
                count = e.count;
                mask = m;
                next = true;
                break;
            }
            if (!next) return;
        }
    }

    // Each level pushes at most kWidth - 1 entries, and the binary tree is at most
    // 64 + 32 levels deep (bvh.cpp), so the wide tree's depth never exceeds that either.
    static constexpr int kStackSize = (kWidth - 1) * 100;

private:
    struct Entry { int32_t ref; uint32_t count; float t_near; };

    // Starts loading a child: an interior node (all its cache lines) or a block leaf.
    template <typename PrefetchBlock>
    void prefetch_child(int32_t ref, uint32_t count, PrefetchBlock&& prefetch_block) const {
        if (ref >= 0) {
            const char* p = reinterpret_cast<const char*>(&nodes_[ref]);
            for (size_t line = 0; line < sizeof(WideNode); line += 64) __builtin_prefetch(p + line);
        } else if (count & kBlockLeaf) {
            prefetch_block(~static_cast<uint32_t>(ref));
        }
    }

    // Pushes child c of node n and starts the load of its memory: it waits on the stack
    // while the nearer subtree is traversed.
    template <typename PrefetchBlock>
    void push(Entry* stack, int& top, const WideNode& n, int c, const V8f& tn, PrefetchBlock&& prefetch_block) const {
        prefetch_child(n.child[c], n.count[c], prefetch_block);
        stack[top++] = {n.child[c], n.count[c], tn[c]};
    }

    // Tests the primitives of a leaf; true on a hit (the first one, for any-hit queries).
    template <bool AnyHit, typename Test, typename TestBlock>
    bool test_leaf(int32_t ref, uint32_t count, double& t_max, Test&& test, TestBlock&& test_block) const {
        if (count & kBlockLeaf) return test_block(~static_cast<uint32_t>(ref), t_max);
        const uint32_t first = ~static_cast<uint32_t>(ref);
        bool any = false;
        for (uint32_t i = 0; i < count; ++i) {
            if (test(order_[first + i], t_max)) {
                any = true;
                if (AnyHit) break;
            }
        }
        return any;
    }

    class CollapsePlan;
    void build(const BVH& binary, const std::function<bool(uint32_t)>& packable);
    int32_t collapse(const BVH& binary, const CollapsePlan& plan, uint32_t node, int depth,
                     const std::function<bool(uint32_t)>& packable);
    // Child reference and count of a leaf of the binary tree (a block leaf when packable).
    void make_leaf(const BVHNode& leaf, const std::function<bool(uint32_t)>& packable, int32_t& child,
                   uint16_t& count);

    std::vector<WideNode> nodes_;
    std::vector<uint32_t> order_;
    std::vector<BlockLeaf> blocks_;
    int depth_ = 0;
};

}  // namespace rt
