// A material of the scene and the dispatch from it to its BSDF. One tagged struct, no
// virtual calls on the hot path.
#pragma once

#include <algorithm>

#include "conductor.h"
#include "dielectric.h"
#include "lambertian.h"
#include "plastic.h"
#include "rough_conductor.h"
#include "rough_dielectric.h"
#include "rough_plastic.h"
#include "thin_dielectric.h"

namespace rt {

enum class MaterialType : int {
    Lambertian = 0,
    Metal = 1,
    Dielectric = 2,
    RoughConductor = 3,
    DiffuseLight = 4,
    Plastic = 5,
    RoughPlastic = 6,
    ThinDielectric = 7,
    RoughDielectric = 8,
    // Mitsuba's `mask`: the material of type `nested` (its other members as that type's),
    // present with probability `opacity`, else the surface lets the ray straight through.
    Masked = 9,
};

// Whether every lobe of a material of type t is a Dirac lobe.
constexpr bool is_delta_type(MaterialType t) {
    return t == MaterialType::Metal || t == MaterialType::Dielectric || t == MaterialType::ThinDielectric;
}

struct Material {
    MaterialType type = MaterialType::Lambertian;
    Vec3 albedo;            // Plastic and RoughPlastic: the diffuse base's reflectance
    Vec3 radiance;          // emitted radiance (DiffuseLight)
    double param = 0.0;     // Metal: fuzz; Dielectric and ThinDielectric: ior; RoughConductor, RoughPlastic and
                            // RoughDielectric: alpha
    bool two_sided = false;
    bool reflects = true;   // false for a DiffuseLight without albedo: a black surface
    bool schlick = false;   // Dielectric: Schlick's approximation instead of exact Fresnel
    // Metal and RoughConductor: Fresnel of a complex index (off: Fresnel 1); RoughConductor,
    // RoughPlastic and RoughDielectric: the microfacet distribution.
    ConductorFresnel fresnel;
    Distribution distribution = Distribution::GGX;
    // Plastic and RoughPlastic: the coating over the base (make_plastic); RoughPlastic: the
    // coating's transmittance table, shared by the materials of equal coatings (owned by
    // rough_plastic::transmittance's cache, which keeps every table for the process's
    // lifetime: a plain pointer, so that copying a material costs no reference count).
    plastic::Coating coating;
    const rough_plastic::Transmittance* transmittance = nullptr;
    // The scene's texture of the reflectance (albedo; a plastic's base) or -1: constant.
    // Where it has one, `albedo` holds its mean (what a plastic's lobe choice takes), and
    // a hit's material is a copy with the texture's value there (with_reflectance).
    int32_t texture = -1;
    // RoughDielectric: int_ior / ext_ior (last: the other members keep their offsets).
    double eta = 1.0;
    // Masked: the type of the material under the mask, and the opacity alpha in [0, 1]
    // (Mitsuba's clip(opacity.eval_1, 0, 1)): the constant, or a hit's copy's value of the
    // scene's texture `opacity_texture` (-1: constant).
    MaterialType nested = MaterialType::Lambertian;
    double opacity = 1.0;
    int32_t opacity_texture = -1;

    rough_conductor::Params rough() const { return {param, distribution, fresnel}; }
    rough_plastic::Params rough_plastic() const { return {{distribution, param}, coating, *transmittance}; }
    rough_dielectric::Params rough_dielectric() const { return {param, distribution, eta}; }

