// Quad (parallelogram Q + a u + b v, a, b in [0, 1]); front face along u x v.
#pragma once

#include "../aabb.h"
#include "../math.h"
#include "../simd.h"

namespace rt {

struct Quad {
    Vec3 Q, u, v;
    Vec3 normal;    // unit u x v
    Vec3 w;         // (u x v) / |u x v|^2, to solve for the planar coordinates
    // Planar coordinates as linear functions of the hit point: alpha = dot(p - Q, ea),
    // beta = dot(p - Q, eb) (the triple products dot(w, (p - Q) x v) and dot(w, u x (p - Q))
    // rearranged), so that their ray-dependent parts are computed alongside the division.
    Vec3 ea, eb;
    double plane_d; // dot(normal, Q)
    double area_;
    uint32_t material;

    Quad(const Vec3& Q_, const Vec3& u_, const Vec3& v_, uint32_t material_)
        : Q(Q_), u(u_), v(v_), material(material_) {
        const Vec3 n = cross(u, v);
        area_ = length(n);
        normal = n / area_;
        w = n / dot(n, n);
        plane_d = dot(normal, Q);
        ea = cross(v, w);
        eb = cross(w, u);
    }

    AABB bounds() const {
        AABB b;
        b.expand(Q); b.expand(Q + u); b.expand(Q + v); b.expand(Q + u + v);
        return b;
    }
    double area() const { return area_; }

    bool intersect(const Ray& r, double t_min, double t_max, double& t_hit) const {
        const double denom = dot_fused(normal, r.d);
        if (denom == 0.0) return false;  // parallel to the plane: never a hit
        // The planar coordinates of o + t d are a0 + t ad and b0 + t bd: the four dot
        // products do not depend on t, so they overlap the division's latency instead of
        // waiting for it (the former test formed o + t d, then two cross products).
        const Vec3 oq = r.o - Q;
        const double a0 = dot_fused(oq, ea), ad = dot_fused(r.d, ea);
        const double b0 = dot_fused(oq, eb), bd = dot_fused(r.d, eb);
        const double t = (plane_d - dot_fused(normal, r.o)) / denom;
        if (!(t > t_min && t < t_max)) return false;
        const double alpha = mul_add(t, ad, a0);
        const double beta = mul_add(t, bd, b0);
        if (alpha < 0.0 || alpha > 1.0 || beta < 0.0 || beta > 1.0) return false;
        t_hit = t;
        return true;
    }

    // dot_fused(a, (x, y, z)) lane by lane.
    static VPd dot_lanes(const Vec3& a, VPd x, VPd y, VPd z) {
        return mul_add(splat(a.z), z, mul_add(splat(a.y), y, a.x * x));
    }

    // The test above on a pack of rays at once (simd.h) (t_min 0): lanes where it hits, with t_max
    // lowered there to the hit's distance. Each lane is bit-identical to intersect(): the
    // same operations in the same order (the build forbids contracting them into FMAs
    // other than mul_add's), only without its early exits, which a lane cannot take alone.
    VPl intersect_pack(const RayPack& r, VPd& t_max) const {
        const VPd denom = dot_lanes(normal, r.dx, r.dy, r.dz);
        const VPd oqx = r.ox - Q.x, oqy = r.oy - Q.y, oqz = r.oz - Q.z;
        const VPd a0 = dot_lanes(ea, oqx, oqy, oqz), ad = dot_lanes(ea, r.dx, r.dy, r.dz);
        const VPd b0 = dot_lanes(eb, oqx, oqy, oqz), bd = dot_lanes(eb, r.dx, r.dy, r.dz);
        const VPd t = (plane_d - dot_lanes(normal, r.ox, r.oy, r.oz)) / denom;
        const VPd alpha = mul_add(t, ad, a0);
        const VPd beta = mul_add(t, bd, b0);
        // Written as intersect() rejects, so that a NaN coordinate passes as it does there.
        // No test of denom: where it is 0, t is infinite or NaN and fails 0 < t < t_max.
#if RT_PACK == 8 && defined(__AVX512F__)
        // The same six comparisons chained through a mask register, each one masked by the
        // ones before: GCC combined the masks of the portable form below in general
        // registers (a dozen moves between the two kinds per quad). "Not less than" and
        // "not greater than" are true for NaN, as the portable form's negated rejects.
        const __m512d T = reinterpret_cast<__m512d>(t), A = reinterpret_cast<__m512d>(alpha),
                      B = reinterpret_cast<__m512d>(beta), zero = _mm512_setzero_pd(), one = _mm512_set1_pd(1.0);
        __mmask8 hit = _mm512_cmp_pd_mask(T, zero, _CMP_GT_OQ);
        hit = _mm512_mask_cmp_pd_mask(hit, T, reinterpret_cast<__m512d>(t_max), _CMP_LT_OQ);
        hit = _mm512_mask_cmp_pd_mask(hit, A, zero, _CMP_NLT_UQ);
        hit = _mm512_mask_cmp_pd_mask(hit, A, one, _CMP_NGT_UQ);
        hit = _mm512_mask_cmp_pd_mask(hit, B, zero, _CMP_NLT_UQ);
        hit = _mm512_mask_cmp_pd_mask(hit, B, one, _CMP_NGT_UQ);
        t_max = reinterpret_cast<VPd>(_mm512_mask_blend_pd(hit, reinterpret_cast<__m512d>(t_max), T));
        return reinterpret_cast<VPl>(_mm512_maskz_mov_epi64(hit, _mm512_set1_epi64(-1)));
#else
        const VPl outside = (alpha < 0.0) | (alpha > 1.0) | (beta < 0.0) | (beta > 1.0);
        const VPl hit = (t > 0.0) & (t < t_max) & ~outside;
        t_max = hit ? t : t_max;
        return hit;
#endif
    }

    // Lanes (bits) whose segment from the origin to t_max stays strictly on one side of
    // the quad's plane, so that intersect_pack could not report a hit there: a shadow ray
    // between two points of a closed room never crosses its walls. num and denom are
    // intersect_pack's, bit for bit: a lane with num < 0 has the origin in front (num is
    // plane_d - n.o, exactly the negated signed distance); if denom >= 0 its t is negative
    // (or NaN), else t = num / denom exceeds t_max as soon as the far end o + t_max d is in
    // front by more than 1e-9 of the origin's distance: the computed far distance errs by a
    // few 1e-16 of it, and the division rounds t by less than 1e-16. The same with both
    // signs flipped.
    unsigned same_side_lanes(const RayPack& r, VPd t_max) const {
        const VPd denom = dot_lanes(normal, r.dx, r.dy, r.dz);
        const VPd num = plane_d - dot_lanes(normal, r.ox, r.oy, r.oz);
        const VPd far = mul_add(t_max, denom, -num);  // the far end's signed distance, times |n|
        const VPd margin = 1e-9 * num;
        return lane_mask(((num < 0.0) & (far > -margin)) | ((num > 0.0) & (far < -margin)));
    }

    // The point p of the quad at (a, b) of the unit square: uniform in area. F: double, or
    // lanes of points (simd.h), each lane computing what the double does.
    template <typename F>
    void point(F a, F b, F (&p)[3]) const {
        for (int k = 0; k < 3; ++k) p[k] = mul_add(b, as_lanes(v[k], a), mul_add(a, as_lanes(u[k], a), as_lanes(Q[k], a)));
    }
    Vec3 point(double a, double b) const {
        double p[3];
        point(a, b, p);
        return {p[0], p[1], p[2]};
    }
};

}  // namespace rt
