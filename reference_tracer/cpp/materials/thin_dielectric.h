// Thin dielectric sheet (Mitsuba `thindielectric`): a pane of glass so thin that light
// leaves it where it entered, undeflected. Reflection sums the light bounced back by the
// pane's two faces over all internal round trips, R' = R + T^2 R / (1 - R^2) = 2R / (1 + R)
// with R the Fresnel reflectance of one face; the rest passes straight through. Both
// lobes are Dirac, and both sides alike: the frame is the viewer's (+z toward wo).
#pragma once

#include "bsdf_sample.h"
#include "dielectric.h"

namespace rt::thin_dielectric {

// Reflectance of the whole pane at |cos| = cos_i, for relative index eta.
inline double reflectance(double cos_i, double eta) {
    const double r = dielectric::fresnel(std::abs(cos_i), eta).F;
    return 2.0 * r / (1.0 + r);
}

inline BSDFSample sample(double eta, const Vec3& wo, double u0) {
    BSDFSample s;
    if (wo.z == 0.0) return s;
    s.delta = true;
    s.valid = true;
    s.weight = Vec3(1.0);  // each lobe chosen with its own probability: the weight is 1
    s.eta = 1.0;           // the path leaves in the medium it came from
    s.wi = u0 <= reflectance(wo.z, eta) ? Vec3(-wo.x, -wo.y, wo.z) : -wo;
    return s;
}

}  // namespace rt::thin_dielectric
