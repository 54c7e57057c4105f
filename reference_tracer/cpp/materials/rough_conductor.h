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

// The plain-GGX pieces are written once over their lane type F (simd.h: double for one
// vertex, a pack for rough_conductor_pack.h's), each lane doing one vertex's operations in
// their order; their early returns are selections. The Vec3 forms below call them.

// v times the reciprocal of its length (normalize), lane by lane.
template <typename F>
inline void normalize_lanes(F (&v)[3]) {
    const F inv = 1.0 / sqrt_of(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    for (int a = 0; a < 3; ++a) v[a] = v[a] * inv;
}

// GGX's distribution of normals m (unit), zero below the surface.
template <typename F>
inline F ggx_d(const F (&m)[3], F alpha) {
    const F a2 = alpha * alpha;
    const F c2 = m[2] * m[2];
    const F denom = c2 * (a2 - 1.0) + 1.0;
    const F d = a2 / (kPi * denom * denom);
    return m[2] <= 0.0 ? F{} : d;
}

// Smith's masking for GGX; zero when v sees the back of the microfacet.
template <Mutant M = Mutant::None, typename F>
inline F smith_g1(const F (&v)[3], const F (&m)[3], F alpha) {
    const F vm = v[0] * m[0] + v[1] * m[1] + v[2] * m[2];  // dot(v, m)
    const F c2 = v[2] * v[2];
    const F one_minus = 1.0 - c2;
    const F tan2 = (0.0 < one_minus ? one_minus : F{}) / c2;  // std::max(0.0, 1 - c2) / c2
    F g;
    if constexpr (M == Mutant::GgxMaskingAlpha)
        g = 2.0 / (1.0 + sqrt_of(1.0 + alpha * tan2));  // seeded bug: alpha, not alpha^2
    else
        g = 2.0 / (1.0 + sqrt_of(1.0 + alpha * alpha * tan2));
    return vm * v[2] <= 0.0 ? F{} : g;
}

// A visible normal m for the view direction wo (Heitz, "Sampling the GGX Distribution of
// Visible Normals", JCGT 2018).
template <typename F>
inline void sample_visible_normal(const F (&wo)[3], F alpha, F u1, F u2, F (&m)[3]) {
    F vh[3] = {alpha * wo[0], alpha * wo[1], wo[2]};
    normalize_lanes(vh);
    const F len2 = vh[0] * vh[0] + vh[1] * vh[1];
    const auto tilted = len2 > 0.0;
    const F inv = 1.0 / sqrt_of(len2);
    // Vec3(-vh.y, vh.x, 0) / sqrt(len2), or (1, 0, 0); the z of both is +0.
    const F t1[3] = {tilted ? -vh[1] * inv : as_lanes(1.0, inv), tilted ? vh[0] * inv : F{}, F{}};
    const F t2[3] = {vh[1] * t1[2] - vh[2] * t1[1], vh[2] * t1[0] - vh[0] * t1[2], vh[0] * t1[1] - vh[1] * t1[0]};
    const F r = sqrt_of(u1);
    F sin_phi, cos_phi;
    sincos_turn(u2, sin_phi, cos_phi);  // phi = 2 pi u2
    const F p1 = r * cos_phi;
    const F s = 0.5 * (1.0 + vh[2]);
    const F p2 = (1.0 - s) * safe_sqrt_of(1.0 - p1 * p1) + s * r * sin_phi;
    const F lift = safe_sqrt_of(1.0 - p1 * p1 - p2 * p2);
    F nh[3];
    for (int a = 0; a < 3; ++a) nh[a] = t1[a] * p1 + t2[a] * p2 + vh[a] * lift;
    m[0] = alpha * nh[0];
    m[1] = alpha * nh[1];
    m[2] = 0.0 < nh[2] ? nh[2] : F{};  // std::max(0.0, nh.z)
    normalize_lanes(m);
}

inline double ggx_d(const Vec3& m, double alpha) {
    const double mm[3] = {m.x, m.y, m.z};
    return ggx_d(mm, alpha);
}
template <Mutant M = Mutant::None>
inline double smith_g1(const Vec3& v, const Vec3& m, double alpha) {
    const double vv[3] = {v.x, v.y, v.z}, mm[3] = {m.x, m.y, m.z};
    return smith_g1<M>(vv, mm, alpha);
}
inline Vec3 sample_visible_normal(const Vec3& wo, double alpha, double u1, double u2) {
    const double w[3] = {wo.x, wo.y, wo.z};
    double m[3];
    sample_visible_normal(w, alpha, u1, u2, m);
    return {m[0], m[1], m[2]};
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

// The general conductor: any distribution, any Fresnel (plain GGX's value and density go
// through the functions above, unchanged).
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

// One body for every distribution: plain GGX's density and value come from pdf() and
// eval(), which take its own path.
template <Mutant M = Mutant::None>
inline BSDFSample sample(const Vec3& albedo, const Params& p, const Vec3& wo, double u1, double u2) {
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
