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

    // Nearest t in (t_min, t_max) where the ray meets the sphere.
    bool intersect(const Ray& r, double t_min, double t_max, double& t_hit) const {
        const Vec3 L = center - r.o;
        const double a = length_squared(r.d);
        const double h = dot(r.d, L);
        // r^2 - |L - (h/a) d|^2 equals the discriminant / a, without catastrophic
        // cancellation when the sphere is small and far away.
        const Vec3 f = L - (h / a) * r.d;
        const double disc = radius * radius - length_squared(f);
        if (disc < 0.0) return false;
        const double c = length_squared(L) - radius * radius;
        const double q = h + std::copysign(std::sqrt(a * disc), h);
        double t0 = c / q, t1 = q / a;
        if (q == 0.0) t0 = t1 = 0.0;
        if (t0 > t1) std::swap(t0, t1);
        if (t0 > t_min && t0 < t_max) { t_hit = t0; return true; }
        if (t1 > t_min && t1 < t_max) { t_hit = t1; return true; }
        return false;
    }

    // The test above on a pack of rays at once (simd.h) (t_min 0): lanes where it hits, with t_max
    // lowered there to the hit's distance. Each lane is bit-identical to intersect() (the
    // same operations in the same order; the build forbids FMA contraction).
    VPl intersect_pack(const RayPack& r, VPd& t_max) const {
        const VPd Lx = center.x - r.ox, Ly = center.y - r.oy, Lz = center.z - r.oz;
        const VPd a = r.dx * r.dx + r.dy * r.dy + r.dz * r.dz;
        const VPd h = r.dx * Lx + r.dy * Ly + r.dz * Lz;
        const VPd ha = h / a;
        const VPd fx = Lx - ha * r.dx, fy = Ly - ha * r.dy, fz = Lz - ha * r.dz;
        const VPd disc = radius * radius - (fx * fx + fy * fy + fz * fz);
        const VPl valid = ~(disc < 0.0);
        // A pack that misses in every lane (most packs against a small light) skips the
        // square root and the two divisions of the roots.
        if (lane_mask(valid) == 0) return VPl{};
        const VPd c = (Lx * Lx + Ly * Ly + Lz * Lz) - radius * radius;
        // Lanes with disc < 0 take the square root of a negative number; they are
        // masked out below, as intersect() returns before it.
        const VPd q = h + copysign_lanes(sqrt_of(a * disc), h);
        const VPl q_zero = q == 0.0;
        VPd t0 = q_zero ? VPd{} : c / q;
        VPd t1 = q_zero ? VPd{} : q / a;
        const VPl swap = t0 > t1;
        const VPd lo = swap ? t1 : t0, hi = swap ? t0 : t1;
        const VPl hit0 = valid & (lo > 0.0) & (lo < t_max);
        const VPl hit1 = valid & ~hit0 & (hi > 0.0) & (hi < t_max);
        t_max = hit0 ? lo : (hit1 ? hi : t_max);
        return hit0 | hit1;
    }

    // Exact point on the sphere and its front-facing normal, for a hit at ray parameter t:
    // the point is re-projected onto the surface to remove the error of o + t d.
    // surface_pack below does these operations lane-wise: keep the two alike (the
    // integrators' images must agree bit for bit).
    void surface(const Vec3& p_approx, Vec3& p, Vec3& n) const {
        Vec3 d = p_approx - center;
        const double len = length(d);
        d = len > 0 ? d / len : Vec3(0, 0, 1);
        p = center + radius * d;
        n = d * normal_sign;
    }

    // surface() for a pack of points, each on its own sphere (centre, radius, normal_sign
    // lane by lane): one square root and one division of a pack instead of one a lane.
    static void surface_pack(const VPd (&p_approx)[3], const VPd (&center)[3], VPd radius, VPd normal_sign,
                             VPd (&p)[3], VPd (&n)[3]) {
        VPd d[3];
        for (int a = 0; a < 3; ++a) d[a] = p_approx[a] - center[a];
        const VPd len = sqrt_of(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        const VPl pos = len > 0.0;
        const VPd inv = 1.0 / len;  // Vec3 / double multiplies by the reciprocal
        d[0] = pos ? d[0] * inv : VPd{};
        d[1] = pos ? d[1] * inv : VPd{};
        d[2] = pos ? d[2] * inv : splat(1.0);
        for (int a = 0; a < 3; ++a) {
            p[a] = center[a] + d[a] * radius;
            n[a] = d[a] * normal_sign;
        }
    }
};

}  // namespace rt
