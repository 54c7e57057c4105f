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

// Which binary interior nodes become wide nodes. A ray meets a box with a probability
// proportional to its surface area (rays uniform in direction and position), so a wide
// tree's expected node visits are the summed areas of the binary nodes chosen as wide
// nodes; every binary leaf is a leaf slot of some wide node whatever the choice, so leaf
// costs do not enter. Dynamic programming over the binary tree (after Ylitie, Karras and
// Laine 2017, "Efficient incoherent ray traversal on GPUs through compressed wide BVHs",
// with the binary tree's leaves kept): cost(n, i) is the least summed area of the wide
// nodes inside n's subtree when n's subtree fills at most i slots of its parent, either as
// one slot (a leaf, or a wide node of its own: area(n) plus its children spread over
// kWidth slots) or opened, its two children sharing the i slots. A greedy collapse (open
// the largest child until eight) leaves nodes 4.1-5.1 children full on the ray
// benchmark's tori; this one fills 6.1 of 8, with 20-29% fewer nodes (PERFORMANCE.md,
// Ideas tried).
class WideBVH::CollapsePlan {
public:
    explicit CollapsePlan(const BVH& binary)
        : bn_(binary.nodes()), cost_(bn_.size() * kWidth), split_(bn_.size() * kWidth) {
        // Children follow their parent in the depth-first array: visit parents last.
        for (size_t n = bn_.size(); n-- > 0;) {
            if (bn_[n].count > 0) {
                for (int i = 1; i <= kWidth; ++i) set(n, i, 0.0, 0);
                continue;
            }
            const uint32_t left = static_cast<uint32_t>(n) + 1, right = bn_[n].offset;
            double shared[kWidth + 1];
            uint8_t shared_k[kWidth + 1];
            for (int i = 2; i <= kWidth; ++i) {
                // A split is defined even if every cost were infinite or NaN (areas
                // cannot overflow for the coordinates the API accepts, |x| <= 1e30).
                shared[i] = std::numeric_limits<double>::infinity();
                shared_k[i] = 1;
                for (int k = 1; k < i; ++k) {
                    const double c = cost(left, k) + cost(right, i - k);
                    if (c < shared[i]) { shared[i] = c; shared_k[i] = static_cast<uint8_t>(k); }
                }
            }
            const double own = bn_[n].box.surface_area() + shared[kWidth];
            set(n, 1, own, 0);
            root_k(n) = shared_k[kWidth];
            // Opened when that costs no more: ties go to fewer nodes.
            for (int i = 2; i <= kWidth; ++i)
                shared[i] <= own ? set(n, i, shared[i], shared_k[i]) : set(n, i, own, 0);
        }
    }
    // The binary nodes filling the slots of the wide node made of binary node `node`.
    int slots(uint32_t node, uint32_t (&out)[kWidth]) const {
        int k = 0;
        const uint8_t split = root_k(node);
        spread(node + 1, split, out, k);
        spread(bn_[node].offset, kWidth - split, out, k);
        return k;
    }

private:
    double cost(size_t n, int i) const { return cost_[n * kWidth + (i - 1)]; }
    void set(size_t n, int i, double c, uint8_t k) {
        cost_[n * kWidth + (i - 1)] = c;
        split_[n * kWidth + (i - 1)] = k;
    }
    // split_[n][0] is unused by cost(n, 1) (one slot is never split): it holds the split
    // of n's children over the kWidth slots of n as a wide node.
    uint8_t& root_k(size_t n) { return split_[n * kWidth]; }
    uint8_t root_k(size_t n) const { return split_[n * kWidth]; }
    void spread(uint32_t n, int i, uint32_t (&out)[kWidth], int& k) const {
        const uint8_t split = i == 1 ? 0 : split_[n * kWidth + (i - 1)];
        if (bn_[n].count > 0 || split == 0) {
            out[k++] = n;
            return;
        }
        spread(n + 1, split, out, k);
        spread(bn_[n].offset, i - split, out, k);
    }

    const std::vector<BVHNode>& bn_;
    std::vector<double> cost_;
    std::vector<uint8_t> split_;
};

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
    const CollapsePlan plan(binary);
    collapse(binary, plan, 0, 1, packable);
}

int32_t WideBVH::collapse(const BVH& binary, const CollapsePlan& plan, uint32_t node, int depth,
                          const std::function<bool(uint32_t)>& packable) {
    const auto& bn = binary.nodes();
    depth_ = std::max(depth_, depth);
    uint32_t kids[kWidth];
    const int k = plan.slots(node, kids);
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
            child = collapse(binary, plan, kids[i], depth + 1, packable);  // may reallocate nodes_
        }
        WideNode& n = nodes_[index];
        for (int a = 0; a < 3; ++a) { n.lo[a][i] = round_down_float(c.box.lo[a]); n.hi[a][i] = round_up_float(c.box.hi[a]); }
        n.child[i] = child;
        n.count[i] = count;
    }
    return index;
}

}  // namespace rt
