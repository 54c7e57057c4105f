// Small value types: 3-vectors, rays, orthonormal frames.
// The core computes in double precision: the harness validates against Mitsuba, and
// double keeps geometric error far below Monte Carlo noise at every scene scale we test
// (1e-4 .. 1e5), with ray offsets proportional to the hit point's magnitude.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include "simd.h"

namespace rt {

constexpr double kPi = 3.14159265358979323846;
constexpr double kInvPi = 1.0 / kPi;
constexpr double kInf = std::numeric_limits<double>::infinity();

struct Vec3 {
    double x = 0, y = 0, z = 0;

    constexpr Vec3() = default;
    constexpr Vec3(double x_, double y_, double z_) : x(x_), y(y_), z(z_) {}
    explicit constexpr Vec3(double s) : x(s), y(s), z(s) {}

    double operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
    double& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }

    Vec3 operator-() const { return {-x, -y, -z}; }
    Vec3& operator+=(const Vec3& o) { x += o.x; y += o.y; z += o.z; return *this; }
    Vec3& operator*=(const Vec3& o) { x *= o.x; y *= o.y; z *= o.z; return *this; }
    Vec3& operator*=(double s) { x *= s; y *= s; z *= s; return *this; }
    Vec3& operator/=(double s) { return *this *= 1.0 / s; }
};

