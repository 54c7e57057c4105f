// Beckmann microfacet distribution, as Mitsuba 3 defines it (render/microfacet.h): the
// normal distribution D, Smith's masking with Walter's rational approximation, and the
// sampling of visible normals by a numerical inversion of the slope CDF (the stretch,
// sample, rotate and unstretch steps of Heitz and d'Eon 2014). Isotropic: one alpha.
// The GGX counterparts live in rough_conductor.h, but for a second map of the square to
// GGX's visible normals, Mitsuba's, here. Local frame: +z the macrosurface normal.
#pragma once

#include <cmath>

#include "../math.h"
#include "../sampling/warp.h"

namespace rt {

enum class Distribution : int { GGX = 0, Beckmann = 1 };

namespace microfacet {

constexpr double kInvSqrtPi = 0.56418958354775628695;

// Inverse error function in double precision: Giles' single-precision approximation
// refined by two Newton steps on erf (each roughly doubles the correct digits).
inline double erfinv(double y) {
    if (!(y > -1.0)) return y == -1.0 ? -kInf : std::nan("");
    if (!(y < 1.0)) return y == 1.0 ? kInf : std::nan("");
    double w = -std::log((1.0 - y) * (1.0 + y)), x;
    if (w < 5.0) {
        w -= 2.5;
        double p = 2.81022636e-08;
        p = 3.43273939e-07 + p * w;
        p = -3.5233877e-06 + p * w;
        p = -4.39150654e-06 + p * w;
        p = 0.00021858087 + p * w;
        p = -0.00125372503 + p * w;
        p = -0.00417768164 + p * w;
        p = 0.246640727 + p * w;
        p = 1.50140941 + p * w;
        x = p * y;
    } else {
        w = std::sqrt(w) - 3.0;
        double p = -0.000200214257;
        p = 0.000100950558 + p * w;
        p = 0.00134934322 + p * w;
        p = -0.00367342844 + p * w;
        p = 0.00573950773 + p * w;
        p = -0.0076224613 + p * w;
        p = 0.00943887047 + p * w;
        p = 1.00167406 + p * w;
        p = 2.83297682 + p * w;
        x = p * y;
    }
    for (int i = 0; i < 2; ++i) {
        const double slope = 2.0 * kInvSqrtPi * std::exp(-x * x);
        if (!(slope > 0.0)) break;
        x -= (std::erf(x) - y) / slope;
    }
    return x;
}

inline double beckmann_d(const Vec3& m, double alpha) {
    const double c2 = m.z * m.z;
    if (!(c2 > 0.0)) return 0.0;
    const double a2 = alpha * alpha;
    const double d = std::exp(-(m.x * m.x + m.y * m.y) / (a2 * c2)) / (kPi * a2 * c2 * c2);
    return d * m.z > 1e-20 ? d : 0.0;  // Mitsuba's guard; also zero below the macrosurface
}

// Smith's masking, exact: 2 / (1 + erf(a) + exp(-a^2) / (a sqrt(pi))), a = 1 / (alpha tan).
// The density of the visible normals sampled below is D G1_exact (wo.m) / cos_o, so the
// sampling pdf uses this one; zero when v sees the back of the microfacet.
inline double beckmann_g1_exact(const Vec3& v, const Vec3& m, double alpha) {
    if (dot(v, m) * v.z <= 0.0) return 0.0;
    const double xy = alpha * alpha * (v.x * v.x + v.y * v.y);
    if (xy == 0.0) return 1.0;
    const double a = std::abs(v.z) / std::sqrt(xy);
    return 2.0 / (1.0 + std::erf(a) + std::exp(-a * a) / (a * 1.7724538509055160273));
}

// Smith's masking with Walter's rational approximation (< 0.35% error), as Mitsuba's BSDF
// value uses it; zero when v sees the back of the microfacet.
inline double beckmann_g1(const Vec3& v, const Vec3& m, double alpha) {
    if (dot(v, m) * v.z <= 0.0) return 0.0;
    const double xy = alpha * alpha * (v.x * v.x + v.y * v.y);
    if (xy == 0.0) return 1.0;  // perpendicular incidence
    const double a = std::abs(v.z) / std::sqrt(xy);
    if (a >= 1.6) return 1.0;
    return (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a);
}

// A slope of the alpha = 1 Beckmann distribution of visible normals at incidence cos_i.
inline void beckmann_visible_slope(double cos_i, double u1, double u2, double& sx, double& sy) {
    const double tan_i = safe_sqrt(1.0 - cos_i * cos_i) / cos_i;
    const double cot_i = 1.0 / tan_i;
    const double maxval = std::erf(cot_i);
    u1 = std::clamp(u1, 1e-6, 1.0 - 1e-6);
    u2 = std::clamp(u2, 1e-6, 1.0 - 1e-6);
    // the exact solution at grazing incidence as a start, then Newton on the CDF
    double x = maxval - (maxval + 1.0) * std::erf(std::sqrt(-std::log(u1)));
    u1 *= 1.0 + maxval + kInvSqrtPi * tan_i * std::exp(-cot_i * cot_i);
    for (int i = 0; i < 3; ++i) {
        const double slope = erfinv(x);
        const double value = 1.0 + x + kInvSqrtPi * tan_i * std::exp(-slope * slope) - u1;
        x -= value / (1.0 - slope * tan_i);
    }
    sx = erfinv(x);
    sy = erfinv(2.0 * u2 - 1.0);
}

// A visible microfacet normal for the view direction wo (wo.z > 0), given slope(cos, sx,
// sy), a slope of the distribution's alpha = 1 visible normals at incidence cos.
template <typename Slope>
inline Vec3 sample_visible_with(const Vec3& wo, double alpha, Slope&& slope) {
    const Vec3 s = normalize(Vec3(alpha * wo.x, alpha * wo.y, wo.z));  // stretch
    const double sin2 = 1.0 - s.z * s.z;
    double sin_phi = 0.0, cos_phi = 1.0;
    if (sin2 > 4.0 * 5.960464477539063e-08) {  // Mitsuba's threshold: 4 float epsilons
        const double inv = 1.0 / std::sqrt(sin2);
        sin_phi = std::clamp(s.y * inv, -1.0, 1.0);
        cos_phi = std::clamp(s.x * inv, -1.0, 1.0);
    }
    double sx, sy;
    slope(s.z, sx, sy);
    // rotate and unstretch; each product rounded on its own (see unfused)
    const double x = (unfused(cos_phi * sx) - unfused(sin_phi * sy)) * alpha;
    const double y = (unfused(sin_phi * sx) + unfused(cos_phi * sy)) * alpha;
    return normalize(Vec3(-x, -y, 1.0));
}

inline Vec3 beckmann_sample_visible(const Vec3& wo, double alpha, double u1, double u2) {
    return sample_visible_with(wo, alpha, [&](double c, double& sx, double& sy) {
        beckmann_visible_slope(c, u1, u2, sx, sy);
    });
}

// A slope of the alpha = 1 GGX distribution of visible normals at incidence cos_i > 0, by
// Mitsuba's map of the square: a point of the concentric disk, squeezed onto the part of
// the disk that the visible hemisphere projects to (Heitz 2018), lifted to it and turned
// into a slope. The density is that of rough_conductor::sample_visible_normal, which maps
// the square through polar coordinates instead; the rough plastic's tables integrate over
// the square through this map, so that their quadrature, and its error, are Mitsuba's.
inline void ggx_visible_slope(double cos_i, double u1, double u2, double& sx, double& sy) {
    const Vec3 disk = square_to_cosine_hemisphere(u1, u2);  // its (x, y): the concentric map
    const double s = 0.5 * (1.0 + cos_i);
    const double x = disk.x;
    const double y = (1.0 - s) * safe_sqrt(1.0 - x * x) + s * disk.y;
    const double z = safe_sqrt(1.0 - x * x - y * y);
    const double sin_i = safe_sqrt(1.0 - cos_i * cos_i);
    const double norm = 1.0 / (sin_i * y + cos_i * z);
    sx = (cos_i * y - sin_i * z) * norm;
    sy = x * norm;
}

inline Vec3 ggx_sample_visible(const Vec3& wo, double alpha, double u1, double u2) {
    return sample_visible_with(wo, alpha, [&](double c, double& sx, double& sy) {
        ggx_visible_slope(c, u1, u2, sx, sy);
    });
}

}  // namespace microfacet
}  // namespace rt
