// Bounding volume hierarchy over primitive bounding boxes, built with a binned surface
// area heuristic (Wald 2007) and stored as a flat, depth-first node array: the left
// child of an interior node follows it, the right child is at `offset`.
#pragma once

#include <cstdint>
#include <vector>

#include "aabb.h"

namespace rt {

struct BVHNode {
    AABB box;
    uint32_t offset = 0;  // leaf: first index into BVH::order; interior: right child
    uint16_t count = 0;   // primitives in a leaf; 0 for interior nodes
    uint8_t axis = 0;     // split axis of an interior node (front-to-back traversal)
};

class BVH {
public:
    static constexpr int kMaxLeafSize = 4;
    static constexpr int kBins = 16;

    BVH() = default;
    // Builds over `boxes`; primitives whose box is empty or non-finite are left out
    // (degenerate primitives can never be hit).
    explicit BVH(const std::vector<AABB>& boxes);

    const std::vector<BVHNode>& nodes() const { return nodes_; }
    const std::vector<uint32_t>& order() const { return order_; }
    int depth() const { return depth_; }

    // Visits primitives along the ray, nearest subtrees first. `test(prim, t_max)` returns
    // true and lowers t_max when the primitive is hit closer. Returns whether any hit; t_max
    // then holds the nearest hit distance.
    template <typename Test>
    bool traverse(const Ray& ray, double& t_max, Test&& test) const {
        if (nodes_.empty()) return false;
        const RayInv inv(ray);
        uint32_t stack[128];
        int top = 0;
        uint32_t node = 0;
        bool hit = false;
        for (;;) {
            const BVHNode& n = nodes_[node];
            if (slab_hit(n.box, inv, 0.0, t_max)) {
                if (n.count > 0) {
                    for (uint32_t i = 0; i < n.count; ++i)
                        if (test(order_[n.offset + i], t_max)) hit = true;
                    if (top == 0) break;
                    node = stack[--top];
                } else if (inv.neg[n.axis]) {  // visit the child nearer the ray first
                    stack[top++] = node + 1;
                    node = n.offset;
                } else {
                    stack[top++] = n.offset;
                    node = node + 1;
                }
            } else {
                if (top == 0) break;
                node = stack[--top];
            }
        }
        return hit;
    }

    // Any-hit query: stops at the first primitive for which `test(prim, t_max)` is true.
    template <typename Test>
    bool any_hit(const Ray& ray, double t_max, Test&& test) const {
        if (nodes_.empty()) return false;
        const RayInv inv(ray);
        uint32_t stack[128];
        int top = 0;
        uint32_t node = 0;
        for (;;) {
            const BVHNode& n = nodes_[node];
            if (slab_hit(n.box, inv, 0.0, t_max)) {
                if (n.count > 0) {
                    for (uint32_t i = 0; i < n.count; ++i)
                        if (test(order_[n.offset + i], t_max)) return true;
                    if (top == 0) return false;
                    node = stack[--top];
                } else {
                    stack[top++] = n.offset;
                    node = node + 1;
                }
            } else {
                if (top == 0) return false;
                node = stack[--top];
            }
        }
    }

private:
    struct BuildItem { AABB box; Vec3 centroid; uint32_t prim; };
    uint32_t build(std::vector<BuildItem>& items, uint32_t begin, uint32_t end, int depth);

    std::vector<BVHNode> nodes_;
    std::vector<uint32_t> order_;
    int depth_ = 0;
};

}  // namespace rt
