// A 4-wide BVH collapsed from the binary SAH tree: each node holds the boxes of up to four
// children, stored as float (rounded outward, so boxes only grow) in structure-of-arrays
// form, so that one node visit tests four boxes with vector instructions and moves half
// the memory of double boxes. The arithmetic of the test is in double.
#pragma once

#include <cstdint>
#include <cstring>
#include <functional>
#include <vector>

#ifdef __AVX__
#include <immintrin.h>
#endif

#include "bvh.h"

namespace rt {

using V4d = double __attribute__((vector_size(32)));
using V4f = float __attribute__((vector_size(16)));

// Four floats (16-byte aligned) widened to doubles, exactly. GCC lowers
// __builtin_convertvector(V4f -> V4d) to two half conversions through the stack, so the
// AVX instruction is named directly where it exists.
inline V4d load_widen(const float* p) {
#ifdef __AVX__
    return reinterpret_cast<V4d>(_mm256_cvtps_pd(_mm_load_ps(p)));
#else
    V4f f;
    std::memcpy(&f, p, sizeof(V4f));
    return __builtin_convertvector(f, V4d);
#endif
}

struct alignas(32) WideNode {
    float lo[3][4];
    float hi[3][4];
    int32_t child[4];   // >= 0: interior node; < 0: leaf (see count)
    uint16_t count[4];  // leaf: primitives, | kBlockLeaf for a packed block; 0: interior or empty
};

// A leaf child whose primitives the scene packs into one block tested at once (four
// triangles in SoA form): ~child is the block index, not an index into order().
constexpr uint16_t kBlockLeaf = 0x8000;

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
    const std::vector<BlockLeaf>& blocks() const { return blocks_; }

    // Closest-hit (AnyHit = false) or any-hit traversal. `test(prim, t_max)` and
    // `test_block(block, t_max)` return true on a hit closer than t_max and lower t_max
    // (closest-hit). Children are visited nearest first; entries are culled when a
    // closer hit was found meanwhile.
    template <bool AnyHit, typename Test, typename TestBlock>
    bool traverse(const Ray& ray, double& t_max, Test&& test, TestBlock&& test_block) const {
        if (nodes_.empty()) return false;
        constexpr double kWiden = 1.0 + 8.0 * std::numeric_limits<double>::epsilon();
        // The three reciprocals with one vector division (three scalar ones were the
        // largest single cost of a traversal on small trees); the same IEEE quotients.
        const V4d inv_d = V4d{1.0, 1.0, 1.0, 1.0} / V4d{ray.d.x, ray.d.y, ray.d.z, 1.0};
        // Per-ray slab constants, and the box rows to read as near/far planes per axis
        // (chosen once per ray rather than per node).
        const V4d o[3] = {V4d{} + ray.o.x, V4d{} + ray.o.y, V4d{} + ray.o.z};
        const V4d id[3] = {V4d{} + inv_d[0], V4d{} + inv_d[1], V4d{} + inv_d[2]};
        const V4d id_far[3] = {id[0] * kWiden, id[1] * kWiden, id[2] * kWiden};
        // Offsets (in floats) of the near and far rows of axis a inside a WideNode.
        int near_row[3], far_row[3];
        for (int a = 0; a < 3; ++a) {
            const bool neg = inv_d[a] < 0.0;
            near_row[a] = (neg ? 12 : 0) + 4 * a;
            far_row[a] = (neg ? 0 : 12) + 4 * a;
        }
        struct Entry { int32_t ref; uint32_t count; double t_near; };
        Entry stack[kStackSize];
        int top = 0;
        bool hit = false;
        // Returns true when an any-hit query is answered.
        auto visit_leaf = [&](int32_t ref, uint32_t count) {
            if (count & kBlockLeaf) {
                if (test_block(~static_cast<uint32_t>(ref), t_max)) { hit = true; return AnyHit; }
                return false;
            }
            const uint32_t first = ~static_cast<uint32_t>(ref);
            for (uint32_t i = 0; i < count; ++i) {
                if (test(order_[first + i], t_max)) {
                    hit = true;
                    if (AnyHit) return true;
                }
            }
            return false;
        };
        int32_t node = 0;  // the interior node visited next
        for (;;) {
            const WideNode& n = nodes_[node];
            const float* rows = &n.lo[0][0];
            // Four slab tests at once (GCC/Clang vector extensions: AVX with -march=native,
            // pairs of SSE2 operations otherwise). Arithmetic in double on float boxes
            // rounded outward: conservative.
            V4d tn = {0.0, 0.0, 0.0, 0.0};
            V4d tf = V4d{} + t_max;
            for (int a = 0; a < 3; ++a) {
                const V4d t0 = (load_widen(rows + near_row[a]) - o[a]) * id[a];
                const V4d t1 = (load_widen(rows + far_row[a]) - o[a]) * id_far[a];
                // NaN (origin on a slab plane of a parallel ray) keeps the bound:
                // conservative (the primitive test decides), never a missed hit.
                tn = t0 > tn ? t0 : tn;
                tf = t1 < tf ? t1 : tf;
            }
            int idx[4], k = 0;
            for (int i = 0; i < 4; ++i)
                if (tn[i] <= tf[i] && (n.child[i] >= 0 || n.count[i] > 0)) idx[k++] = i;
            // Nearest first, for closest hits only: it lets a near hit cull the farther
            // entries. An any-hit query takes the first occluder in any order, and the sort's
            // data-dependent branches cost more than the order saves on small trees.
            if (!AnyHit)
                for (int i = 1; i < k; ++i)
                    for (int j = i; j > 0 && tn[idx[j]] < tn[idx[j - 1]]; --j) std::swap(idx[j], idx[j - 1]);
            // Push all but the nearest, farthest first; the nearest is visited now, with
            // no round trip through the stack.
            for (int j = k - 1; j > 0; --j) stack[top++] = {n.child[idx[j]], n.count[idx[j]], tn[idx[j]]};
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
            // nearer than the closest hit is visited next.
            while (!descend && top > 0) {
                const Entry e = stack[--top];
                if (e.t_near > t_max) continue;
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

    static constexpr int kStackSize = 512;

private:
    void build(const BVH& binary, const std::function<bool(uint32_t)>& packable);
    int32_t collapse(const BVH& binary, uint32_t node, int depth, const std::function<bool(uint32_t)>& packable);
    // Child reference and count of a leaf of the binary tree (a block leaf when packable).
    void make_leaf(const BVHNode& leaf, const std::function<bool(uint32_t)>& packable, int32_t& child,
                   uint16_t& count);

    std::vector<WideNode> nodes_;
    std::vector<uint32_t> order_;
    std::vector<BlockLeaf> blocks_;
    int depth_ = 0;
};

}  // namespace rt
