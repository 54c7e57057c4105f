// Smooth plastic (Mitsuba `plastic`): a diffuse base under a smooth dielectric coating of
// relative index eta = int_ior / ext_ior. Two lobes, front side only:
//  - the coating's specular reflection, a Dirac delta of weight F(cos_o) ks, and
//  - the light that refracts in, scatters off the base any number of times (the base's
//    reflectance rho divided by 1 - Fi, Fi the coating's internal diffuse reflectance;
//    `nonlinear`: by 1 - rho Fi, the exact sum of the geometric series), and refracts out:
//    f cos = rho' cos_i / pi (1 - F(cos_o)) (1 - F(cos_i)) / eta^2.
// bsdf_eval and bsdf_pdf give the diffuse lobe only, as Mitsuba's do: the Dirac lobe is
// reached by sampling alone (BSDFSample::delta), so the integrator takes a light sample at
// a plastic vertex for the diffuse lobe and treats a specular sample as a mirror bounce.
// The lobe is chosen with probability proportional to F sw and (1 - F)(1 - sw), sw the
// specular sampling weight from the reflectances' means (Mitsuba's choice, kept so that
// the noise is Mitsuba's too). Local frame: +z is the side the viewer is on.
#pragma once

#include "../sampling/warp.h"
#include "bsdf_sample.h"
#include "dielectric.h"

namespace rt::plastic {

// Hemispherical average of the Fresnel reflectance seen from a medium of relative index
// `eta` (Mitsuba's fresnel_diffuse_reflectance: Egan and Hilgeman's fit below 1, d'Eon
// and Irving's above). The coating's internal reflectance is this at 1 / eta.
inline double fresnel_diffuse_reflectance(double eta) {
    if (eta < 1.0) return -1.4399 * eta * eta + 0.7099 * eta + 0.6681 + 0.0636 / eta;
    const double x = 1.0 / eta;
    return 0.919317 + x * (-3.4793 + x * (6.75335 + x * (-7.80989 + x * (4.98554 - 1.36881 * x))));
}

// What the smooth and the rough plastic share: the coating and the base under it.
struct Coating {
    double eta = 1.49 / 1.000277;  // int_ior / ext_ior (Mitsuba's defaults)
    double inv_eta2 = 1.0;         // 1 / eta^2: the radiance scale of leaving the coating
    Vec3 specular{1.0};            // specular_reflectance, ks
    Vec3 diffuse;                  // rho': the base's reflectance with the internal scattering
    double specular_weight = 0.5;  // sw = mean(ks) / (mean(rho) + mean(ks))
    double internal_reflectance = 0.0;  // Fi
    bool nonlinear = false;

    // `internal_reflectance`: Fi (fresnel_diffuse_reflectance(1 / eta) for the smooth
    // coating, the rough one's own table for the rough).
    static Coating make(const Vec3& rho, const Vec3& ks, double eta, bool nonlinear, double internal_reflectance) {
        // Mitsuba's mean of an RGB value is the plain mean of its channels.
        return make(rho, ks, eta, nonlinear, internal_reflectance, (rho.x + rho.y + rho.z) / 3.0);
    }
    // The same with the mean of the base's reflectance given: a texture's (Mitsuba's
    // Texture::mean), which sets the lobe choice over the whole surface.
    static Coating make(const Vec3& rho, const Vec3& ks, double eta, bool nonlinear, double internal_reflectance,
                        double d_mean) {
        Coating c;
        c.eta = eta;
        c.inv_eta2 = 1.0 / (eta * eta);
        c.specular = ks;
        c.internal_reflectance = internal_reflectance;
        c.nonlinear = nonlinear;
        c.diffuse = c.base(rho);
        // A coating over a black base with black ks reflects nothing; any weight then does
        // (0/0 otherwise).
        const double s_mean = (ks.x + ks.y + ks.z) / 3.0;
        c.specular_weight = d_mean + s_mean > 0.0 ? s_mean / (d_mean + s_mean) : 0.5;
        return c;
    }

    // rho' of a base of reflectance rho under this coating.
    Vec3 base(const Vec3& rho) const {
        Vec3 d;
        for (int i = 0; i < 3; ++i)
            d[i] = rho[i] / (1.0 - (nonlinear ? rho[i] * internal_reflectance : internal_reflectance));
        return d;
    }

    // Probability of sampling the specular lobe when a share `s` of the light meets it (F
    // for the smooth coating, 1 - T for the rough). 0 where neither lobe can be chosen (a
    // black ks at total internal reflection): then nothing is reflected at all.
    double specular_probability(double s) const {
        const double ps = s * specular_weight, pd = (1.0 - s) * (1.0 - specular_weight);
        return ps + pd > 0.0 ? ps / (ps + pd) : 0.0;
    }

    double fresnel(double cos_i) const { return dielectric::fresnel(cos_i, eta).F; }
};

// f * cos of the diffuse lobe (the Dirac lobe has no value to evaluate).
inline Vec3 eval(const Coating& c, const Vec3& wo, const Vec3& wi) {
    if (!(wo.z > 0.0 && wi.z > 0.0)) return Vec3(0.0);
    return c.diffuse * (kInvPi * wi.z * c.inv_eta2 * (1.0 - c.fresnel(wo.z)) * (1.0 - c.fresnel(wi.z)));
}

// Density of the diffuse lobe's directions, times the probability of choosing that lobe.
inline double pdf(const Coating& c, const Vec3& wo, const Vec3& wi) {
    if (!(wo.z > 0.0 && wi.z > 0.0)) return 0.0;
    return (1.0 - c.specular_probability(c.fresnel(wo.z))) * cosine_hemisphere_pdf(wi.z);
}

// Probability of the Dirac lobe at wo: what a strategy that samples the other lobe its own
// way (uniform, mixture) must leave to it.
inline double delta_probability(const Coating& c, const Vec3& wo) {
    return wo.z > 0.0 ? c.specular_probability(c.fresnel(wo.z)) : 0.0;
}

// u0 chooses the lobe; (u1, u2) the diffuse direction.
inline BSDFSample sample(const Coating& c, const Vec3& wo, double u0, double u1, double u2) {
    BSDFSample s;
    if (!(wo.z > 0.0)) return s;
    const double f_o = c.fresnel(wo.z);
    const double p_specular = c.specular_probability(f_o);
    if (u0 < p_specular) {
        s.wi = Vec3(-wo.x, -wo.y, wo.z);
        s.weight = c.specular * (f_o / p_specular);
        s.pdf = p_specular;  // a probability, as Mitsuba's bs.pdf for this lobe
        s.delta = true;
        s.valid = true;
        return s;
    }
    const double p_diffuse = 1.0 - p_specular;
    s.wi = square_to_cosine_hemisphere(u1, u2);
    s.pdf = p_diffuse * cosine_hemisphere_pdf(s.wi.z);
    if (!(s.pdf > 0.0)) return s;
    // eval / pdf: the cosine over pi cancels.
    s.weight = c.diffuse * (c.inv_eta2 * (1.0 - f_o) * (1.0 - c.fresnel(s.wi.z)) / p_diffuse);
    s.valid = true;
    return s;
}

}  // namespace rt::plastic
