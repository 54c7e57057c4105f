// A material of the scene and the dispatch from it to its BSDF. One tagged struct, no
// virtual calls on the hot path.
#pragma once

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
};

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

    rough_conductor::Params rough() const { return {param, distribution, fresnel}; }
    rough_plastic::Params rough_plastic() const { return {{distribution, param}, coating, *transmittance}; }
    rough_dielectric::Params rough_dielectric() const { return {param, distribution, eta}; }

    bool emits() const { return type == MaterialType::DiffuseLight && max_component(radiance) > 0.0; }
    bool textured() const { return texture >= 0; }
    // This material with reflectance rho (a texture's value at a hit): the albedo, or a
    // plastic's base under its coating (the lobe choice keeps the texture's mean).
    void set_reflectance(const Vec3& rho) {
        albedo = rho;
        if (type == MaterialType::Plastic || type == MaterialType::RoughPlastic) coating.diffuse = coating.base(rho);
    }
    // Delta lobes: sampled directly, no pdf machinery, no light sampling at the vertex.
    bool is_delta() const {
        return type == MaterialType::Metal || type == MaterialType::Dielectric || type == MaterialType::ThinDielectric;
    }
    // Glass keeps its front normal as the local frame's +z, whichever side the path is on.
    bool is_glass() const { return type == MaterialType::Dielectric || type == MaterialType::RoughDielectric; }
    // Lobes of finite density on both sides of the surface: light sampling meets lights
    // behind it too, and uniform direction sampling covers the whole sphere.
    bool has_glossy_transmission() const { return type == MaterialType::RoughDielectric; }
    // A Dirac lobe beside lobes of finite density (smooth plastic): light sampling at the
    // vertex, and a sample of the Dirac lobe continues the path as a mirror's would.
    bool has_delta_lobe() const { return type == MaterialType::Plastic; }
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

// f * |cos| for a non-delta material in its local frame (wo.z > 0 assumed by the caller, but
// for glass, whose wo.z < 0 means inside).
template <Mutant M = Mutant::None>
inline Vec3 bsdf_eval(const Material& m, const Vec3& wo, const Vec3& wi) {
    switch (m.type) {
        case MaterialType::Lambertian:
        case MaterialType::DiffuseLight: return lambertian::eval<M>(m.albedo, wo, wi);
        case MaterialType::RoughConductor: return rough_conductor::eval<M>(m.albedo, m.rough(), wo, wi);
        case MaterialType::Plastic: return plastic::eval(m.coating, wo, wi);
        case MaterialType::RoughPlastic: return rough_plastic::eval(m.rough_plastic(), wo, wi);
        case MaterialType::RoughDielectric: return rough_dielectric::eval(m.rough_dielectric(), wo, wi);
        default: return Vec3(0.0);
    }
}

// Density of bsdf_sample's direction (the `cosine` strategy's pdf).
template <Mutant M = Mutant::None>
inline double bsdf_pdf(const Material& m, const Vec3& wo, const Vec3& wi) {
    switch (m.type) {
        case MaterialType::Lambertian:
        case MaterialType::DiffuseLight: return lambertian::pdf<M>(wo, wi);
        case MaterialType::RoughConductor: return rough_conductor::pdf<M>(m.rough(), wo, wi);
        case MaterialType::Plastic: return plastic::pdf(m.coating, wo, wi);
        case MaterialType::RoughPlastic: return rough_plastic::pdf(m.rough_plastic(), wo, wi);
        case MaterialType::RoughDielectric: return rough_dielectric::pdf(m.rough_dielectric(), wo, wi);
        default: return 0.0;
    }
}

// Probability that bsdf_sample picks the material's Dirac lobe, for a material that has one
// beside lobes of finite density (Material::has_delta_lobe); 0 for the others.
inline double bsdf_delta_probability(const Material& m, const Vec3& wo) {
    return m.type == MaterialType::Plastic ? plastic::delta_probability(m.coating, wo) : 0.0;
}

// The specular and rough lobes, kept out of line so that the diffuse case below inlines
// into the integrator without the rest of the switch.
template <Mutant M = Mutant::None>
[[gnu::noinline]] inline BSDFSample bsdf_sample_other(const Material& m, const Vec3& wo, double u0, double u1,
                                                      double u2) {
    switch (m.type) {
        case MaterialType::RoughConductor: return rough_conductor::sample<M>(m.albedo, m.rough(), wo, u1, u2);
        case MaterialType::Metal: return conductor::sample(m.albedo, m.param, m.fresnel, wo, u1, u2);
        case MaterialType::Dielectric: return dielectric::sample<M>(m.param, wo, u0, m.schlick);
        case MaterialType::ThinDielectric: return thin_dielectric::sample(m.param, wo, u0);
        case MaterialType::Plastic: return plastic::sample(m.coating, wo, u0, u1, u2);
        case MaterialType::RoughPlastic: return rough_plastic::sample(m.rough_plastic(), wo, u0, u1, u2);
        case MaterialType::RoughDielectric: return rough_dielectric::sample(m.rough_dielectric(), wo, u0, u1, u2);
        default: return {};
    }
}

template <Mutant M = Mutant::None>
inline BSDFSample bsdf_sample(const Material& m, const Vec3& wo, double u0, double u1, double u2) {
    // Diffuse first and inline: the common case (a call returning the sample through
    // memory was ~6% of cornell_box's samples).
    if (m.type == MaterialType::Lambertian || m.type == MaterialType::DiffuseLight)
        return lambertian::sample<M>(m.albedo, wo, u1, u2);
    return bsdf_sample_other<M>(m, wo, u0, u1, u2);
}

}  // namespace rt
