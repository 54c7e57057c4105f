// The order in which a batch of rays is gathered into packets (Scene::intersect_stream).
//
// Rays arrive in the order the caller made them, and camera rays come in scanline order:
// pixel after pixel along a row, row after row. Sixteen consecutive rays are then a strip
// of 16 x 1 pixels. Its rays' boxes overlap less than those of a square of 4 x 4 pixels,
// so the packet visits more nodes and leaves for the same rays: at 1M triangles, where a
// camera ray meets about one triangle a pixel, camera rays in tiles of 4 x 4 ran 1.24x
// faster than in rows (2 threads; Embree's speed did not change with the order;
// PERFORMANCE.md, Ideas tried).
//
// PacketOrder finds the rows of such rays and gathers them into tiles, four rays wide and
// kPacketRays / 4 rows high. It reads only the rays, so the caller needs no image size,
// and it falls back on the rays' own order wherever it sees no rows. Only speed depends
// on the order: each ray's hit is the same in any packet (WideBVH::traverse_packet).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "math.h"
#include "wide_bvh.h"

namespace rt {

// How far apart two consecutive rays are: the largest change of a direction component,
// relative to the first direction's largest component, or of an origin component,
// relative to `origin_scale`. Along a row of camera rays it is about a pixel's angle; from
// one row's end to the next row's start it is the row's width in pixels.
inline double ray_step(const Ray& a, const Ray& b, double origin_scale) {
    const double d_scale = std::max({std::abs(a.d.x), std::abs(a.d.y), std::abs(a.d.z)});
    const double dd = std::max({std::abs(b.d.x - a.d.x), std::abs(b.d.y - a.d.y), std::abs(b.d.z - a.d.z)});
    const double od = std::max({std::abs(b.o.x - a.o.x), std::abs(b.o.y - a.o.y), std::abs(b.o.z - a.o.z)});
    const double step_o = od == 0.0 ? 0.0 : od / origin_scale;  // origin_scale 0: any move is infinite
    const double step = std::max(dd / d_scale, step_o);
    // NaN (a zero direction, or NaN in a ray) as infinitely far: the median below needs an
    // order, and such rays start no rows.
    return step >= 0.0 ? step : std::numeric_limits<double>::infinity();
}

class PacketOrder {
public:
    // Tiles this many rays wide (and kPacketRays / kTileWidth rows high).
    static constexpr int kTileWidth = 4;
    static constexpr int kTileRows = kPacketRays / kTileWidth;
    // A row is detected when the step from its last ray to the next row's first is at least
    // this many times the median step between the first rays of the batch.
    static constexpr double kRowJump = 8.0;
    // Rays whose median step exceeds this are not rows of an image (see find_rows).
    static constexpr double kMaxStep = 1.0 / 16.0;
    // A ray and the one below it in the next row are at most this many typical steps apart
    // (two, for pixels jittered by up to half a pixel).
    static constexpr double kRowStep = 3.0;

    // The order of rays ray_at(0 .. n-1). `coherent(indices, m)` says whether the rays
    // ray_at(indices[0 .. m)) may be one packet (Scene::coherent): tiles are made only where
    // some of the first rows' tiles are.
    template <typename RayAt, typename Coherent>
    PacketOrder(size_t n, RayAt&& ray_at, Coherent&& coherent, double origin_scale)
        : n_(n), rows_(find_rows(n, ray_at, coherent, origin_scale)) {
        if (rows_.width > 0) make_tiles();
    }

    // An image's rows among rays that come row after row: the rays in a row and the first
    // whole row's first ray; width 0 where the rays show no rows.
    struct Rows {
        size_t width = 0, first = 0;
    };
    // The rows of rays ray_at(0 .. n-1), as the constructor finds them. It reads the first
    // 32 rays, and of camera rays the first two or three rows.
    template <typename RayAt, typename Coherent>
    static Rows find_rows(size_t n, RayAt&& ray_at, Coherent&& coherent, double origin_scale);

    // The k-th ray to gather, as the caller's index.
    size_t operator[](size_t k) const { return order_.empty() ? k : order_[k]; }
    // The packets, as their numbers of rays (at most kPacketRays each), in order: packet j
    // holds the rays (*this)[sum of sizes before j ...].
    template <typename Visit>
    void for_each_packet(Visit&& visit) const {
        if (order_.empty()) {
            for (size_t k = 0; k < n_; k += kPacketRays) visit(k, static_cast<int>(std::min<size_t>(kPacketRays, n_ - k)));
            return;
        }
        size_t k = 0;
        for (uint8_t m : sizes_) {
            visit(k, static_cast<int>(m));
            k += m;
        }
    }
    // The rows found (Rows::width 0: none, the rays' own order).
    const Rows& rows() const { return rows_; }

private:
    // Rays before the first row and after the last band as they come, in packets of
    // kPacketRays; each band of kTileRows rows as tiles, left to right.
    void make_tiles();

