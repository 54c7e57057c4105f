// Smooth dielectric (Mitsuba `dielectric`, ext_ior 1): exact unpolarised Fresnel,
// reflection chosen with probability F, refraction otherwise. Transmitted radiance is
// scaled by (eta_i / eta_t)^2 as in Mitsuba's radiance transport mode; the relative
// index crossed is returned in `eta` for Russian roulette.
// Local frame: +z is the material's front (outside) normal; wo.z < 0 means inside.
#pragma once

#include "../mutants.h"
#include "bsdf_sample.h"

namespace rt::dielectric {

struct Fresnel {
    double F;          // reflectance
    double cos_t;      // |cos| of the transmitted direction (0 under total internal reflection)
    double eta_it;     // eta_t / eta_i for this side
    double eta_ti;     // 1 / eta_it
};

inline Fresnel fresnel(double cos_i, double eta) {
    Fresnel f{};
    f.eta_it = cos_i >= 0.0 ? eta : 1.0 / eta;
    f.eta_ti = 1.0 / f.eta_it;
    const double ci = std::abs(cos_i);
    const double cos_t2 = 1.0 - (1.0 - ci * ci) * f.eta_ti * f.eta_ti;
    if (cos_t2 <= 0.0) {  // total internal reflection
        f.F = 1.0;
        f.cos_t = 0.0;
        return f;
    }
    f.cos_t = std::sqrt(cos_t2);
    const double rs = (ci - f.eta_it * f.cos_t) / (ci + f.eta_it * f.cos_t);
    const double rp = (f.eta_it * ci - f.cos_t) / (f.eta_it * ci + f.cos_t);
    f.F = 0.5 * (rs * rs + rp * rp);
    return f;
}

// Schlick's approximation of F (the book's glass), R0 + (1 - R0)(1 - |cos_i|)^5; total
// internal reflection is kept exact. Selectable only to measure its bias.
inline double schlick(const Fresnel& exact, double cos_i, double eta) {
    if (exact.cos_t == 0.0) return 1.0;
    const double r0 = (1.0 - eta) / (1.0 + eta);
    const double m = 1.0 - std::abs(cos_i);
    return r0 * r0 + (1.0 - r0 * r0) * m * m * m * m * m;
}

template <Mutant M = Mutant::None>
inline BSDFSample sample(double ior, const Vec3& wo, double u1, bool use_schlick = false) {
    BSDFSample s;
    if (wo.z == 0.0) return s;
    Fresnel f = fresnel(wo.z, ior);
    if (use_schlick) f.F = schlick(f, wo.z, ior);
    s.delta = true;
    s.valid = true;
    if (u1 < f.F) {
        s.wi = Vec3(-wo.x, -wo.y, wo.z);
        s.weight = Vec3(1.0);
        s.eta = 1.0;
    } else {
        const double side = wo.z > 0.0 ? 1.0 : -1.0;
        s.wi = normalize(-f.eta_ti * wo + Vec3(0.0, 0.0, f.eta_ti * wo.z - side * f.cos_t));
        if constexpr (M == Mutant::GlassNoEtaScale)
            s.weight = Vec3(1.0);  // seeded bug: the radiance scale (eta_i / eta_t)^2 forgotten
        else
            s.weight = Vec3(f.eta_ti * f.eta_ti);
        s.eta = f.eta_it;
    }
    return s;
}

}  // namespace rt::dielectric
