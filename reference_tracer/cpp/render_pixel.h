// Definition of rt::render_pixel<M> (render.h), included by render.cpp (the tracer,
// Mutant::None) and mutants.cpp (the self-test's seeded bugs).
#pragma once

#include <algorithm>

#include "render.h"

namespace rt {

namespace detail {

// Power sums about a shift, per channel: the tail diagnostics of one pixel.
struct TailSums {
    bool started = false;
    double shift[3] = {0, 0, 0}, d[4][3] = {}, max[3] = {-kInf, -kInf, -kInf};

    void add(const Vec3& L) {
        if (!started) {
            started = true;
            for (int c = 0; c < 3; ++c) shift[c] = L[c];
        }
        for (int c = 0; c < 3; ++c) {
            const double v = L[c] - shift[c], v2 = v * v;
            d[0][c] += v;
            d[1][c] += v2;
            d[2][c] += v2 * v;
            d[3][c] += v2 * v2;
            max[c] = std::max(max[c], L[c]);
        }
    }

    void write(const PixelSums& out) const {
        for (int c = 0; c < 3; ++c) {
            for (int k = 0; k < 4; ++k) out.d[k][c] = d[k][c];
            out.max[c] = started ? max[c] : 0.0;
        }
    }
};

}  // namespace detail

template <Mutant M>
void render_pixel(const Scene& scene, const Integrator<M>& integrator, int x, int y, int spp, uint64_t seed,
                  const PixelSums& out, uint64_t& rays, uint64_t& nonfinite) {
    const Camera& cam = scene.camera();
    // (Mutant::CorrelatedPixelStreams: the pixel index forgotten, every pixel the same stream.)
    const uint64_t pixel_index =
        M == Mutant::CorrelatedPixelStreams ? 0 : uint64_t(y) * uint64_t(cam.width) + uint64_t(x);
    PCG64 rng = pixel_rng(seed, pixel_index);
    double s[3] = {0, 0, 0}, s2[3] = {0, 0, 0};
    const bool tails = out.max != nullptr;
    detail::TailSums t;
    // Samples in chunks of kCancelPollSamples, the cancel flag polled between chunks: no
    // cost per sample, and a pixel of a huge spp still stops soon after Ctrl-C.
    // (64-bit chunk index: spp may be INT_MAX.)
    for (int64_t chunk = 0; chunk < spp; chunk += PixelSums::kCancelPollSamples) {
        if (chunk > 0 && out.cancel && out.cancel->load(std::memory_order_relaxed))
            return;  // cancelled: the render's image is discarded
        const int chunk_end = int(std::min<int64_t>(spp, chunk + PixelSums::kCancelPollSamples));
        for (int i = int(chunk); i < chunk_end; ++i) {
            // Box filter: the pixel value is the plain mean of samples jittered in the pixel.
            double px = x + rng.next_double(), py = y + rng.next_double();
            if constexpr (M == Mutant::HalfPixelJitter) {  // seeded bug: centred on the pixel's corner
                px -= 0.5;
                py -= 0.5;
            }
            // A thin lens's aperture point: two numbers more, drawn only for it (the pinhole's
            // stream of numbers, and so its images, stay as they were).
            double lens[2] = {0.0, 0.0};
            if (cam.thin_lens()) {
                lens[0] = rng.next_double();
                lens[1] = rng.next_double();
            }
            double reach;
            const Ray ray = cam.generate(px, py, lens, reach);
            const Vec3 L = integrator.Li(ray, rng, rays, reach);
            if (!is_finite(L)) {  // counted and reported; must stay 0 in every suite scene
                ++nonfinite;
                continue;
            }
            // A reconstruction filter: the sample also goes to the pixels it covers. The plain
            // sums below stay: the per-sample moments of the samples drawn in this pixel are
            // what the statistics of a filtered pixel are computed from.
            if (out.splat) out.splat->add(px, py, L);
            for (int c = 0; c < 3; ++c) {
                s[c] += L[c];
                s2[c] += L[c] * L[c];
            }
            if (tails) t.add(L);
        }
    }
    for (int c = 0; c < 3; ++c) {
        out.sum[c] = s[c];
        out.sum_sq[c] = s2[c];
    }
    if (tails) t.write(out);
}

}  // namespace rt
