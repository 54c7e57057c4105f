// Microfacet conductor (Mitsuba `roughconductor`): f = albedo F(wo.h) D(h) G1(wo,h) G1(wi,h)
// / (4 cos_o cos_i), separable Smith shadowing, isotropic alpha as Mitsuba's, GGX or
// Beckmann, Fresnel 1 (material 'none') or a complex index eta + i k. Sampled through the
// distribution of visible normals, whose density is G1(wo,h) D(h) / (4 cos_o). The GGX
// functions without Fresnel are the tracer's original ones, kept as they were: images of
// scenes that use only them do not change by a bit.
#pragma once

#include "../mutants.h"
#include "../sampling/warp.h"
#include "bsdf_sample.h"
#include "conductor_fresnel.h"
#include "microfacet.h"

namespace rt::rough_conductor {

// What a rough conductor is, beyond its albedo: roughness, distribution and Fresnel.
struct Params {
    double alpha = 0.1;
    Distribution distribution = Distribution::GGX;
    ConductorFresnel fresnel;

    bool plain_ggx() const { return distribution == Distribution::GGX && !fresnel.enabled; }
};

inline double ggx_d(const Vec3& m, double alpha) {
    if (m.z <= 0.0) return 0.0;
    const double a2 = alpha * alpha;
    const double c2 = m.z * m.z;
    const double denom = c2 * (a2 - 1.0) + 1.0;
    return a2 / (kPi * denom * denom);
}

// Smith's masking for GGX; zero when v sees the back of the microfacet.
template <Mutant M = Mutant::None>
inline double smith_g1(const Vec3& v, const Vec3& m, double alpha) {
    if (dot(v, m) * v.z <= 0.0) return 0.0;
    const double c2 = v.z * v.z;
    const double tan2 = std::max(0.0, 1.0 - c2) / c2;
    if constexpr (M == Mutant::GgxMaskingAlpha)
        return 2.0 / (1.0 + std::sqrt(1.0 + alpha * tan2));  // seeded bug: alpha, not alpha^2
    return 2.0 / (1.0 + std::sqrt(1.0 + alpha * alpha * tan2));
}

template <Mutant M = Mutant::None>
inline Vec3 eval(const Vec3& albedo, double alpha, const Vec3& wo, const Vec3& wi) {
    if (wo.z <= 0.0 || wi.z <= 0.0) return Vec3(0.0);
    const Vec3 h = normalize(wo + wi);
    const double value = ggx_d(h, alpha) * smith_g1<M>(wo, h, alpha) * smith_g1<M>(wi, h, alpha) / (4.0 * wo.z);
    return albedo * value;  // f * cos_i
}

template <Mutant M = Mutant::None>
inline double pdf(double alpha, const Vec3& wo, const Vec3& wi) {
    if (wo.z <= 0.0 || wi.z <= 0.0) return 0.0;
    const Vec3 h = normalize(wo + wi);
    return smith_g1<M>(wo, h, alpha) * ggx_d(h, alpha) / (4.0 * wo.z);
}

// A visible normal for the view direction wo (Heitz, "Sampling the GGX Distribution of
// Visible Normals", JCGT 2018).
inline Vec3 sample_visible_normal(const Vec3& wo, double alpha, double u1, double u2) {
    const Vec3 vh = normalize(Vec3(alpha * wo.x, alpha * wo.y, wo.z));
    const double len2 = vh.x * vh.x + vh.y * vh.y;
    const Vec3 t1 = len2 > 0.0 ? Vec3(-vh.y, vh.x, 0.0) / std::sqrt(len2) : Vec3(1.0, 0.0, 0.0);
    const Vec3 t2 = cross(vh, t1);
    const double r = std::sqrt(u1);
    double sin_phi, cos_phi;
    sincos_turn(u2, sin_phi, cos_phi);  // phi = 2 pi u2
    const double p1 = r * cos_phi;
    const double s = 0.5 * (1.0 + vh.z);
    const double p2 = (1.0 - s) * safe_sqrt(1.0 - p1 * p1) + s * r * sin_phi;
    const Vec3 nh = p1 * t1 + p2 * t2 + safe_sqrt(1.0 - p1 * p1 - p2 * p2) * vh;
    return normalize(Vec3(alpha * nh.x, alpha * nh.y, std::max(0.0, nh.z)));
}

template <Mutant M = Mutant::None>
inline BSDFSample sample(const Vec3& albedo, double alpha, const Vec3& wo, double u1, double u2) {
    BSDFSample s;
    if (wo.z <= 0.0) return s;
    const Vec3 m = sample_visible_normal(wo, alpha, u1, u2);
    const Vec3 wi = 2.0 * dot(wo, m) * m - wo;
    if (wi.z <= 0.0) return s;
    s.wi = wi;
    s.pdf = pdf<M>(alpha, wo, wi);
    if (!(s.pdf > 0.0)) return s;
    s.weight = eval<M>(albedo, alpha, wo, wi) / s.pdf;
    s.valid = true;
    return s;
}

// The general conductor: any distribution, any Fresnel (plain GGX goes through the
// functions above, unchanged).
template <Mutant M = Mutant::None>
inline double d(const Params& p, const Vec3& m) {
    return p.distribution == Distribution::GGX ? ggx_d(m, p.alpha) : microfacet::beckmann_d(m, p.alpha);
}

template <Mutant M = Mutant::None>
inline double g1(const Params& p, const Vec3& v, const Vec3& m) {
    return p.distribution == Distribution::GGX ? smith_g1<M>(v, m, p.alpha) : microfacet::beckmann_g1(v, m, p.alpha);
}

template <Mutant M = Mutant::None>
inline Vec3 eval(const Vec3& albedo, const Params& p, const Vec3& wo, const Vec3& wi) {
    if (p.plain_ggx()) return eval<M>(albedo, p.alpha, wo, wi);
    if (wo.z <= 0.0 || wi.z <= 0.0) return Vec3(0.0);
    const Vec3 h = normalize(wo + wi);
    const double value = d<M>(p, h) * g1<M>(p, wo, h) * g1<M>(p, wi, h) / (4.0 * wo.z);
    return albedo * p.fresnel.eval(dot(wo, h)) * value;  // f * cos_i
}

// The density of sample() below. Beckmann's uses the exact masking of the visible normals
// it samples (Mitsuba divides by its approximate one, a bias of up to 0.35% at grazing
// angles that this estimator does not share; the BSDF value is Mitsuba's either way).
template <Mutant M = Mutant::None>
inline double pdf(const Params& p, const Vec3& wo, const Vec3& wi) {
    if (p.plain_ggx()) return pdf<M>(p.alpha, wo, wi);
    if (wo.z <= 0.0 || wi.z <= 0.0) return 0.0;
    const Vec3 h = normalize(wo + wi);
    if (dot(wo, h) <= 0.0 || dot(wi, h) <= 0.0) return 0.0;
    const double g1_wo = p.distribution == Distribution::GGX ? smith_g1<M>(wo, h, p.alpha)
                                                             : microfacet::beckmann_g1_exact(wo, h, p.alpha);
    return g1_wo * d<M>(p, h) / (4.0 * wo.z);
}

template <Mutant M = Mutant::None>
inline BSDFSample sample(const Vec3& albedo, const Params& p, const Vec3& wo, double u1, double u2) {
    if (p.plain_ggx()) return sample<M>(albedo, p.alpha, wo, u1, u2);
    BSDFSample s;
    if (wo.z <= 0.0) return s;
    const Vec3 m = p.distribution == Distribution::GGX ? sample_visible_normal(wo, p.alpha, u1, u2)
                                                       : microfacet::beckmann_sample_visible(wo, p.alpha, u1, u2);
    const Vec3 wi = 2.0 * dot(wo, m) * m - wo;
    if (wi.z <= 0.0) return s;
    s.wi = wi;
    s.pdf = pdf<M>(p, wo, wi);
    if (!(s.pdf > 0.0)) return s;
    s.weight = eval<M>(albedo, p, wo, wi) / s.pdf;
    s.valid = true;
    return s;
}

}  // namespace rt::rough_conductor
