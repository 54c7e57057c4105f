// Axis-aligned bounding box and a robust slab test.
#pragma once

#include "math.h"

namespace rt {

struct AABB {
    Vec3 lo{kInf, kInf, kInf};
    Vec3 hi{-kInf, -kInf, -kInf};

    void expand(const Vec3& p) { lo = vmin(lo, p); hi = vmax(hi, p); }
    void expand(const AABB& b) { lo = vmin(lo, b.lo); hi = vmax(hi, b.hi); }
    Vec3 centroid() const { return (lo + hi) * 0.5; }
    Vec3 extent() const { return hi - lo; }
    bool valid() const { return lo.x <= hi.x && lo.y <= hi.y && lo.z <= hi.z; }
    double surface_area() const {
        if (!valid()) return 0.0;
        const Vec3 e = extent();
        return 2.0 * (e.x * e.y + e.y * e.z + e.z * e.x);
    }
    int longest_axis() const {
        const Vec3 e = extent();
        return (e.x >= e.y && e.x >= e.z) ? 0 : (e.y >= e.z ? 1 : 2);
    }
};

// Per-ray constants for slab tests.
struct RayInv {
    Vec3 o, inv_d;
    int neg[3];
    explicit RayInv(const Ray& r) : o(r.o), inv_d(1.0 / r.d.x, 1.0 / r.d.y, 1.0 / r.d.z) {
        neg[0] = inv_d.x < 0; neg[1] = inv_d.y < 0; neg[2] = inv_d.z < 0;
    }
};

// Slab test against [t_min, t_max]. Flat boxes (a quad's zero thickness) give t0 == t1 and
// still hit. When the origin lies exactly on a slab plane of a ray parallel to it, 0 * inf
// gives NaN; the comparisons below are false for NaN, so that axis is treated as
// unbounded: conservative (the primitive test decides), never a missed hit. t_far is
// widened by a few ulps (pbrt's 1 + 2 gamma(3)) so rounding cannot reject a true hit.
inline bool slab_hit(const AABB& b, const RayInv& r, double t_min, double t_max) {
    constexpr double kWiden = 1.0 + 8.0 * std::numeric_limits<double>::epsilon();
    for (int a = 0; a < 3; ++a) {
        const double lo = r.neg[a] ? b.hi[a] : b.lo[a];
        const double hi = r.neg[a] ? b.lo[a] : b.hi[a];
        const double t0 = (lo - r.o[a]) * r.inv_d[a];
        const double t1 = (hi - r.o[a]) * r.inv_d[a] * kWiden;
        t_min = t0 > t_min ? t0 : t_min;
        t_max = t1 < t_max ? t1 : t_max;
        if (t_min > t_max) return false;
    }
    return true;
}

}  // namespace rt
