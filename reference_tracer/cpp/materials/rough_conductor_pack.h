// rough_conductor::sample (plain GGX, Fresnel 1) for a pack of vertices at once (simd.h),
// for the wavefront integrator: each lane does the scalar functions' operations in their
// order (lane-wise square roots and divisions are IEEE like the scalar ones, the build
// forbids contraction), with their early returns as selections, so that every lane's sample
// is the scalar one's bit for bit. A sample's four normalisations, its masking terms and
// densities are a score of square roots and divisions: one lane at a time they queue on the
// divider, a pack at a time they share it.
#pragma once

#include "../sampling/warp.h"
#include "../simd.h"

namespace rt::rough_conductor {

// std::max(0.0, x), with its selection ((0.0 < x) ? x : 0.0; NaN gives 0).
inline VPd max_zero(VPd x) { return 0.0 < x ? x : VPd{}; }

// normalize(v): v times the reciprocal of its length.
inline void normalize_pack(VPd (&v)[3]) {
    const VPd inv = 1.0 / sqrt_of(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    for (int a = 0; a < 3; ++a) v[a] = v[a] * inv;
}

// ggx_d(m, alpha).
inline VPd ggx_d_pack(const VPd (&m)[3], VPd alpha) {
    const VPd a2 = alpha * alpha;
    const VPd c2 = m[2] * m[2];
    const VPd denom = c2 * (a2 - 1.0) + 1.0;
    const VPd d = a2 / (kPi * denom * denom);
    return m[2] <= 0.0 ? VPd{} : d;
}

// smith_g1(v, m, alpha).
inline VPd smith_g1_pack(const VPd (&v)[3], const VPd (&m)[3], VPd alpha) {
    const VPd vm = v[0] * m[0] + v[1] * m[1] + v[2] * m[2];
    const VPd c2 = v[2] * v[2];
    const VPd tan2 = max_zero(1.0 - c2) / c2;
    const VPd g = 2.0 / (1.0 + sqrt_of(1.0 + alpha * alpha * tan2));
    return vm * v[2] <= 0.0 ? VPd{} : g;
}

// sample_visible_normal(wo, alpha, u1, u2).
inline void sample_visible_normal_pack(const VPd (&wo)[3], VPd alpha, VPd u1, VPd u2, VPd (&m)[3]) {
    VPd vh[3] = {alpha * wo[0], alpha * wo[1], wo[2]};
    normalize_pack(vh);
    const VPd len2 = vh[0] * vh[0] + vh[1] * vh[1];
    const VPl tilted = len2 > 0.0;
    const VPd inv = 1.0 / sqrt_of(len2);
    // Vec3(-vh.y, vh.x, 0) / sqrt(len2), or (1, 0, 0); the z of both is +0.
    const VPd t1[3] = {tilted ? -vh[1] * inv : splat(1.0), tilted ? vh[0] * inv : VPd{}, VPd{}};
    const VPd t2[3] = {vh[1] * t1[2] - vh[2] * t1[1], vh[2] * t1[0] - vh[0] * t1[2], vh[0] * t1[1] - vh[1] * t1[0]};
    const VPd r = sqrt_of(u1);
    VPd sin_phi, cos_phi;
    sincos_turn(u2, sin_phi, cos_phi);
    const VPd p1 = r * cos_phi;
    const VPd s = 0.5 * (1.0 + vh[2]);
    const VPd p2 = (1.0 - s) * safe_sqrt_of(1.0 - p1 * p1) + s * r * sin_phi;
    const VPd lift = safe_sqrt_of(1.0 - p1 * p1 - p2 * p2);
    VPd nh[3];
    for (int a = 0; a < 3; ++a) nh[a] = t1[a] * p1 + t2[a] * p2 + vh[a] * lift;
    m[0] = alpha * nh[0];
    m[1] = alpha * nh[1];
    m[2] = max_zero(nh[2]);
    normalize_pack(m);
}

// sample(albedo, alpha, wo, u1, u2) for the lanes of a pack: wi and weight of the valid
// lanes (bits returned), pdf everywhere (any value where the sample is not valid).
inline unsigned sample_pack(const VPd (&albedo)[3], VPd alpha, const VPd (&wo)[3], VPd u1, VPd u2, VPd (&wi)[3],
                            VPd (&weight)[3], VPd& pdf) {
    VPd m[3];
    sample_visible_normal_pack(wo, alpha, u1, u2, m);
    const VPd k = 2.0 * (wo[0] * m[0] + wo[1] * m[1] + wo[2] * m[2]);
    for (int a = 0; a < 3; ++a) wi[a] = m[a] * k - wo[a];
    // pdf(alpha, wo, wi) and eval(albedo, alpha, wo, wi) share their half vector (the same
    // operations in each).
    VPd h[3];
    for (int a = 0; a < 3; ++a) h[a] = wo[a] + wi[a];
    normalize_pack(h);
    const VPd d = ggx_d_pack(h, alpha);
    const VPd g1_o = smith_g1_pack(wo, h, alpha);
    const VPd cos4 = 4.0 * wo[2];
    pdf = g1_o * d / cos4;
    const VPd value = d * g1_o * smith_g1_pack(wi, h, alpha) / cos4;
    const VPd inv_pdf = 1.0 / pdf;
    for (int a = 0; a < 3; ++a) weight[a] = albedo[a] * value * inv_pdf;
    // sample()'s returns: wo from below, wi below, a density that is not positive (pdf()'s
    // own zero where a cosine is not positive included).
    return lane_mask((wo[2] > 0.0) & (wi[2] > 0.0) & (pdf > 0.0));
}

}  // namespace rt::rough_conductor
