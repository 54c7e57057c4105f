// Microfacet dielectric (Mitsuba `roughdielectric`, Walter et al. 2007): a rough interface
// of relative index eta = int_ior / ext_ior that reflects and refracts through microfacets
// of an isotropic GGX or Beckmann distribution. The distribution's D, masking G1 and
// visible-normal sampling are the rough conductor's (rough_conductor.h, microfacet.h).
//
// Local frame as the smooth dielectric's: +z is the material's front (outside) normal and
// wo.z < 0 means the path arrives from inside; both lobes have a density, so the integrator
// samples lights at the vertex, on either side of the surface.
//
// A sample picks a visible normal m for wo flipped to the outside hemisphere, then
// reflection with probability F(wo.m) (the Fresnel reflectance of that microfacet), else
// refraction through m. Its density is that of the visible normals, D G1(wo, m) |wo.m| /
// |cos_o|, times the lobe's probability and the Jacobian of the half-vector map. Radiance
// transport scales refracted radiance by (eta_i / eta_t)^2, as the smooth dielectric does
// and as Mitsuba does in its radiance mode.
#pragma once

#include "bsdf_sample.h"
#include "dielectric.h"
#include "microfacet.h"
#include "rough_conductor.h"

namespace rt::rough_dielectric {

struct Params {
    double alpha = 0.1;
    Distribution distribution = Distribution::Beckmann;
    double eta = 1.5;  // int_ior / ext_ior

