#include "wide_bvh.h"

#include <cmath>

namespace rt {

namespace {

void set_empty(WideNode& n, int i) {
    for (int a = 0; a < 3; ++a) {
        n.lo[a][i] = std::numeric_limits<float>::infinity();
        n.hi[a][i] = -std::numeric_limits<float>::infinity();
    }
    n.child[i] = 0;
    n.count[i] = 0;
}

}  // namespace

void WideBVH::make_leaf(const BVHNode& leaf, const std::function<bool(uint32_t)>& packable, int32_t& child,
                        uint16_t& count) {
    bool pack = true;
    for (uint32_t i = 0; i < leaf.count; ++i) pack = pack && packable(order_[leaf.offset + i]);
    if (pack) {
        child = ~static_cast<int32_t>(blocks_.size());
        blocks_.push_back({leaf.offset, leaf.count});
        count = static_cast<uint16_t>(leaf.count | kBlockLeaf);
    } else {
        child = ~static_cast<int32_t>(leaf.offset);
        count = leaf.count;
    }
}

void WideBVH::build(const BVH& binary, const std::function<bool(uint32_t)>& packable) {
    const auto& bn = binary.nodes();
    if (bn.empty()) return;
    nodes_.reserve(bn.size() / 2 + 1);
    if (bn[0].count > 0) {  // a single leaf: one node with one leaf child
        nodes_.emplace_back();
        WideNode& n = nodes_[0];
        for (int i = 0; i < kWidth; ++i) set_empty(n, i);
        for (int a = 0; a < 3; ++a) { n.lo[a][0] = round_down_float(bn[0].box.lo[a]); n.hi[a][0] = round_up_float(bn[0].box.hi[a]); }
        make_leaf(bn[0], packable, n.child[0], n.count[0]);
        depth_ = 1;
        return;
    }
    collapse(binary, 0, 1, packable);
}

int32_t WideBVH::collapse(const BVH& binary, uint32_t node, int depth, const std::function<bool(uint32_t)>& packable) {
    const auto& bn = binary.nodes();
    depth_ = std::max(depth_, depth);
    // Open the largest interior child until there are kWidth (greedy by surface area:
    // the children most likely to be hit are the ones worth testing together).
    uint32_t kids[kWidth] = {node + 1, bn[node].offset};
    int k = 2;
    while (k < kWidth) {
        int best = -1;
        double best_area = -1.0;
        for (int i = 0; i < k; ++i) {
            const BVHNode& c = bn[kids[i]];
            if (c.count == 0 && c.box.surface_area() > best_area) { best_area = c.box.surface_area(); best = i; }
        }
        if (best < 0) break;
        const uint32_t opened = kids[best];
        kids[best] = opened + 1;
        kids[k++] = bn[opened].offset;
    }
    const int32_t index = static_cast<int32_t>(nodes_.size());
    nodes_.emplace_back();
    for (int i = 0; i < kWidth; ++i) set_empty(nodes_[index], i);
    for (int i = 0; i < k; ++i) {
        const BVHNode& c = bn[kids[i]];
        int32_t child;
        uint16_t count = 0;
        if (c.count > 0) {
            make_leaf(c, packable, child, count);
        } else {
            child = collapse(binary, kids[i], depth + 1, packable);  // may reallocate nodes_
        }
        WideNode& n = nodes_[index];
        for (int a = 0; a < 3; ++a) { n.lo[a][i] = round_down_float(c.box.lo[a]); n.hi[a][i] = round_up_float(c.box.hi[a]); }
        n.child[i] = child;
        n.count[i] = count;
    }
    return index;
}

}  // namespace rt
