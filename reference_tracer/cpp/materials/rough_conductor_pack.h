// rough_conductor::sample (plain GGX, Fresnel 1) for a pack of vertices at once (simd.h),
// for the wavefront integrator: the pieces of rough_conductor.h (sample_visible_normal,
// ggx_d, smith_g1, normalize_lanes) on the pack, composed as sample() composes them through
// pdf() and eval(), which share their half vector here, so that every lane's sample is the
// scalar one's bit for bit. A sample's four normalisations, its masking terms and densities
// are a score of square roots and divisions: one lane at a time they queue on the divider,
// a pack at a time they share it.
#pragma once

#include "../sampling/warp.h"
#include "../simd.h"
#include "rough_conductor.h"

namespace rt::rough_conductor {

// sample(albedo, alpha, wo, u1, u2) for the lanes of a pack (F: V4d or V8d): wi and
// weight of the valid lanes (bits returned), pdf everywhere (any value where the sample is
// not valid).
template <typename F>
inline unsigned sample_pack(const F (&albedo)[3], F alpha, const F (&wo)[3], F u1, F u2, F (&wi)[3], F (&weight)[3],
                            F& pdf) {
    F m[3];
    sample_visible_normal(wo, alpha, u1, u2, m);
    const F k = 2.0 * (wo[0] * m[0] + wo[1] * m[1] + wo[2] * m[2]);
    for (int a = 0; a < 3; ++a) wi[a] = m[a] * k - wo[a];
    // pdf(alpha, wo, wi) and eval(albedo, alpha, wo, wi) share their half vector (the same
    // operations in each).
    F h[3];
    for (int a = 0; a < 3; ++a) h[a] = wo[a] + wi[a];
    normalize_lanes(h);
    const F d = ggx_d(h, alpha);
    const F g1_o = smith_g1(wo, h, alpha);
    const F cos4 = 4.0 * wo[2];
    pdf = g1_o * d / cos4;
    const F value = d * g1_o * smith_g1(wi, h, alpha) / cos4;
    const F inv_pdf = 1.0 / pdf;
    for (int a = 0; a < 3; ++a) weight[a] = albedo[a] * value * inv_pdf;
    // sample()'s returns: wo from below, wi below, a density that is not positive (pdf()'s
    // own zero where a cosine is not positive included).
    return lane_mask((wo[2] > 0.0) & (wi[2] > 0.0) & (pdf > 0.0));
}

}  // namespace rt::rough_conductor
