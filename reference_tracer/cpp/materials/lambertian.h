// Lambertian reflection, albedo / pi (Mitsuba `diffuse`). Reflects only into the
// hemisphere the viewer is in; the caller handles one-/two-sidedness.
#pragma once

#include "../mutants.h"
#include "../sampling/warp.h"
#include "bsdf_sample.h"

namespace rt::lambertian {

// f * cos and the density of sample() from the local z of wo and wi, on lanes of type F
// (one vertex, or a pack of the wavefront integrator's diffuse vertices): black, and density
// 0, unless both are above the surface. A NaN cosine is not rejected by eval_z (no
// comparison with NaN holds), as Vec3 code would not.
// M: a self-test mutant (mutants.h); Mutant::None is the tracer.
template <Mutant M = Mutant::None, typename F>
inline void eval_z(const F (&albedo)[3], F wo_z, F wi_z, F (&f)[3]) {
    const auto black = (wo_z <= 0.0) | (wi_z <= 0.0);
    F k;
    if constexpr (M == Mutant::MissingCosine)
        k = as_lanes(kInvPi, wi_z);  // seeded bug: f, not f * cos
    else
        k = kInvPi * wi_z;
    for (int c = 0; c < 3; ++c) f[c] = black ? F{} : albedo[c] * k;
}

template <Mutant M = Mutant::None, typename F>
inline F pdf_z(F wo_z, F wi_z) {
    const auto above = (wo_z > 0.0) & (wi_z > 0.0);
    if constexpr (M == Mutant::PdfOffByPi) return above ? wi_z : F{};  // seeded bug: no 1/pi
    return above ? cosine_hemisphere_pdf(wi_z) : F{};
}

template <Mutant M = Mutant::None>
inline Vec3 eval(const Vec3& albedo, const Vec3& wo, const Vec3& wi) {
    const double a[3] = {albedo.x, albedo.y, albedo.z};
    double f[3];
    eval_z<M>(a, wo.z, wi.z, f);
    return {f[0], f[1], f[2]};
}

template <Mutant M = Mutant::None>
inline double pdf(const Vec3& wo, const Vec3& wi) {
    return pdf_z<M>(wo.z, wi.z);
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
