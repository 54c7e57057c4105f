// Mirror (Mitsuba `conductor`: the albedo times the Fresnel reflectance, 1 for
// material='none', else that of a complex index eta + i k) and the book's fuzzy metal
// (reflection direction perturbed by fuzz times a random unit vector; absorbed if it
// points below the surface; Fresnel 1 only). Both are sampled like delta lobes: the fuzzy
// metal is defined by its sampling procedure and has no evaluable density.
#pragma once

#include "../sampling/warp.h"
#include "bsdf_sample.h"
#include "conductor_fresnel.h"

namespace rt::conductor {

inline BSDFSample sample(const Vec3& albedo, double fuzz, const ConductorFresnel& fresnel, const Vec3& wo,
                         double u1, double u2) {
    BSDFSample s;
    if (wo.z <= 0.0) return s;
    Vec3 wi(-wo.x, -wo.y, wo.z);
    if (fuzz > 0.0) {
        wi = normalize(normalize(wi) + fuzz * square_to_uniform_sphere(u1, u2));
        if (!(wi.z > 0.0)) return s;
    }
    s.wi = wi;
    s.weight = fresnel.enabled ? albedo * fresnel.eval(wo.z) : albedo;
    s.delta = true;
    s.valid = true;
    return s;
}

}  // namespace rt::conductor
