// The render loop: image tiles handed to worker threads through an atomic counter.
// Every pixel owns its random stream, so the image does not depend on the thread count.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <vector>

#include "film_filter.h"
#include "integrator.h"

namespace rt {

// Optional per-pixel tail diagnostics (RenderJob::moments). Power sums of the samples about
// a per-pixel shift (the pixel's first finite sample) give the central moments up to the
// fourth without the cancellation raw power sums suffer where the mean dwarfs the spread;
// the largest sample shows how much one rare path dominates. The statistics of the
// harness need them to tell "rare paths not sampled yet" from bias.
struct TailMoments {
    std::vector<double> d1, d2, d3, d4, max;  // (H, W, 3) each
};

struct RenderOutput {
    std::vector<double> sum, sum_sq;  // (H, W, 3): per-pixel sums of sample values and squares
    std::vector<double> filtered;     // (H, W, 4): weighted radiance and weight sums (a non-box filter)
    TailMoments tails;                // empty unless the job asked for moments
    uint64_t rays = 0;
    uint64_t nonfinite = 0;           // samples discarded because a channel was NaN or Inf
    double seconds = 0.0;
    bool cancelled = false;
};

// Which integrator runs the paths: both compute the same samples from the same random
// streams, so their images agree bit for bit (up to which of two primitives at exactly
// the same distance counts as hit).
enum class IntegratorKind : int {
    Wavefront = 0,  // batches of paths, intersection queries batched (wavefront.h)
    Scalar = 1,     // one path at a time (Integrator::Li): the reference implementation
};

struct RenderJob {
    const Scene* scene = nullptr;
    IntegratorKind integrator = IntegratorKind::Wavefront;
    Strategy strategy = Strategy::MIS;
    int spp = 1;
    uint64_t seed = 0;
    int threads = 1;
    bool moments = false;             // also accumulate TailMoments (a few flops per sample)
    PixelFilter filter;               // box: per-pixel sums; else splats into RenderOutput::filtered
    DirectCounts direct;              // Mitsuba's `direct` (scalar steps only); none: `path`
    static constexpr int kTileSize = 16;
};

// Renders in worker threads; `poll` is called on the calling thread about every 50 ms with
// (pixels done, pixels total) and returns false to cancel. Returns when all workers have
// stopped.
template <typename Poll>
RenderOutput render(const RenderJob& job, Poll&& poll);

// Where render_pixel writes one pixel's results: three channels at each pointer; the tail
// pointers are null when the job did not ask for moments. `cancel` (when set) is polled
// every kCancelPollSamples samples: a pixel of a huge spp stops soon after Ctrl-C, its
// sums left unwritten (a cancelled render's image is discarded).
struct PixelSums {
    double* sum;
    double* sum_sq;
    double* d[4] = {nullptr, nullptr, nullptr, nullptr};
    double* max = nullptr;
    SplatImage* splat = nullptr;  // a non-box filter: samples go here, not into the sums
    const std::atomic<bool>* cancel = nullptr;
    static constexpr int kCancelPollSamples = 256;
};

// The outputs of pixel (x, y) of a W-wide image.
inline PixelSums pixel_sums(RenderOutput& out, bool moments, int W, int x, int y) {
    const size_t k = (size_t(y) * W + x) * 3;
    PixelSums px{&out.sum[k], &out.sum_sq[k]};
    if (moments) {
        TailMoments& tm = out.tails;
        px.d[0] = &tm.d1[k];
        px.d[1] = &tm.d2[k];
        px.d[2] = &tm.d3[k];
        px.d[3] = &tm.d4[k];
        px.max = &tm.max[k];
    }
    return px;
}

// The image's pixels in tiles of kTileSize^2, tiles handed to workers through a shared
// counter (one cursor per worker): the order in which the wavefront integrator's lanes
// take pixels.
class TileCursor {
public:
    TileCursor(std::atomic<int>& next_tile, int width, int height)
        : next_tile_(next_tile), W_(width), H_(height),
          tiles_x_((width + RenderJob::kTileSize - 1) / RenderJob::kTileSize),
          n_tiles_(tiles_x_ * ((height + RenderJob::kTileSize - 1) / RenderJob::kTileSize)) {}

    // The next pixel of this worker's tile, or of a new tile; false when none is left.
    bool next(int& x, int& y) {
        if (x_ >= x1_) {
            x_ = x0_;
            ++y_;
        }
        if (y_ >= y1_) {
            const int tile = next_tile_.fetch_add(1);
            if (tile >= n_tiles_) return false;
            constexpr int T = RenderJob::kTileSize;
            x0_ = (tile % tiles_x_) * T;
            y_ = (tile / tiles_x_) * T;
            x1_ = std::min(x0_ + T, W_);
            y1_ = std::min(y_ + T, H_);
            x_ = x0_;
        }
        x = x_++;
        y = y_;
        return true;
    }

private:
    std::atomic<int>& next_tile_;
    int W_, H_, tiles_x_, n_tiles_;
    int x0_ = 0, x1_ = 0, y1_ = 0, x_ = 0, y_ = 0;
};

// The radiance samples of one pixel, accumulated into `out` (M: see mutants.h). Defined in
// render_pixel.h: the tracer's instantiation in render.cpp, the mutants' in mutants.cpp.
template <Mutant M>
void render_pixel(const Scene& scene, const Integrator<M>& integrator, int x, int y, int spp, uint64_t seed,
                  const PixelSums& out, uint64_t& rays, uint64_t& nonfinite);
extern template void render_pixel<Mutant::None>(const Scene&, const Integrator<Mutant::None>&, int, int, int,
                                                 uint64_t, const PixelSums&, uint64_t&, uint64_t&);

// The wavefront integrator's share of a render, for one worker (wavefront.h; defined in
// wavefront.cpp): renders the pixels `pixels` hands out, as render_pixel would each.
void render_wavefront(const Integrator<Mutant::None>& integrator, const RenderJob& job, TileCursor& pixels,
                      RenderOutput& out, const std::atomic<bool>& cancel, std::atomic<uint64_t>& pixels_done,
                      uint64_t& rays, uint64_t& nonfinite);

}  // namespace rt

#include "render_impl.h"
