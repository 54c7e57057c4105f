// Lambertian reflection, albedo / pi (Mitsuba `diffuse`). Reflects only into the
// hemisphere the viewer is in; the caller handles one-/two-sidedness.
#pragma once

#include "../mutants.h"
#include "../sampling/warp.h"
#include "bsdf_sample.h"

namespace rt::lambertian {

// M: a self-test mutant (mutants.h); Mutant::None is the tracer.
template <Mutant M = Mutant::None>
inline Vec3 eval(const Vec3& albedo, const Vec3& wo, const Vec3& wi) {
    if (wo.z <= 0.0 || wi.z <= 0.0) return Vec3(0.0);
    if constexpr (M == Mutant::MissingCosine) return albedo * kInvPi;  // seeded bug: f, not f * cos
    return albedo * (kInvPi * wi.z);  // f * cos
}

template <Mutant M = Mutant::None>
inline double pdf(const Vec3& wo, const Vec3& wi) {
    if constexpr (M == Mutant::PdfOffByPi) return (wo.z > 0.0 && wi.z > 0.0) ? wi.z : 0.0;  // seeded bug: no 1/pi
    return (wo.z > 0.0 && wi.z > 0.0) ? cosine_hemisphere_pdf(wi.z) : 0.0;
}

// sample() given its cosine-weighted direction wi (the wavefront integrator warps a pack
// of directions at once, then finishes each sample here).
template <Mutant M = Mutant::None>
inline BSDFSample sample_with(const Vec3& albedo, const Vec3& wo, const Vec3& wi) {
    BSDFSample s;
    if (wo.z <= 0.0) return s;
    s.wi = wi;
    if constexpr (M == Mutant::PdfOffByPi)
        s.pdf = pdf<M>(wo, s.wi);  // the same wrong density as pdf(): MIS weights stay consistent
    else
        s.pdf = cosine_hemisphere_pdf(s.wi.z);
    if (!(s.pdf > 0.0)) return s;
    s.weight = albedo;  // (albedo/pi * cos) / (cos/pi)
    s.valid = true;
    return s;
}

template <Mutant M = Mutant::None>
inline BSDFSample sample(const Vec3& albedo, const Vec3& wo, double u1, double u2) {
    return sample_with<M>(albedo, wo, square_to_cosine_hemisphere(u1, u2));
}

}  // namespace rt::lambertian