    bool emits() const { return type == MaterialType::DiffuseLight && max_component(radiance) > 0.0; }
    // Whether a hit needs a texture's value: a reflectance or an opacity texture (-1, none,
    // has every bit set, so the AND is negative only where both are -1: one test).
    bool textured() const { return (texture & opacity_texture) >= 0; }
    // The type whose lobes the material has: its own, or under a mask the nested one's (a
    // selection, no branch: the tests below stay one comparison for the unmasked).
    MaterialType lobes() const { return type == MaterialType::Masked ? nested : type; }
    bool masked() const { return type == MaterialType::Masked; }
    // This material with reflectance rho (a texture's value at a hit): the albedo, or a
    // plastic's base under its coating (the lobe choice keeps the texture's mean).
    void set_reflectance(const Vec3& rho) {
        albedo = rho;
        const MaterialType t = lobes();
        if (t == MaterialType::Plastic || t == MaterialType::RoughPlastic) coating.diffuse = coating.base(rho);
    }
    // Delta lobes only: sampled directly, no pdf machinery, no light sampling at the vertex
    // (a mask's null lobe is a Dirac lobe too: a masked mirror is all Dirac lobes).
    bool is_delta() const { return is_delta_type(lobes()); }
    // Glass keeps its front normal as the local frame's +z, whichever side the path is on.
    bool is_glass() const {
        const MaterialType t = lobes();
        return t == MaterialType::Dielectric || t == MaterialType::RoughDielectric;
    }
    // The frame keeps the front normal on the back too: glass, and a one-sided material
    // under a mask, whose nested lobes are then black (wo.z < 0) while the null lobe passes.
    bool keeps_front_frame() const { return is_glass() || (masked() && !two_sided); }
    // Lobes of finite density on both sides of the surface: light sampling meets lights
    // behind it too, and uniform direction sampling covers the whole sphere.
    bool has_glossy_transmission() const { return lobes() == MaterialType::RoughDielectric; }
    // A Dirac lobe beside lobes of finite density (smooth plastic; a mask's null lobe
    // beside a non-delta material): light sampling at the vertex, and a sample of the Dirac
    // lobe continues the path as a mirror's would.
    bool has_delta_lobe() const {
        return type == MaterialType::Plastic || (masked() && !is_delta_type(nested));
    }
};

// Makes m (type Plastic or RoughPlastic, its albedo, param and distribution set) a plastic of
// relative index eta = int_ior / ext_ior: its coating and, for the rough one, the coating's
// table (computed here, once per coating: scene load).
inline void make_plastic(Material& m, const Vec3& specular, double eta, bool nonlinear) {
    double internal_reflectance = plastic::fresnel_diffuse_reflectance(1.0 / eta);
    if (m.type == MaterialType::RoughPlastic) {
        m.transmittance = rough_plastic::transmittance({m.distribution, m.param}, eta).get();
        internal_reflectance = m.transmittance->internal_reflectance;
    }
    m.coating = plastic::Coating::make(m.albedo, specular, eta, nonlinear, internal_reflectance);
}

// M, in the functions below: a self-test mutant (mutants.h); Mutant::None is the tracer.
// The *_as functions dispatch on type t, the material's own (bsdf_eval and the others) or
// the type nested under a mask (namespace masked, below).

namespace masked {
template <Mutant M>
Vec3 eval(const Material& m, const Vec3& wo, const Vec3& wi);
template <Mutant M>
double pdf(const Material& m, const Vec3& wo, const Vec3& wi);
template <Mutant M>
BSDFSample sample(const Material& m, const Vec3& wo, double u0, double u1, double u2);
double delta_probability(const Material& m, const Vec3& wo);
}  // namespace masked

// f * |cos| for a non-delta material in its local frame (wo.z > 0 assumed by the caller, but
// for glass, whose wo.z < 0 means inside, and a mask, which checks the side itself).
template <Mutant M = Mutant::None>
inline Vec3 bsdf_eval_as(MaterialType t, const Material& m, const Vec3& wo, const Vec3& wi) {
    switch (t) {
        case MaterialType::Lambertian:
        case MaterialType::DiffuseLight: return lambertian::eval<M>(m.albedo, wo, wi);
        case MaterialType::RoughConductor: return rough_conductor::eval<M>(m.albedo, m.rough(), wo, wi);
        case MaterialType::Plastic: return plastic::eval(m.coating, wo, wi);
        case MaterialType::RoughPlastic: return rough_plastic::eval(m.rough_plastic(), wo, wi);
        case MaterialType::RoughDielectric: return rough_dielectric::eval(m.rough_dielectric(), wo, wi);
        case MaterialType::Masked: return masked::eval<M>(m, wo, wi);
        default: return Vec3(0.0);
    }
}
template <Mutant M = Mutant::None>
inline Vec3 bsdf_eval(const Material& m, const Vec3& wo, const Vec3& wi) {
    return bsdf_eval_as<M>(m.type, m, wo, wi);
}

// Density of bsdf_sample's direction (the `cosine` strategy's pdf).
template <Mutant M = Mutant::None>
inline double bsdf_pdf_as(MaterialType t, const Material& m, const Vec3& wo, const Vec3& wi) {
    switch (t) {
        case MaterialType::Lambertian:
        case MaterialType::DiffuseLight: return lambertian::pdf<M>(wo, wi);
        case MaterialType::RoughConductor: return rough_conductor::pdf<M>(m.rough(), wo, wi);
        case MaterialType::Plastic: return plastic::pdf(m.coating, wo, wi);
        case MaterialType::RoughPlastic: return rough_plastic::pdf(m.rough_plastic(), wo, wi);
        case MaterialType::RoughDielectric: return rough_dielectric::pdf(m.rough_dielectric(), wo, wi);
        case MaterialType::Masked: return masked::pdf<M>(m, wo, wi);
        default: return 0.0;
    }
}
template <Mutant M = Mutant::None>
inline double bsdf_pdf(const Material& m, const Vec3& wo, const Vec3& wi) {
    return bsdf_pdf_as<M>(m.type, m, wo, wi);
}

// Probability that bsdf_sample picks the material's Dirac lobe, for a material that has one
// beside lobes of finite density (Material::has_delta_lobe); 0 for the others.
inline double bsdf_delta_probability(const Material& m, const Vec3& wo) {
    if (m.masked()) return masked::delta_probability(m, wo);
    return m.type == MaterialType::Plastic ? plastic::delta_probability(m.coating, wo) : 0.0;
}

// The specular and rough lobes, kept out of line so that the diffuse case below inlines
// into the integrator without the rest of the switch.
template <Mutant M = Mutant::None>
[[gnu::noinline]] inline BSDFSample bsdf_sample_other(MaterialType t, const Material& m, const Vec3& wo, double u0,
                                                      double u1, double u2) {
    switch (t) {
        case MaterialType::Lambertian:
        case MaterialType::DiffuseLight: return lambertian::sample<M>(m.albedo, wo, u1, u2);
        case MaterialType::RoughConductor: return rough_conductor::sample<M>(m.albedo, m.rough(), wo, u1, u2);
        case MaterialType::Metal: return conductor::sample(m.albedo, m.param, m.fresnel, wo, u1, u2);
        case MaterialType::Dielectric: return dielectric::sample<M>(m.param, wo, u0, m.schlick);
        case MaterialType::ThinDielectric: return thin_dielectric::sample(m.param, wo, u0);
        case MaterialType::Plastic: return plastic::sample(m.coating, wo, u0, u1, u2);
        case MaterialType::RoughPlastic: return rough_plastic::sample(m.rough_plastic(), wo, u0, u1, u2);
        case MaterialType::RoughDielectric: return rough_dielectric::sample(m.rough_dielectric(), wo, u0, u1, u2);
        case MaterialType::Masked: return masked::sample<M>(m, wo, u0, u1, u2);
        default: return {};
    }
}

template <Mutant M = Mutant::None>
inline BSDFSample bsdf_sample(const Material& m, const Vec3& wo, double u0, double u1, double u2) {
    // Diffuse first and inline: the common case (a call returning the sample through
    // memory was ~6% of cornell_box's samples). A masked diffuse material is of type
    // Masked: it goes through bsdf_sample_other, at no cost here.
    if (m.type == MaterialType::Lambertian || m.type == MaterialType::DiffuseLight)
        return lambertian::sample<M>(m.albedo, wo, u1, u2);
    return bsdf_sample_other<M>(m.type, m, wo, u0, u1, u2);
}

// Mitsuba's `mask` (src/bsdfs/mask.cpp): with probability 1 - alpha the null lobe, a Dirac
// lobe straight through (wi = -wo, weight 1, eta 1, pdf 1 - alpha), else the nested
// material's sample with its weight and its pdf times alpha; eval and pdf are the nested
// ones times alpha. Seen from the back of a one-sided nested material (wo.z <= 0 in the
// front frame, Material::keeps_front_frame) the nested part is black, and the null lobe
// passes all the same. Out of line: only masked materials come here.
namespace masked {

// Whether the nested material scatters seen from wo (glass: from both sides).
inline bool nested_active(const Material& m, const Vec3& wo) {
    return wo.z > 0.0 || m.is_glass();
}

template <Mutant M>
[[gnu::noinline]] Vec3 eval(const Material& m, const Vec3& wo, const Vec3& wi) {
    if (!nested_active(m, wo)) return Vec3(0.0);
    return bsdf_eval_as<M>(m.nested, m, wo, wi) * m.opacity;
}

template <Mutant M>
[[gnu::noinline]] double pdf(const Material& m, const Vec3& wo, const Vec3& wi) {
    if (!nested_active(m, wo)) return 0.0;
    return bsdf_pdf_as<M>(m.nested, m, wo, wi) * m.opacity;
}

// The null lobe takes u0 in [0, 1 - alpha), the nested material the rest, rescaled to
// [0, 1): the Dirac lobes come first, as sample_uniform_beside_delta wants them (a smooth
// plastic's own Dirac lobe follows in the nested part).
template <Mutant M>
[[gnu::noinline]] BSDFSample sample(const Material& m, const Vec3& wo, double u0, double u1, double u2) {
    const double p_null = 1.0 - m.opacity;
    if (u0 < p_null) {
        BSDFSample s;
        s.wi = -wo;
        s.weight = Vec3(1.0);
        s.pdf = p_null;
        s.delta = true;
        s.valid = true;
        return s;
    }
    if (!nested_active(m, wo)) return {};
    // (Rounding could carry u0 - p_null to alpha itself: the result stays below 1.)
    const double u0_nested = std::min((u0 - p_null) / m.opacity, 0x1.fffffffffffffp-1);
    BSDFSample s = bsdf_sample_other<M>(m.nested, m, wo, u0_nested, u1, u2);
    s.pdf *= m.opacity;
    return s;
}

inline double delta_probability(const Material& m, const Vec3& wo) {
    const double p_null = 1.0 - m.opacity;
    if (m.nested != MaterialType::Plastic || !nested_active(m, wo)) return p_null;
    return p_null + m.opacity * plastic::delta_probability(m.coating, wo);
}

}  // namespace masked

}  // namespace rt