inline Vec3 operator+(const Vec3& a, const Vec3& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec3 operator-(const Vec3& a, const Vec3& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec3 operator*(const Vec3& a, const Vec3& b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }
inline Vec3 operator*(const Vec3& a, double s) { return {a.x * s, a.y * s, a.z * s}; }
inline Vec3 operator*(double s, const Vec3& a) { return a * s; }
inline Vec3 operator/(const Vec3& a, double s) { return a * (1.0 / s); }

inline double dot(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
// a * b + c in one rounding where the target has FMA instructions (one instruction instead
// of two), else in two. The lane-wise version (simd.h) makes the same choice, so that the
// scalar and batched shape tests agree bit for bit within a build; builds for CPUs with
// and without FMA may differ in the last bit of such results.
inline double mul_add(double a, double b, double c) {
#ifdef __FMA__
    return __builtin_fma(a, b, c);
#else
    return a * b + c;
#endif
}
// x, as a value the optimiser cannot see through. GCC 12 fuses the pair a*b - c*d and
// e*f + g*h into one vector fused multiply-add-subtract (its SLP vectoriser's add-sub
// pattern) even under -ffp-contract=off, and only where the code around the pair lets it
// vectorise the two: the same source then rounds differently depending on where it is
// inlined (the Beckmann sampler's rotation changed by an ulp when the material dispatch
// grew). A product passed through here is rounded on its own wherever it is inlined.
inline double unfused(double x) {
#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__))
    __asm__("" : "+x"(x));
#elif defined(__GNUC__)
    __asm__("" : "+m"(x));
#endif
    return x;
}
// dot(a, b) with two of its additions fused: x first, then y and z added by mul_add.
inline double dot_fused(const Vec3& a, const Vec3& b) { return mul_add(a.z, b.z, mul_add(a.y, b.y, a.x * b.x)); }
inline Vec3 cross(const Vec3& a, const Vec3& b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline double length_squared(const Vec3& a) { return dot(a, a); }
inline double length(const Vec3& a) { return std::sqrt(dot(a, a)); }
inline Vec3 normalize(const Vec3& a) { return a / length(a); }
inline double max_component(const Vec3& a) { return std::max(a.x, std::max(a.y, a.z)); }
// The next double above x, for x >= +0 (+inf stays): std::nextafter without its
// call (the closest-hit tie rule, Scene::closest_primitive, takes it per candidate).
inline double next_up(double x) {
    if (!(x < std::numeric_limits<double>::infinity())) return x;
    uint64_t bits;
    std::memcpy(&bits, &x, sizeof bits);
    ++bits;
    std::memcpy(&x, &bits, sizeof bits);
    return x;
}

inline double max_abs_component(const Vec3& a) {
    return std::max(std::abs(a.x), std::max(std::abs(a.y), std::abs(a.z)));
}
inline Vec3 vmin(const Vec3& a, const Vec3& b) { return {std::min(a.x, b.x), std::min(a.y, b.y), std::min(a.z, b.z)}; }
inline Vec3 vmax(const Vec3& a, const Vec3& b) { return {std::max(a.x, b.x), std::max(a.y, b.y), std::max(a.z, b.z)}; }
inline bool is_finite(const Vec3& a) { return std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(a.z); }
// c ? a : b, bit for bit, without a branch: for choices the CPU cannot predict (GCC turns
// the conditional operator on doubles into a jump). The choice is made on the bits.
inline double select_bits(bool c, double a, double b) {
    uint64_t ua, ub;
    std::memcpy(&ua, &a, sizeof ua);
    std::memcpy(&ub, &b, sizeof ub);
    const uint64_t take_a = uint64_t(0) - uint64_t(c);
    const uint64_t u = (ua & take_a) | (ub & ~take_a);
    double r;
    std::memcpy(&r, &u, sizeof r);
    return r;
}
inline Vec3 select_bits(bool c, const Vec3& a, const Vec3& b) {
    return {select_bits(c, a.x, b.x), select_bits(c, a.y, b.y), select_bits(c, a.z, b.z)};
}
inline bool is_black(const Vec3& a) { return a.x == 0.0 && a.y == 0.0 && a.z == 0.0; }
inline double luminance(const Vec3& c) { return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z; }

// Mirror reflection of d about n (both as seen in world space, d pointing into the surface).
inline Vec3 reflect(const Vec3& d, const Vec3& n) { return d - 2.0 * dot(d, n) * n; }

inline double safe_sqrt(double x) { return std::sqrt(std::max(0.0, x)); }

struct Ray {
    Vec3 o;
    Vec3 d;   // not necessarily unit length for shape tests; the integrator keeps it unit
    Vec3 at(double t) const { return o + t * d; }
};

// A shape's test written once over the lane type (Shape::hit<F>, simd.h), run on one ray:
// whether it meets the shape at t in (t_min, t_max), t then in t_hit.
template <typename Shape>
inline bool hit_one(const Shape& shape, const Ray& r, double t_min, double t_max, double& t_hit) {
    const double o[3] = {r.o.x, r.o.y, r.o.z}, d[3] = {r.d.x, r.d.y, r.d.z};
    if (!shape.hit(o, d, t_min, t_max)) return false;
    t_hit = t_max;
    return true;
}

// The same on a pack of rays (t_min 0): the lanes where it hits, t_max lowered there.
template <typename Shape>
inline VPl hit_pack(const Shape& shape, const RayPack& r, VPd& t_max) {
    const VPd o[3] = {r.ox, r.oy, r.oz}, d[3] = {r.dx, r.dy, r.dz};
    return shape.hit(o, d, VPd{}, t_max);
}

// Orthonormal basis around a unit normal (Duff et al. 2017, branchless and continuous).
// The tangents s and t of an orthonormal basis around the unit normal n (Duff et al.,
// "Building an Orthonormal Basis, Revisited", 2017: branchless). F: double (Frame), or a
// pack of normals (simd.h), each lane computing what the double does.
template <typename F>
inline void frame_tangents(const F (&n)[3], F (&s)[3], F (&t)[3]) {
    const F sign = copysign_lanes(as_lanes(1.0, n[2]), n[2]);
    const F a = -1.0 / (sign + n[2]);
    const F b = n[0] * n[1] * a;
    s[0] = 1.0 + sign * n[0] * n[0] * a;
    s[1] = sign * b;
    s[2] = -sign * n[0];
    t[0] = b;
    t[1] = sign + n[1] * n[1] * a;
    t[2] = -n[1];
}

struct Frame {
    Vec3 s, t, n;

    explicit Frame(const Vec3& normal) : n(normal) {
        const double nn[3] = {n.x, n.y, n.z};
        double ss[3], tt[3];
        frame_tangents(nn, ss, tt);
        s = Vec3(ss[0], ss[1], ss[2]);
        t = Vec3(tt[0], tt[1], tt[2]);
    }
    // With fused multiply-adds (mul_add): two thirds of the instructions, one rounding less.
    Vec3 to_local(const Vec3& v) const { return {dot_fused(v, s), dot_fused(v, t), dot_fused(v, n)}; }
    Vec3 to_world(const Vec3& v) const {
        return {mul_add(n.x, v.z, mul_add(t.x, v.y, s.x * v.x)), mul_add(n.y, v.z, mul_add(t.y, v.y, s.y * v.x)),
                mul_add(n.z, v.z, mul_add(t.z, v.y, s.z * v.x))};
    }
};

// Offset applied to ray origins leaving a surface, relative to the hit point's largest
// coordinate. Hit points are re-projected onto their primitive (Scene::fill_interaction),
// which leaves them within a few ulps of the surface whatever the ray's origin; 64 ulps
// of |p| clears that error with a wide margin while staying far below any geometric
// feature even for a scene 1e-3 across placed 1e5 from the origin (the offset there is
// 1.4e-9, a million times smaller than the scene).
constexpr double kRayEpsilon = 64.0 * std::numeric_limits<double>::epsilon();

// Origin for a ray leaving point p (geometric normal n) in direction d: pushed off the
// surface on the side d points to, so the ray cannot re-hit the surface it starts on.
// In two steps on lanes of type F (one ray, or a pack of the wavefront integrator's):
// offset_epsilon, the push for points p (relative to their largest coordinate, so that it
// clears the rounding of p at any scale), then offset_toward, p moved by it along n to the
// side of d. A pack computes the epsilon once for the two origins of a vertex.
// Always inline: called at every vertex from both integrators, GCC sometimes left it out
// of line (3-4% of the wavefront integrator's instructions as a call).
template <typename F>
[[gnu::always_inline]] inline F offset_epsilon(const F (&p)[3]) {
    F abs_p[3];
    for (int a = 0; a < 3; ++a) abs_p[a] = copysign_lanes(p[a], as_lanes(1.0, p[a]));
    const F max_yz = abs_p[1] < abs_p[2] ? abs_p[2] : abs_p[1];  // std::max's selection
    const F max_p = abs_p[0] < max_yz ? max_yz : abs_p[0];
    return kRayEpsilon * max_p + std::numeric_limits<double>::min();
}

template <typename F>
[[gnu::always_inline]] inline void offset_toward(const F (&p)[3], const F (&n)[3], const F (&d)[3], F eps,
                                                 F (&out)[3]) {
    const auto outward = n[0] * d[0] + n[1] * d[1] + n[2] * d[2] >= 0.0;  // dot(n, d) >= 0
    for (int a = 0; a < 3; ++a) out[a] = outward ? p[a] + n[a] * eps : p[a] - n[a] * eps;
}

[[gnu::always_inline]] inline Vec3 offset_origin(const Vec3& p, const Vec3& n, const Vec3& d) {
    const double pa[3] = {p.x, p.y, p.z}, na[3] = {n.x, n.y, n.z}, da[3] = {d.x, d.y, d.z};
    double out[3];
    offset_toward(pa, na, da, offset_epsilon(pa), out);
    return {out[0], out[1], out[2]};
}

}  // namespace rt
