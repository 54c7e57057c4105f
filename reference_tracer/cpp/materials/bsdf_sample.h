// What every BSDF returns, in the local shading frame (+z = the side the viewer is on for
// one- and two-sided reflectors; the material's front side for glass).
#pragma once

#include "../math.h"

namespace rt {

struct BSDFSample {
    Vec3 wi;            // sampled direction toward the next vertex (local frame)
    Vec3 weight;        // f * |cos| / pdf, including any radiance scaling (glass)
    double pdf = 0.0;   // solid-angle density; meaningless for delta lobes
    double eta = 1.0;   // relative index of refraction crossed (Mitsuba's bs.eta)
    bool delta = false; // sampled a Dirac lobe
    bool valid = false;
};

}  // namespace rt
