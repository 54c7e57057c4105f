#include "render.h"

namespace rt {

void render_pixel(const Scene& scene, const Integrator& integrator, int x, int y, int spp, uint64_t seed,
                  double* sum, double* sum_sq, uint64_t& rays, uint64_t& nonfinite) {
    const Camera& cam = scene.camera();
    PCG32 rng = pixel_rng(seed, uint64_t(y) * uint64_t(cam.width) + uint64_t(x));
    double s[3] = {0, 0, 0}, s2[3] = {0, 0, 0};
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
    }
    for (int c = 0; c < 3; ++c) {
        sum[c] = s[c];
        sum_sq[c] = s2[c];
    }
}

}  // namespace rt
