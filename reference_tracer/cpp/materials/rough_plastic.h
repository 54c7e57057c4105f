// Rough plastic (Mitsuba `roughplastic`): a diffuse base under a rough dielectric coating
// (GGX or Beckmann, isotropic alpha). Two lobes, front side only:
//  - the coating's glossy reflection, ks F(wo.h) D(h) G1(wo,h) G1(wi,h) / (4 cos_o), and
//  - the diffuse light that crosses the coating twice:
//    rho' cos_i / pi T(cos_o) T(cos_i) / eta^2,
// T the coating's transmittance and rho' the base's reflectance divided by 1 - Fi (or by
// 1 - rho Fi when `nonlinear`), Fi the coating's internal diffuse reflectance. T and Fi
// are integrals over the microfacets; Mitsuba tabulates T at 64 cosines and interpolates,
// and so do we (Transmittance below, computed once per coating at scene load). The lobe
// is chosen with probability proportional to (1 - T(cos_o)) sw and T(cos_o) (1 - sw); a
// sample's weight is the whole BSDF over the whole mixture density, as Mitsuba's.
// Microfacet functions: GGX's are the rough conductor's, Beckmann's microfacet.h's; the
// density uses the exact masking of the visible normals sampled (for Beckmann, Mitsuba
// divides by its approximate masking instead: see rough_conductor::pdf).
#pragma once

#include <array>
#include <memory>

#include "bsdf_sample.h"
#include "microfacet.h"
#include "plastic.h"
#include "rough_conductor.h"

namespace rt::rough_plastic {

// A microfacet distribution: its kind and (isotropic) roughness.
struct Microfacet {
    Distribution distribution = Distribution::Beckmann;
    double alpha = 0.1;

    double d(const Vec3& m) const {
        return distribution == Distribution::GGX ? rough_conductor::ggx_d(m, alpha) : microfacet::beckmann_d(m, alpha);
    }
    // Masking in the BSDF's value (Mitsuba's: Walter's approximation for Beckmann).
    double g1(const Vec3& v, const Vec3& m) const {
        return distribution == Distribution::GGX ? rough_conductor::smith_g1(v, m, alpha)
                                                 : microfacet::beckmann_g1(v, m, alpha);
    }
    // Masking in the density of the visible normals that sample_visible draws (exact).
    double g1_visible(const Vec3& v, const Vec3& m) const {
        return distribution == Distribution::GGX ? rough_conductor::smith_g1(v, m, alpha)
                                                 : microfacet::beckmann_g1_exact(v, m, alpha);
    }
    // Mitsuba's maps of the square for both (its table's quadrature runs through them).
    Vec3 sample_visible(const Vec3& wo, double u1, double u2) const {
        return distribution == Distribution::GGX ? microfacet::ggx_sample_visible(wo, alpha, u1, u2)
                                                 : microfacet::beckmann_sample_visible(wo, alpha, u1, u2);
    }
};

// The coating's transmittance T(cos) for light arriving from outside, tabulated at 64
// cosines k / 63 (the first raised to 1e-6), and its internal diffuse reflectance: Mitsuba's
// definitions, integrated by our own quadrature (rough_plastic.cpp).
struct Transmittance {
    static constexpr int kSize = 64;
    std::array<double, kSize> table{};
    double internal_reflectance = 0.0;

    // Linear interpolation between the two entries around cos (Mitsuba's lerp_gather).
    double operator()(double cos) const {
        const double x = cos * double(kSize - 1);
        const int i = std::min(int(x), kSize - 2);
        return table[i] + (table[i + 1] - table[i]) * (x - double(i));
    }
};

// The coating's tables for (distribution, alpha, eta), computed on first use and shared
// afterwards (thread-safe): a scene's materials, and the chi-square probe's many calls.
std::shared_ptr<const Transmittance> transmittance(const Microfacet& microfacet, double eta);

// The integrals behind the table, at one direction of incidence cos_i, for a coating of
// relative index eta seen from the side light arrives on: the share of light that crosses
// it, and the share it reflects (an N x N Gauss-Legendre rule over the visible-normal
// sampler's square, N = 32 where eta > 1, else 128, as Mitsuba integrates them).
double coating_transmittance(const Microfacet& microfacet, double eta, double cos_i);
double coating_reflectance(const Microfacet& microfacet, double eta, double cos_i);

// What a rough plastic is: its microfacets, its coating and the coating's table (the
// material owns the last two; this view is built per call).
struct Params {
    Microfacet microfacet;
    const plastic::Coating& coating;
    const Transmittance& t;
};

inline Vec3 eval(const Params& p, const Vec3& wo, const Vec3& wi) {
    if (!(wo.z > 0.0 && wi.z > 0.0)) return Vec3(0.0);
    const plastic::Coating& c = p.coating;
    const Microfacet& mf = p.microfacet;
    const Vec3 h = normalize(wo + wi);
    const double glossy = c.fresnel(dot(wo, h)) * mf.d(h) * mf.g1(wo, h) * mf.g1(wi, h) / (4.0 * wo.z);
    const double diffuse = kInvPi * c.inv_eta2 * wi.z * p.t(wo.z) * p.t(wi.z);
    return c.specular * glossy + c.diffuse * diffuse;  // f * cos_i
}

inline double pdf(const Params& p, const Vec3& wo, const Vec3& wi) {
    if (!(wo.z > 0.0 && wi.z > 0.0)) return 0.0;
    const double p_glossy = p.coating.specular_probability(1.0 - p.t(wo.z));
    const Vec3 h = normalize(wo + wi);
    const double glossy = p.microfacet.d(h) * p.microfacet.g1_visible(wo, h) / (4.0 * wo.z);
    return p_glossy * glossy + (1.0 - p_glossy) * cosine_hemisphere_pdf(wi.z);
}

// u0 chooses the lobe; (u1, u2) the microfacet normal or the diffuse direction.
inline BSDFSample sample(const Params& p, const Vec3& wo, double u0, double u1, double u2) {
    BSDFSample s;
    if (!(wo.z > 0.0)) return s;
    const double p_glossy = p.coating.specular_probability(1.0 - p.t(wo.z));
    if (u0 < p_glossy) {
        const Vec3 m = p.microfacet.sample_visible(wo, u1, u2);
        s.wi = 2.0 * dot(wo, m) * m - wo;
    } else {
        s.wi = square_to_cosine_hemisphere(u1, u2);
    }
    if (!(s.wi.z > 0.0)) return s;
    s.pdf = pdf(p, wo, s.wi);
    if (!(s.pdf > 0.0)) return s;
    s.weight = eval(p, wo, s.wi) / s.pdf;
    s.valid = true;
    return s;
}

}  // namespace rt::rough_plastic
