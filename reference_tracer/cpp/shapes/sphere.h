// Sphere: ray intersection with a cancellation-free discriminant (pbrt-v4 / Haines et al.,
// "Precision Improvements for Ray/Sphere Intersection", Ray Tracing Gems 2019).
#pragma once

#include "../aabb.h"
#include "../math.h"
#include "../simd.h"

namespace rt {

struct Sphere {
    Vec3 center;
    double radius;
    double normal_sign;  // +1: outward normals (front outside); -1: flip_normals
    uint32_t material;

    AABB bounds() const {
        AABB b;
        b.expand(center - Vec3(radius));
        b.expand(center + Vec3(radius));
        return b;
    }
    double area() const { return 4.0 * kPi * radius * radius; }

    // The nearest t in (t_min, t_max) where rays (o, d) meet the sphere, on lanes of type F
    // (simd.h: double for one ray, a pack for several): lanes where one does, with t_max
    // lowered there to the hit's distance. One body for every width, each lane doing one
    // ray's operations in its order (the build forbids FMA contraction).
    template <typename F>
    [[gnu::always_inline]] MaskOf<F> hit(const F (&o)[3], const F (&d)[3], F t_min, F& t_max) const {
        return hit(o, d, reciprocal_length_squared(d), t_min, t_max);
    }
    // 1 / |d|^2 of the rays, which a pack of rays shares across every sphere it meets: the
    // test multiplies by it where it would divide by |d|^2 (a pack's divisions wait on the
    // divider one after another, and most packs miss most spheres).
    template <typename F>
    static F reciprocal_length_squared(const F (&d)[3]) {
        return 1.0 / (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    }
    template <typename F>
    [[gnu::always_inline]] MaskOf<F> hit(const F (&o)[3], const F (&d)[3], F inv_a, F t_min, F& t_max) const {
        const F L[3] = {center.x - o[0], center.y - o[1], center.z - o[2]};
        const F a = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        const F h = d[0] * L[0] + d[1] * L[1] + d[2] * L[2];
        // r^2 - |L - (h/a) d|^2 equals the discriminant / a, without catastrophic
        // cancellation when the sphere is small and far away.
        const F ha = h * inv_a;
        const F f[3] = {L[0] - ha * d[0], L[1] - ha * d[1], L[2] - ha * d[2]};
        const F disc = radius * radius - (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
        const auto met = (disc < 0.0) == 0;
        // Lanes that all miss (most packs against a small light) skip the square root and
        // the division of the roots.
        if (lane_mask(met) == 0) return MaskOf<F>{};
        const F c = (L[0] * L[0] + L[1] * L[1] + L[2] * L[2]) - radius * radius;
        // Lanes with disc < 0 take the square root of a negative number; they are masked
        // out below.
        const F q = h + copysign_lanes(sqrt_of(a * disc), h);
        const auto q_zero = q == 0.0;
        const F t0 = q_zero ? F{} : c / q;
        const F t1 = q_zero ? F{} : q * inv_a;
        const auto swap = t0 > t1;
        const F lo = swap ? t1 : t0, hi = swap ? t0 : t1;
        const MaskOf<F> hit0 = met & (lo > t_min) & (lo < t_max);
        const MaskOf<F> hit1 = met & (hit0 == 0) & (hi > t_min) & (hi < t_max);
        t_max = hit0 ? lo : (hit1 ? hi : t_max);
        return hit0 | hit1;
    }

    // hit() on one ray, and on a pack of rays (t_min 0).
    bool intersect(const Ray& r, double t_min, double t_max, double& t_hit) const {
        return hit_one(*this, r, t_min, t_max, t_hit);
    }
    VPl intersect_pack(const RayPack& r, VPd inv_a, VPd& t_max) const {
        const VPd o[3] = {r.ox, r.oy, r.oz}, d[3] = {r.dx, r.dy, r.dz};
        return hit(o, d, inv_a, VPd{}, t_max);
    }

    // The exact point p on a sphere and its front-facing normal n, for a hit at p_approx:
    // the point is re-projected onto the surface to remove the error of o + t d. On lanes
    // of type F (simd.h: double for one point, a pack for several), each lane on its own
    // sphere (centre, radius, normal_sign lane by lane): one body for every width.
    template <typename F>
    static void surface_lanes(const F (&p_approx)[3], const F (&center)[3], F radius, F normal_sign, F (&p)[3],
                              F (&n)[3]) {
        F d[3];
        for (int a = 0; a < 3; ++a) d[a] = p_approx[a] - center[a];
        const F len = sqrt_of(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);  // length(d)
        const auto pos = len > 0.0;
        const F inv = 1.0 / len;  // Vec3 / double multiplies by the reciprocal
        d[0] = pos ? d[0] * inv : F{};
        d[1] = pos ? d[1] * inv : F{};
        d[2] = pos ? d[2] * inv : as_lanes(1.0, len);
        for (int a = 0; a < 3; ++a) {
            p[a] = center[a] + d[a] * radius;
            n[a] = d[a] * normal_sign;
        }
    }

    void surface(const Vec3& p_approx, Vec3& p, Vec3& n) const {
        const double at[3] = {p_approx.x, p_approx.y, p_approx.z}, c[3] = {center.x, center.y, center.z};
        double pp[3], nn[3];
        surface_lanes(at, c, radius, normal_sign, pp, nn);
        p = Vec3(pp[0], pp[1], pp[2]);
        n = Vec3(nn[0], nn[1], nn[2]);
    }
};

}  // namespace rt
