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

    // The test on lanes of rays (o, d) of type F (simd.h: double for one ray, a pack for
    // several): lanes where the ray meets the quad at t in (t_min, t_max), with t_max
    // lowered there to the hit's distance. One body for every width, each lane doing one
    // ray's operations in its order (the build forbids contracting them into FMAs other
    // than mul_add's); no early exit, which a lane cannot take alone: where denom is 0, t
    // is infinite or NaN and fails t_min < t < t_max.
    template <typename F>
    [[gnu::always_inline]] MaskOf<F> hit(const F (&o)[3], const F (&d)[3], F t_min, F& t_max) const {
        const F denom = dot_lanes(normal, d);
        // The planar coordinates of o + t d are a0 + t ad and b0 + t bd: the four dot
        // products do not depend on t, so they overlap the division's latency instead of
        // waiting for it.
        const F oq[3] = {o[0] - Q.x, o[1] - Q.y, o[2] - Q.z};
        const F a0 = dot_lanes(ea, oq), ad = dot_lanes(ea, d);
        const F b0 = dot_lanes(eb, oq), bd = dot_lanes(eb, d);
        const F t = (plane_d - dot_lanes(normal, o)) / denom;
        const F alpha = mul_add(t, ad, a0);
        const F beta = mul_add(t, bd, b0);
        return accept(t, t_min, alpha, beta, t_max);
    }

    // hit() on one ray, and on a pack of rays (t_min 0).
    bool intersect(const Ray& r, double t_min, double t_max, double& t_hit) const {
        return hit_one(*this, r, t_min, t_max, t_hit);
    }
    VPl intersect_pack(const RayPack& r, VPd& t_max) const { return hit_pack(*this, r, t_max); }

    // dot_fused(a, v) on lanes of v.
    template <typename F>
    static F dot_lanes(const Vec3& a, const F (&v)[3]) {
        return mul_add(as_lanes(a.z, v[2]), v[2], mul_add(as_lanes(a.y, v[1]), v[1], a.x * v[0]));
    }

    // The lanes where t lies in (t_min, t_max) and the planar coordinates in [0, 1], with
    // t_max lowered to t there. Written as the rejections, so that a NaN coordinate passes.
    template <typename F>
    static MaskOf<F> accept(F t, F t_min, F alpha, F beta, F& t_max) {
        const auto outside = (alpha < 0.0) | (alpha > 1.0) | (beta < 0.0) | (beta > 1.0);
        const MaskOf<F> in = (t > t_min) & (t < t_max) & (outside == 0);
        t_max = in ? t : t_max;
        return in;
    }
#if defined(__AVX512F__)
    // The same six comparisons chained through a mask register, each one masked by the
    // ones before, and the blend by that register: GCC combined the masks of the portable
    // form in general registers on AVX-512 (a dozen moves between the two kinds per quad).
    // "Not less than" and "not greater than" are true for NaN, as the portable form's
    // negated rejections.
    static V8l accept(V8d t, V8d t_min, V8d alpha, V8d beta, V8d& t_max) {
        const __m512d T = reinterpret_cast<__m512d>(t), A = reinterpret_cast<__m512d>(alpha),
                      B = reinterpret_cast<__m512d>(beta), zero = _mm512_setzero_pd(), one = _mm512_set1_pd(1.0);
        __mmask8 in = _mm512_cmp_pd_mask(T, reinterpret_cast<__m512d>(t_min), _CMP_GT_OQ);
        in = _mm512_mask_cmp_pd_mask(in, T, reinterpret_cast<__m512d>(t_max), _CMP_LT_OQ);
        in = _mm512_mask_cmp_pd_mask(in, A, zero, _CMP_NLT_UQ);
        in = _mm512_mask_cmp_pd_mask(in, A, one, _CMP_NGT_UQ);
        in = _mm512_mask_cmp_pd_mask(in, B, zero, _CMP_NLT_UQ);
        in = _mm512_mask_cmp_pd_mask(in, B, one, _CMP_NGT_UQ);
        t_max = reinterpret_cast<V8d>(_mm512_mask_blend_pd(in, reinterpret_cast<__m512d>(t_max), T));
        return reinterpret_cast<V8l>(_mm512_maskz_mov_epi64(in, _mm512_set1_epi64(-1)));
    }
#endif

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
        const VPd o[3] = {r.ox, r.oy, r.oz}, d[3] = {r.dx, r.dy, r.dz};
        const VPd denom = dot_lanes(normal, d);
        const VPd num = plane_d - dot_lanes(normal, o);
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
