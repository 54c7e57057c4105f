#include "bvh.h"

#include <algorithm>

namespace rt {

BVH::BVH(const std::vector<AABB>& boxes, const std::function<bool(uint32_t)>& packable) {
    std::vector<BuildItem> items;
    items.reserve(boxes.size());
    for (uint32_t i = 0; i < boxes.size(); ++i) {
        const AABB& b = boxes[i];
        if (!b.valid() || !is_finite(b.lo) || !is_finite(b.hi)) continue;
        items.push_back({b, b.centroid(), i, packable && packable(i)});
    }
    if (items.empty()) return;
    nodes_.reserve(2 * items.size() / kMaxLeafSize + 1);
    order_.reserve(items.size());
    build(items, 0, static_cast<uint32_t>(items.size()), 1);
}

uint32_t BVH::build(std::vector<BuildItem>& items, uint32_t begin, uint32_t end, int depth) {
    depth_ = std::max(depth_, depth);
    const uint32_t index = static_cast<uint32_t>(nodes_.size());
    nodes_.emplace_back();
    AABB box, centroids;
    bool all_packable = true;
    for (uint32_t i = begin; i < end; ++i) {
        box.expand(items[i].box);
        centroids.expand(items[i].centroid);
        all_packable = all_packable && items[i].packable;
    }
    nodes_[index].box = box;
    const uint32_t count = end - begin;

    auto make_leaf = [&]() {
        nodes_[index].offset = static_cast<uint32_t>(order_.size());
        nodes_[index].count = static_cast<uint16_t>(count);
        for (uint32_t i = begin; i < end; ++i) order_.push_back(items[i].prim);
        return index;
    };
    if (count <= 1) return make_leaf();

    // Binned SAH over all three axes (the best split of any axis). Binning only the
    // axis of largest centroid extent misses the better split where the primitives'
    // boxes, not their centroids, decide (tubes, slanted surfaces): every ray pays for
    // the worse tree, the build only for binning three axes instead of one.
    const int longest = centroids.longest_axis();
    int axis = longest;
    uint32_t mid = begin;
    bool split_found = false;
    struct Bin { AABB box; uint32_t count = 0; };
    // Bin index scale per axis (0 where the centroids do not spread: that axis is skipped).
    double scale[3];
    for (int a = 0; a < 3; ++a) {
        const double extent = centroids.hi[a] - centroids.lo[a];
        scale[a] = extent > 0.0 && depth < 64 ? kBins / extent : 0.0;
    }
    auto bin_of = [&](const BuildItem& it, int a) {
        const int b = static_cast<int>((it.centroid[a] - centroids.lo[a]) * scale[a]);
        return std::clamp(b, 0, kBins - 1);
    };
    // Cost of n primitives in a leaf: n tests, or one test per block of up to
    // kMaxLeafSize when they are all packable (Embree's SAH rounds the same way).
    auto leaf_cost = [&](uint32_t n) {
        return all_packable ? kBlockCost * double((n + kMaxLeafSize - 1) / kMaxLeafSize) : double(n);
    };
    // One pass over the primitives bins all three axes.
    Bin bins[3][kBins];
    if (scale[0] > 0.0 || scale[1] > 0.0 || scale[2] > 0.0) {
        for (uint32_t i = begin; i < end; ++i)
            for (int a = 0; a < 3; ++a) {
                Bin& b = bins[a][bin_of(items[i], a)];
                b.box.expand(items[i].box);
                ++b.count;
            }
    }
    double best_cost = kInf;
    int best_split = -1;
    // Past depth 64 only median splits (scale 0): the traversal stack can never overflow.
    for (int a = 0; a < 3; ++a) {
        if (!(scale[a] > 0.0)) continue;
        // Sweep from the right to get the area and count of every right-hand side.
        double right_area[kBins];
        uint32_t right_count[kBins];
        AABB acc;
        uint32_t n = 0;
        for (int i = kBins - 1; i > 0; --i) {
            acc.expand(bins[a][i].box);
            n += bins[a][i].count;
            right_area[i] = acc.surface_area();
            right_count[i] = n;
        }
        acc = AABB();
        n = 0;
        for (int i = 0; i < kBins - 1; ++i) {
            acc.expand(bins[a][i].box);
            n += bins[a][i].count;
            if (n == 0 || right_count[i + 1] == 0) continue;
            const double cost = leaf_cost(n) * acc.surface_area() + leaf_cost(right_count[i + 1]) * right_area[i + 1];
            // Strictly better only: ties keep the earlier axis (deterministic builds).
            if (cost < best_cost) { best_cost = cost; best_split = i; axis = a; }
        }
    }
    if (best_split >= 0) {
        const double parent_area = box.surface_area();
        // Traversal cost 1 relative to one intersection; areas relative to the parent's.
        const double split_cost = parent_area > 0.0 ? 1.0 + best_cost / parent_area : kInf;
        if (count > kMaxLeafSize || split_cost < leaf_cost(count)) {
            auto it = std::partition(items.begin() + begin, items.begin() + end,
                                     [&](const BuildItem& x) { return bin_of(x, axis) <= best_split; });
            mid = static_cast<uint32_t>(it - items.begin());
            split_found = mid > begin && mid < end;
        } else {
            return make_leaf();
        }
    }
    if (!split_found) {
        if (count <= kMaxLeafSize) return make_leaf();
        // Coincident centroids (or no useful SAH split): split by count so leaves stay
        // small and the build stays O(n log n) for any input.
        mid = begin + count / 2;
        std::nth_element(items.begin() + begin, items.begin() + mid, items.begin() + end,
                         [&](const BuildItem& a, const BuildItem& b) { return a.centroid[longest] < b.centroid[longest]; });
    }
    build(items, begin, mid, depth + 1);
    const uint32_t right = build(items, mid, end, depth + 1);
    nodes_[index].offset = right;
    return index;
}

}  // namespace rt
