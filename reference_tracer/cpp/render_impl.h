// Implementation of rt::render (a template over the poll callback).
#pragma once

#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <thread>

#include "threads.h"

namespace rt {

// The render loop of one instantiation of the integrator (M: see mutants.h).
template <Mutant M, typename Poll>
RenderOutput render_with(const RenderJob& job, Poll&& poll) {
    const Scene& scene = *job.scene;
    const Camera& cam = scene.camera();
    const int W = cam.width, H = cam.height, T = RenderJob::kTileSize;
    const int tiles_x = (W + T - 1) / T, tiles_y = (H + T - 1) / T;
    const int n_tiles = tiles_x * tiles_y;

    RenderOutput out;
    out.sum.assign(size_t(W) * H * 3, 0.0);
    out.sum_sq.assign(size_t(W) * H * 3, 0.0);
    TailMoments& tm = out.tails;
    if (job.moments)
        for (std::vector<double>* v : {&tm.d1, &tm.d2, &tm.d3, &tm.d4, &tm.max})
            v->assign(size_t(W) * H * 3, 0.0);

    const bool filtered = job.filter.kind != FilterKind::Box;
    if (filtered) out.filtered.assign(size_t(W) * H * 4, 0.0);
    const Integrator<M> integrator(scene, job.strategy, job.direct);
    std::atomic<int> next_tile{0};
    std::atomic<uint64_t> pixels_done{0}, rays{0}, nonfinite{0};
    std::atomic<bool> cancel{false};
    // A thread beyond the tiles would find no work.
    const int threads = std::max(1, std::min(job.threads, n_tiles));
    std::atomic<int> running{threads};
    std::mutex mutex;
    std::condition_variable finished;

    auto worker = [&](int) {
        uint64_t my_rays = 0, my_nonfinite = 0;
        bool scalar = true;
        // A filter splats across pixels: each worker into an image of its own, summed at the end.
        std::unique_ptr<SplatImage> splat = filtered ? std::make_unique<SplatImage>(W, H, job.filter) : nullptr;
        if constexpr (M == Mutant::None) {
            if (job.integrator == IntegratorKind::Wavefront && !filtered && !integrator.is_direct()) {
                scalar = false;
                TileCursor pixels(next_tile, W, H);
                render_wavefront(integrator, job, pixels, out, cancel, pixels_done, my_rays, my_nonfinite);
            }
        }
        for (int tile; scalar && !cancel.load(std::memory_order_relaxed) && (tile = next_tile.fetch_add(1)) < n_tiles;) {
            const int x0 = (tile % tiles_x) * T, y0 = (tile / tiles_x) * T;
            const int x1 = std::min(x0 + T, W), y1 = std::min(y0 + T, H);
            for (int y = y0; y < y1 && !cancel.load(std::memory_order_relaxed); ++y)
                for (int x = x0; x < x1; ++x) {
                    PixelSums px = pixel_sums(out, job.moments, W, x, y);
                    px.cancel = &cancel;
                    px.splat = splat.get();
                    render_pixel<M>(scene, integrator, x, y, job.spp, job.seed, px, my_rays, my_nonfinite);
                }
            pixels_done.fetch_add(uint64_t(x1 - x0) * (y1 - y0), std::memory_order_relaxed);
        }
        rays.fetch_add(my_rays);
        nonfinite.fetch_add(my_nonfinite);
        std::lock_guard<std::mutex> lock(mutex);
        if (splat) splat->add_to(out.filtered);
        if (--running == 0) finished.notify_all();
    };

    const auto t0 = std::chrono::steady_clock::now();
    std::vector<std::thread> pool;
    running -= threads - start_threads(pool, threads, worker);  // the threads refused finish at once
    const uint64_t total = uint64_t(W) * H;
    {
        std::unique_lock<std::mutex> lock(mutex);
        while (running > 0) {
            finished.wait_for(lock, std::chrono::milliseconds(50));
            if (running == 0) break;
            lock.unlock();
            const bool keep_going = poll(pixels_done.load(), total);
            lock.lock();
            if (!keep_going) { cancel = true; out.cancelled = true; }
        }
    }
    for (std::thread& t : pool) t.join();
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    out.rays = rays.load();
    out.nonfinite = nonfinite.load();
    return out;
}

// A render by the tracer.
template <typename Poll>
RenderOutput render(const RenderJob& job, Poll&& poll) {
    return render_with<Mutant::None>(job, poll);
}

// A render with seeded bug `mutant` (None: the tracer), the instantiation chosen once per
// render. Only the self-test's module (reference_tracer._mutants, built with mutants.cpp)
// calls it; the tracer's module contains no mutant code.
template <typename Poll>
RenderOutput render_mutant(const RenderJob& job, Mutant mutant, Poll&& poll) {
    return dispatch_mutant(mutant, [&](auto tag) { return render_with<decltype(tag)::value>(job, poll); });
}

}  // namespace rt