    rough_conductor::Params microfacet() const { return {alpha, distribution, {}}; }
};

// v, negated where z < 0 (Mitsuba's mulsign(v, z)): wo as seen from the outside hemisphere,
// or a half vector turned into it.
inline Vec3 upper(const Vec3& v, double z) { return z < 0.0 ? -v : v; }

// What eval and pdf share: the half vector of (wo, wi) in the outside hemisphere and the
// index ratio eta_t / eta_i seen from wo's side. `valid` is false for exact grazing or a
// degenerate half vector (wo = -eta wi).
struct Half {
    Vec3 m;
    double eta = 1.0;
    bool reflect = false;
    bool valid = false;
};

inline Half half(const Params& p, const Vec3& wo, const Vec3& wi) {
    Half h;
    if (wo.z == 0.0) return h;  // Mitsuba ignores perfectly grazing configurations
    h.reflect = wo.z * wi.z > 0.0;
    h.eta = wo.z > 0.0 ? p.eta : 1.0 / p.eta;
    const Vec3 sum = wo + wi * (h.reflect ? 1.0 : h.eta);
    const double len2 = dot(sum, sum);
    if (!(len2 > 0.0)) return h;
    const Vec3 m = sum / std::sqrt(len2);
    h.m = upper(m, m.z);
    h.valid = true;
    return h;
}

// The density of the visible normals m of wo: D(m) G1(wo, m) |wo.m| / |cos_o|, wo seen
// from outside. Beckmann's G1 is the exact masking of the normals microfacet.h samples
// (rough_conductor::pdf says why: Mitsuba divides by its approximate one).
inline double visible_pdf(const Params& p, const Vec3& wo, const Vec3& m) {
    const rough_conductor::Params mf = p.microfacet();
    const Vec3 v = upper(wo, wo.z);
    const double g1 = p.distribution == Distribution::GGX ? rough_conductor::smith_g1(v, m, p.alpha)
                                                          : microfacet::beckmann_g1_exact(v, m, p.alpha);
    return rough_conductor::d(mf, m) * g1 * std::abs(dot(v, m)) / v.z;
}

// f * |cos_i| (cos_i = wi.z), Mitsuba's eval: reflection F D G / (4 |cos_o|); refraction
// (1 - F) D G eta^2 |wo.m| |wi.m| / (|cos_o| (wo.m + eta wi.m)^2), scaled by 1 / eta^2.
inline Vec3 eval(const Params& p, const Vec3& wo, const Vec3& wi) {
    const Half h = half(p, wo, wi);
    if (!h.valid) return Vec3(0.0);
    const rough_conductor::Params mf = p.microfacet();
    const double D = rough_conductor::d(mf, h.m);
    const double G = rough_conductor::g1(mf, wo, h.m) * rough_conductor::g1(mf, wi, h.m);
    const double dot_o = dot(wo, h.m), dot_i = dot(wi, h.m);
    const double F = dielectric::fresnel(dot_o, p.eta).F;
    double value;
    if (h.reflect) {
        value = F * D * G / (4.0 * std::abs(wo.z));
    } else {
        const double scale = 1.0 / (h.eta * h.eta);  // radiance: solid-angle compression
        const double denom = dot_o + h.eta * dot_i;
        value = std::abs(scale * (1.0 - F) * D * G * h.eta * h.eta * dot_o * dot_i / (wo.z * denom * denom));
    }
    return Vec3(std::isfinite(value) ? value : 0.0);
}

// The density of sample()'s direction, Mitsuba's eval_pdf: zero where the microfacet and
// the macrosurface disagree on the side of wo or wi (the G1 terms vanish there).
inline double pdf(const Params& p, const Vec3& wo, const Vec3& wi) {
    const Half h = half(p, wo, wi);
    if (!h.valid) return 0.0;
    const double dot_o = dot(wo, h.m), dot_i = dot(wi, h.m);
    if (!(dot_o * wo.z > 0.0 && dot_i * wi.z > 0.0)) return 0.0;
    const double F = dielectric::fresnel(dot_o, p.eta).F;
    double jacobian;  // of the half-vector map, d(m) / d(wi)
    if (h.reflect) {
        jacobian = 1.0 / (4.0 * dot_i);
    } else {
        const double denom = dot_o + h.eta * dot_i;
        jacobian = h.eta * h.eta * dot_i / (denom * denom);
    }
    const double value = visible_pdf(p, wo, h.m) * (h.reflect ? F : 1.0 - F) * std::abs(jacobian);
    return std::isfinite(value) ? value : 0.0;
}

// The relative index crossed from wo to wi (Mitsuba's bs.eta, for Russian roulette): eta_t /
// eta_i where wi is across the surface, else 1.
inline double eta_crossed(const Params& p, const Vec3& wo, const Vec3& wi) {
    if (!(wo.z * wi.z < 0.0)) return 1.0;
    return wo.z > 0.0 ? p.eta : 1.0 / p.eta;
}

// u0 picks the lobe, (u1, u2) the visible normal. A direction that leaves on the wrong side
// of the macrosurface (G1(wi, m) = 0, Mitsuba's weight 0) is no sample.
inline BSDFSample sample(const Params& p, const Vec3& wo, double u0, double u1, double u2) {
    BSDFSample s;
    if (wo.z == 0.0) return s;
    const Vec3 v = upper(wo, wo.z);
    const Vec3 m = p.distribution == Distribution::GGX ? rough_conductor::sample_visible_normal(v, p.alpha, u1, u2)
                                                       : microfacet::beckmann_sample_visible(v, p.alpha, u1, u2);
    const double dot_o = dot(wo, m);
    const dielectric::Fresnel f = dielectric::fresnel(dot_o, p.eta);
    const bool reflect = u0 <= f.F;
    Vec3 wi;
    if (reflect) {
        wi = 2.0 * dot_o * m - wo;
    } else {
        // refraction through m: the transmitted cosine has the sign opposite to wo.m's
        const double cos_t = dot_o > 0.0 ? -f.cos_t : f.cos_t;
        wi = m * (dot_o * f.eta_ti + cos_t) - wo * f.eta_ti;
        s.eta = f.eta_it;
    }
    if (reflect ? !(wi.z * wo.z > 0.0) : !(wi.z * wo.z < 0.0)) return s;
    s.wi = wi;
    s.pdf = pdf(p, wo, wi);
    if (!(s.pdf > 0.0)) return s;
    s.weight = eval(p, wo, wi) / s.pdf;
    s.valid = true;
    return s;
}

}  // namespace rt::rough_dielectric
