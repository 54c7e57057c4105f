// Sphere: ray intersection with a cancellation-free discriminant (pbrt-v4 / Haines et al.,
// "Precision Improvements for Ray/Sphere Intersection", Ray Tracing Gems 2019).
#pragma once

#include "../aabb.h"
#include "../math.h"

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

    // Exact point on the sphere and its front-facing normal, for a hit at ray parameter t:
    // the point is re-projected onto the surface to remove the error of o + t d.
    void surface(const Vec3& p_approx, Vec3& p, Vec3& n) const {
        Vec3 d = p_approx - center;
        const double len = length(d);
        d = len > 0 ? d / len : Vec3(0, 0, 1);
        p = center + radius * d;
        n = d * normal_sign;
    }
};

}  // namespace rt
