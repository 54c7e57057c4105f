// The render loop: image tiles handed to worker threads through an atomic counter.
// Every pixel owns its random stream, so the image does not depend on the thread count.
#pragma once

#include <atomic>
#include <cstdint>
#include <vector>

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
    TailMoments tails;                // empty unless the job asked for moments
    uint64_t rays = 0;
    uint64_t nonfinite = 0;           // samples discarded because a channel was NaN or Inf
    double seconds = 0.0;
    bool cancelled = false;
};

struct RenderJob {
    const Scene* scene = nullptr;
    Strategy strategy = Strategy::MIS;
    int spp = 1;
    uint64_t seed = 0;
    int threads = 1;
    bool moments = false;             // also accumulate TailMoments (a few flops per sample)
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
    const std::atomic<bool>* cancel = nullptr;
    static constexpr int kCancelPollSamples = 256;
};

// The radiance samples of one pixel, accumulated into `out` (M: see mutants.h). Defined in
// render_pixel.h: the tracer's instantiation in render.cpp, the mutants' in mutants.cpp.
template <Mutant M>
void render_pixel(const Scene& scene, const Integrator<M>& integrator, int x, int y, int spp, uint64_t seed,
                  const PixelSums& out, uint64_t& rays, uint64_t& nonfinite);
extern template void render_pixel<Mutant::None>(const Scene&, const Integrator<Mutant::None>&, int, int, int,
                                                 uint64_t, const PixelSums&, uint64_t&, uint64_t&);

}  // namespace rt

#include "render_impl.h"
