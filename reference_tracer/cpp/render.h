// The render loop: image tiles handed to worker threads through an atomic counter.
// Every pixel owns its random stream, so the image does not depend on the thread count.
#pragma once

#include <atomic>
#include <cstdint>
#include <vector>

#include "integrator.h"

namespace rt {

struct RenderOutput {
    std::vector<double> sum, sum_sq;  // (H, W, 3): per-pixel sums of sample values and squares
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
    static constexpr int kTileSize = 16;
};

// Renders in worker threads; `poll` is called on the calling thread about every 50 ms with
// (pixels done, pixels total) and returns false to cancel. Returns when all workers have
// stopped.
template <typename Poll>
RenderOutput render(const RenderJob& job, Poll&& poll);

// The radiance samples of one pixel, accumulated into out[0..2] (sums) and out2 (squares).
void render_pixel(const Scene& scene, const Integrator& integrator, int x, int y, int spp, uint64_t seed,
                  double* sum, double* sum_sq, uint64_t& rays, uint64_t& nonfinite);

}  // namespace rt

#include "render_impl.h"
