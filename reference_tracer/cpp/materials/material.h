// A material of the scene and the dispatch from it to its BSDF. One tagged struct, no
// virtual calls on the hot path.
#pragma once

#include "conductor.h"
#include "dielectric.h"
#include "lambertian.h"
#include "rough_conductor.h"

namespace rt {

enum class MaterialType : int { Lambertian = 0, Metal = 1, Dielectric = 2, RoughConductor = 3, DiffuseLight = 4 };

struct Material {
    MaterialType type = MaterialType::Lambertian;
    Vec3 albedo;
    Vec3 radiance;          // emitted radiance (DiffuseLight)
    double param = 0.0;     // Metal: fuzz; Dielectric: ior; RoughConductor: alpha
    bool two_sided = false;
    bool reflects = true;   // false for a DiffuseLight without albedo: a black surface
    bool schlick = false;   // Dielectric: Schlick's approximation instead of exact Fresnel
    // Metal and RoughConductor: Fresnel of a complex index (off: Fresnel 1); RoughConductor:
    // its microfacet distribution.
    ConductorFresnel fresnel;
    Distribution distribution = Distribution::GGX;

    rough_conductor::Params rough() const { return {param, distribution, fresnel}; }

    bool emits() const { return type == MaterialType::DiffuseLight && max_component(radiance) > 0.0; }
    // Delta lobes: sampled directly, no pdf machinery, no light sampling at the vertex.
    bool is_delta() const { return type == MaterialType::Metal || type == MaterialType::Dielectric; }
    bool is_glass() const { return type == MaterialType::Dielectric; }
};

// M, in the functions below: a self-test mutant (mutants.h); Mutant::None is the tracer.

// f * cos for a non-delta material in its local frame (wo.z > 0 assumed by the caller).
template <Mutant M = Mutant::None>
inline Vec3 bsdf_eval(const Material& m, const Vec3& wo, const Vec3& wi) {
    switch (m.type) {
        case MaterialType::Lambertian:
        case MaterialType::DiffuseLight: return lambertian::eval<M>(m.albedo, wo, wi);
        case MaterialType::RoughConductor: return rough_conductor::eval<M>(m.albedo, m.rough(), wo, wi);
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
        default: return 0.0;
    }
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
