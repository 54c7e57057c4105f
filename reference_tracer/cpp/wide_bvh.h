// A 4-wide BVH collapsed from the binary SAH tree: each node holds the boxes of up to four
// children, stored as float (rounded outward, so boxes only grow) in structure-of-arrays
// form, so that one node visit tests four boxes with vector instructions and moves half
// the memory of double boxes. The arithmetic of the test is in double.
#pragma once

#include <cstdint>
#include <cstring>
#include <vector>

#include "bvh.h"

namespace rt {

using V4d = double __attribute__((vector_size(32)));
using V4f = float __attribute__((vector_size(16)));

struct alignas(32) WideNode {
    float lo[3][4];
    float hi[3][4];
    int32_t child[4];   // >= 0: interior node; < 0: leaf whose first primitive is ~child
    uint16_t count[4];  // primitives of a leaf child; 0 for interior or empty slots
};

class WideBVH {
public:
    WideBVH() = default;
    explicit WideBVH(const BVH& binary);

    size_t node_count() const { return nodes_.size(); }
    int depth() const { return depth_; }
    const std::vector<uint32_t>& order() const { return order_; }

    // Closest-hit (AnyHit = false) or any-hit traversal. `test(prim, t_max)` returns true
    // on a hit closer than t_max and lowers t_max (closest-hit). Children are visited
    // nearest first; entries are culled when a closer hit was found meanwhile.
    template <bool AnyHit, typename Test>
    bool traverse(const Ray& ray, double& t_max, Test&& test) const {
        if (nodes_.empty()) return false;
        constexpr double kWiden = 1.0 + 8.0 * std::numeric_limits<double>::epsilon();
        const RayInv inv(ray);
        struct Entry { int32_t ref; uint32_t count; double t_near; };
        Entry stack[kStackSize];
        int top = 0;
        stack[top++] = {0, 0, 0.0};
        bool hit = false;
        while (top > 0) {
            const Entry e = stack[--top];
            if (e.t_near > t_max) continue;
            if (e.ref < 0) {
                const uint32_t first = ~static_cast<uint32_t>(e.ref);
                for (uint32_t i = 0; i < e.count; ++i) {
                    if (test(order_[first + i], t_max)) {
                        hit = true;
                        if (AnyHit) return true;
                    }
                }
                continue;
            }
            const WideNode& n = nodes_[e.ref];
            // Four slab tests at once (GCC/Clang vector extensions: AVX with -march=native,
            // pairs of SSE2 operations otherwise).
            V4d tn = {0.0, 0.0, 0.0, 0.0};
            V4d tf = {t_max, t_max, t_max, t_max};
            for (int a = 0; a < 3; ++a) {
                V4f near_f, far_f;
                std::memcpy(&near_f, inv.neg[a] ? n.hi[a] : n.lo[a], sizeof(V4f));
                std::memcpy(&far_f, inv.neg[a] ? n.lo[a] : n.hi[a], sizeof(V4f));
                const double o = inv.o[a], id = inv.inv_d[a];
                const V4d t0 = (__builtin_convertvector(near_f, V4d) - o) * id;
                const V4d t1 = (__builtin_convertvector(far_f, V4d) - o) * id * kWiden;
                // NaN (origin on a slab plane of a parallel ray) keeps the bound:
                // conservative, as in slab_hit.
                tn = t0 > tn ? t0 : tn;
                tf = t1 < tf ? t1 : tf;
            }
            int idx[4], k = 0;
            for (int i = 0; i < 4; ++i)
                if (tn[i] <= tf[i] && (n.child[i] >= 0 || n.count[i] > 0)) idx[k++] = i;
            // Push the farthest first so the nearest child is visited next.
            for (int i = 1; i < k; ++i)
                for (int j = i; j > 0 && tn[idx[j]] > tn[idx[j - 1]]; --j) std::swap(idx[j], idx[j - 1]);
            for (int j = 0; j < k; ++j) stack[top++] = {n.child[idx[j]], n.count[idx[j]], tn[idx[j]]};
        }
        return hit;
    }

    static constexpr int kStackSize = 512;

private:
    int32_t collapse(const BVH& binary, uint32_t node, int depth);

    std::vector<WideNode> nodes_;
    std::vector<uint32_t> order_;
    int depth_ = 0;
};

}  // namespace rt