    size_t n_;
    Rows rows_;
    std::vector<size_t> order_;   // empty: the rays' own order
    std::vector<uint8_t> sizes_;  // the packets' sizes, with order_
};

template <typename RayAt, typename Coherent>
PacketOrder::Rows PacketOrder::find_rows(size_t n, RayAt&& ray_at, Coherent&& coherent, double origin_scale) {
    constexpr size_t kSample = 32;  // steps whose median is a step along a row
    // At least one band of tile rows, and rows of at least two tiles.
    if (n < 2 * kSample || n < static_cast<size_t>(kTileRows) * 2 * kTileWidth) return {};
    double steps[kSample - 1];
    for (size_t i = 0; i + 1 < kSample; ++i) steps[i] = ray_step(ray_at(i), ray_at(i + 1), origin_scale);
    std::nth_element(steps, steps + (kSample - 1) / 2, steps + kSample - 1);
    const double typical = steps[(kSample - 1) / 2];
    // Identical rays pack in any order. Rays whose typical step exceeds kMaxStep (random
    // directions: about 1) leave here: a tile spans about three steps each way, and a
    // coherent packet's directions differ by at most half their largest component.
    if (!(typical > 0.0 && typical <= kMaxStep)) return {};
    // The first two jumps: the ends of the first (maybe partial) row and of the next.
    size_t jumps[2], found = 0;
    const size_t limit = n / kTileRows;  // a band of rows must fit after the first jump
    Ray prev = ray_at(0);
    for (size_t i = 0; i + 1 < n && i < limit + 1 && found < 2; ++i) {
        const Ray next = ray_at(i + 1);
        if (ray_step(prev, next, origin_scale) >= kRowJump * typical) jumps[found++] = i + 1;
        prev = next;
    }
    if (found < 2) return {};
    const size_t width = jumps[1] - jumps[0];
    if (width < 2 * kTileWidth) return {};
    // The first whole row: the batch may begin with a row's end.
    const size_t first = jumps[0] % width;
    if (first + kTileRows * width > n) return {};
    // Rows only where tiles hold together: up to four across each of the first two bands,
    // each coherent and the rays below its first no farther from it than kRowStep steps.
    // The rays of a 4 x 4 pixel tile, say, come in rows of four: sixteen tiles across
    // a 64-pixel image make "rows" of 256 whose neighbours are four pixels apart.
    size_t head[kPacketRays];
    const size_t stride = std::max<size_t>(kTileWidth, width / 4 / kTileWidth * kTileWidth);
    for (size_t b = first; b < first + 2 * kTileRows * width && b + kTileRows * width <= n; b += kTileRows * width) {
        for (size_t c = 0; c + kTileWidth <= width; c += stride) {
            for (int r = 0; r < kTileRows; ++r)
                for (int x = 0; x < kTileWidth; ++x) head[r * kTileWidth + x] = b + r * width + c + x;
            const bool near = ray_step(ray_at(head[0]), ray_at(head[kTileWidth]), origin_scale) <= kRowStep * typical;
            if (near && coherent(head, kPacketRays)) return {width, first};
        }
    }
    return {};
}

inline void PacketOrder::make_tiles() {
    order_.reserve(n_);
    auto as_they_come = [&](size_t begin, size_t end) {
        for (size_t k = begin; k < end; k += kPacketRays) {
            const size_t m = std::min<size_t>(kPacketRays, end - k);
            for (size_t i = k; i < k + m; ++i) order_.push_back(i);
            sizes_.push_back(static_cast<uint8_t>(m));
        }
    };
    as_they_come(0, rows_.first);
    const size_t band = kTileRows * rows_.width;
    size_t b = rows_.first;
    for (; b + band <= n_; b += band) {
        for (size_t c = 0; c < rows_.width; c += kTileWidth) {
            const size_t w = std::min<size_t>(kTileWidth, rows_.width - c);
            for (int r = 0; r < kTileRows; ++r)
                for (size_t x = 0; x < w; ++x) order_.push_back(b + r * rows_.width + c + x);
            sizes_.push_back(static_cast<uint8_t>(kTileRows * w));
        }
    }
    as_they_come(b, n_);
}

}  // namespace rt
