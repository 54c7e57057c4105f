#include "render.h"

#include <algorithm>

namespace rt {

namespace {

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

}  // namespace

void render_pixel(const Scene& scene, const Integrator& integrator, int x, int y, int spp, uint64_t seed,
                  const PixelSums& out, uint64_t& rays, uint64_t& nonfinite) {
    const Camera& cam = scene.camera();
    PCG32 rng = pixel_rng(seed, uint64_t(y) * uint64_t(cam.width) + uint64_t(x));
    double s[3] = {0, 0, 0}, s2[3] = {0, 0, 0};
    const bool tails = out.max != nullptr;
    TailSums t;
    for (int i = 0; i < spp; ++i) {
        // Box filter: the pixel value is the plain mean of samples jittered in the pixel.
        const double px = x + rng.next_double(), py = y + rng.next_double();
        const Vec3 L = integrator.Li(cam.generate(px, py), rng, rays);
        if (!is_finite(L)) {  // counted and reported; must stay 0 in every suite scene
            ++nonfinite;
            continue;
        }
        for (int c = 0; c < 3; ++c) {
            s[c] += L[c];
            s2[c] += L[c] * L[c];
        }
        if (tails) t.add(L);
    }
    for (int c = 0; c < 3; ++c) {
        out.sum[c] = s[c];
        out.sum_sq[c] = s2[c];
    }
    if (tails) t.write(out);
}

}  // namespace rt
