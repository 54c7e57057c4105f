// Fresnel reflectance of a conductor of complex index eta + i k, unpolarised, per RGB
// channel (Mitsuba's fresnel_conductor; its named materials are RGB eta and k). A
// conductor without eta and k reflects everything (Fresnel 1: Mitsuba's material='none').
#pragma once

#include "../math.h"

namespace rt {

struct ConductorFresnel {
    bool enabled = false;  // false: Fresnel 1
    Vec3 eta, k;

    // Reflectance at cos_i >= 0 (the angle to the microfacet or surface normal).
    Vec3 eval(double cos_i) const {
        if (!enabled) return Vec3(1.0);
        Vec3 f;
        for (int c = 0; c < 3; ++c) f[c] = channel(cos_i, eta[c], k[c]);
        return f;
    }

    static double channel(double cos_i, double eta, double k) {
        const double c2 = cos_i * cos_i, s2 = 1.0 - c2, s4 = s2 * s2;
        const double t1 = eta * eta - k * k - s2;
        const double a2b2 = std::sqrt(t1 * t1 + 4.0 * eta * eta * k * k);
        const double a = std::sqrt(std::max(0.0, 0.5 * (a2b2 + t1)));
        const double rs = (a2b2 + c2 - 2.0 * cos_i * a) / (a2b2 + c2 + 2.0 * cos_i * a);
        const double rp = rs * (a2b2 * c2 + s4 - 2.0 * cos_i * a * s2) / (a2b2 * c2 + s4 + 2.0 * cos_i * a * s2);
        return 0.5 * (rs + rp);
    }
};

}  // namespace rt
