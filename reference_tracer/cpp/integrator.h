// The path integrator: one radiance estimate per camera ray, with the direction sampling
// strategy at non-specular bounces chosen per render (shared/DESIGN.md section 2).
#pragma once

#include <cstdint>

#include "rng.h"
#include "scene.h"

namespace rt {

enum class Strategy : int {
    Uniform = 0,  // uniform hemisphere, pdf 1/(2 pi); no light sampling
    Cosine = 1,   // the material's own sampling (cosine for Lambertian, visible GGX normals)
    Light = 2,    // toward emitters only: direct light at diffuse vertices; biased on purpose
    Mixture = 3,  // one direction from 0.5 light pdf + 0.5 material pdf
    MIS = 4,      // next-event estimation + material sampling, power heuristic (Mitsuba `path`)
};

class Integrator {
public:
    Integrator(const Scene& scene, Strategy strategy) : scene_(scene), strategy_(strategy) {}

    // Radiance arriving along `ray`; `rays` counts every ray cast (camera, continuation,
    // shadow/light rays).
    Vec3 Li(Ray ray, PCG32& rng, uint64_t& rays) const;

private:
    // Radiance along (o, wi) that comes straight from an emitter or the background: the
    // emission of the first surface hit (front side only), or the background on escape.
    Vec3 direct_emission(const Vec3& o, const Vec3& wi, uint64_t& rays) const;

    const Scene& scene_;
    Strategy strategy_;
};

}  // namespace rt
