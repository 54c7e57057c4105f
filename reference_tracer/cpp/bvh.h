// Bounding volume hierarchy over primitive bounding boxes, built with a binned surface
// area heuristic (Wald 2007) and stored as a flat, depth-first node array: the left
// child of an interior node follows it, the right child is at `offset`. It is the build
// stage only: rays traverse the 8-wide tree collapsed from it (wide_bvh.h).
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "aabb.h"

namespace rt {

struct BVHNode {
    AABB box;
    uint32_t offset = 0;  // leaf: first index into BVH::order; interior: right child
    uint16_t count = 0;   // primitives in a leaf; 0 for interior nodes
};

class BVH {
public:
    static constexpr int kMaxLeafSize = 4;
    static constexpr int kBins = 32;
    // SAH cost of testing one block of up to kMaxLeafSize packable primitives at once,
    // relative to one node traversal (and to one test of an unpacked primitive).
    static constexpr double kBlockCost = 2.0;

    BVH() = default;
    // Builds over `boxes`; primitives whose box is empty or non-finite are left out
    // (degenerate primitives can never be hit). `packable(prim)` says whether the
    // primitive goes into the SoA blocks that a leaf tests all at once (wide_bvh.h):
    // ranges made only of such primitives are costed per block, not per primitive, so
    // the SAH fills leaves instead of splitting them down to single triangles.
    explicit BVH(const std::vector<AABB>& boxes, const std::function<bool(uint32_t)>& packable = {});

    const std::vector<BVHNode>& nodes() const { return nodes_; }
    const std::vector<uint32_t>& order() const { return order_; }
    int depth() const { return depth_; }

private:
    struct BuildItem { AABB box; Vec3 centroid; uint32_t prim; bool packable; };
    uint32_t build(std::vector<BuildItem>& items, uint32_t begin, uint32_t end, int depth);

    std::vector<BVHNode> nodes_;
    std::vector<uint32_t> order_;
    int depth_ = 0;
};

}  // namespace rt
