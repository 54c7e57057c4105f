// Triangle a, b, c; counter-clockwise ((b - a) x (c - a)) is the front face.
// Three intersection tests, selectable per scene:
//  * watertight: Woop, Benthin and Wald, "Watertight Ray/Triangle Intersection" (JCGT 2013).
//    Edge functions of a shared edge are computed from the same sheared vertex
//    coordinates, so a ray can never pass between two triangles sharing that edge.
//  * cramer / cramer32: the seed's barycentric test, the 3x3 system
//    o + t d = a + b1 (b - a) + b2 (c - a) solved by Cramer's rule (Snyder and Barr 1987;
//    written with triple products as in Moller-Trumbore), in double or single precision.
#pragma once

#include <initializer_list>
#include <utility>

#ifdef __AVX__
#include <immintrin.h>
#endif

#include "../aabb.h"
#include "../math.h"
#include "../simd.h"

namespace rt {

enum class TriangleTest : int { Watertight = 0, Cramer = 1, Cramer32 = 2 };

struct Triangle {
    // `normals` of a triangle shaded flat: it has no vertex normals.
    static constexpr uint32_t kFlat = UINT32_MAX;

    Vec3 a, b, c;
    uint32_t material;
    // Index of its vertex normals in the scene's TriangleNormals (smooth shading), or
    // kFlat. It fills the padding after `material`: flat scenes pay nothing for it.
    uint32_t normals = kFlat;

    AABB bounds() const {
        AABB box;
        box.expand(a); box.expand(b); box.expand(c);
        return box;
    }
    Vec3 normal() const { return normalize(cross(b - a, c - a)); }
    double area() const { return 0.5 * length(cross(b - a, c - a)); }
    bool degenerate() const {
        const Vec3 n = cross(b - a, c - a);
        return !(length_squared(n) > 0.0) || !std::isfinite(length_squared(n));
    }

    // Uniform point from two uniform numbers (square-root warp).
    Vec3 point(double u1, double u2) const {
        const double su = std::sqrt(u1);
        return (1.0 - su) * a + (su * (1.0 - u2)) * b + (su * u2) * c;
    }
    // The same point with its barycentric coordinates (weights of a, b, c).
    Vec3 point(double u1, double u2, double (&w)[3]) const {
        const double su = std::sqrt(u1);
        w[0] = 1.0 - su;
        w[1] = su * (1.0 - u2);
        w[2] = su * u2;
        return w[0] * a + w[1] * b + w[2] * c;
    }
    // Barycentric coordinates (weights of a, b, c) of a point p in the triangle's plane.
    void barycentrics(const Vec3& p, double (&w)[3]) const {
        const Vec3 e1 = b - a, e2 = c - a, d = p - a;
        const double d11 = dot(e1, e1), d12 = dot(e1, e2), d22 = dot(e2, e2);
        const double d1 = dot(d, e1), d2 = dot(d, e2);
        const double inv = 1.0 / (d11 * d22 - d12 * d12);
        w[1] = (d22 * d1 - d12 * d2) * inv;
        w[2] = (d11 * d2 - d12 * d1) * inv;
        w[0] = 1.0 - w[1] - w[2];
    }
};
static_assert(sizeof(Triangle) == 80, "Triangle: the normals index lives in the padding after the material");

// The unit vertex normals (world space) of a smooth-shaded triangle, at a, b and c.
struct TriangleNormals {
    Vec3 n[3];

    // Mitsuba's shading normal at barycentric coordinates w (weights of a, b, c): the
    // interpolated vertex normals, normalised (src/render/mesh.cpp,
    // compute_surface_interaction and sample_position). Where they cancel (vertex
    // normals facing opposite ways), the length is 0 and Mitsuba's normal would be NaN:
    // the triangle's own normal `flat` is used there instead.
    Vec3 at(const double (&w)[3], const Vec3& flat) const {
        const Vec3 s = n[2] * w[2] + (n[1] * w[1] + n[0] * w[0]);
        const double len2 = dot(s, s);
        if (!(len2 > 0.0) || !std::isfinite(len2)) return flat;
        return s / std::sqrt(len2);
    }
};

// Per-ray constants of the watertight test: the axis permutation and shear that map the
// ray direction onto +z.
struct WatertightRay {
    int kx = 0, ky = 1, kz = 2;
    double Sx = 0, Sy = 0, Sz = 1;
    WatertightRay() = default;  // unused placeholder (scenes without triangles)
    explicit WatertightRay(const Vec3& d) {
        // kz: the axis of the largest |d| (on ties the later axis); kx, ky the two others,
        // swapped where d[kz] < 0 to keep the winding of the sheared triangle. Looked up in
        // tables indexed by the comparisons: as conditional expressions (and as bit
        // arithmetic) GCC compiled them to branches, each a coin toss on random directions
        // (1.4 mispredictions per ray; PERFORMANCE.md, Ideas tried).
        const double ax = std::abs(d.x), ay = std::abs(d.y), az = std::abs(d.z);
        // Index bits: |x| > |y|, |x| > |z|, |y| > |z|.
        static constexpr int kLargest[8] = {2, 1, 2, 1, 2, 2, 0, 0};
        kz = kLargest[(int(ax > ay) << 2) | (int(ax > az) << 1) | int(ay > az)];
        const double dd[3] = {d.x, d.y, d.z};
        const int flip = dd[kz] < 0.0;
        static constexpr int kFirst[2][3] = {{1, 2, 0}, {2, 0, 1}};
        static constexpr int kSecond[2][3] = {{2, 0, 1}, {1, 2, 0}};
        kx = kFirst[flip][kz];
        ky = kSecond[flip][kz];
        Sx = dd[kx] / dd[kz];
        Sy = dd[ky] / dd[kz];
        Sz = 1.0 / dd[kz];
    }
};

// WatertightRay of four rays at once (lane i: the direction (dx[i], dy[i], dz[i])): the
// axis choice as lane selections and the three divisions on four lanes, each lane's
// constants the very bits WatertightRay(d) computes (the same comparisons, the same
// divisions). For packets: one ray at a time cost ~60 instructions a camera ray.
struct WatertightRays4 {
    V4l kx = V4l{} + 0, ky = V4l{} + 1, kz = V4l{} + 2;
    V4d Sx{}, Sy{}, Sz = V4d{} + 1.0;

    WatertightRays4() = default;  // four WatertightRay() placeholders (scenes without triangles)
    WatertightRays4(const V4d& dx, const V4d& dy, const V4d& dz) {
        auto magnitude = [](const V4d& v) { return v < 0.0 ? -v : v; };
        const V4d ax = magnitude(dx), ay = magnitude(dy), az = magnitude(dz);
        // WatertightRay's table kLargest as selections (masks are 0 / -1): kz = 0 where
        // |x| > |y| and |x| > |z|, 1 where not |x| > |y| but |y| > |z|, else 2.
        const V4l x_y = ax > ay, z0 = x_y & (ax > az), z1 = ~x_y & (ay > az);
        kz = 2 + 2 * z0 + z1;
        const V4d dkz = z0 ? dx : (z1 ? dy : dz);
        // kFirst / kSecond: kx = kz + 1 and ky = kz + 2 (mod 3), swapped where d[kz] < 0.
        const V4l flip = dkz < 0.0;
        auto mod3 = [](const V4l& k) { return k >= 3 ? k - 3 : k; };
        kx = mod3(kz + 1 - flip);
        ky = mod3(kz + 2 + flip);
        auto component = [&](const V4l& k) { return k == 0 ? dx : (k == 1 ? dy : dz); };
        Sx = component(kx) / dkz;
        Sy = component(ky) / dkz;
        Sz = 1.0 / dkz;
    }
    WatertightRay lane(int i) const {
        WatertightRay w;
        w.kx = static_cast<int>(kx[i]);
        w.ky = static_cast<int>(ky[i]);
        w.kz = static_cast<int>(kz[i]);
        w.Sx = Sx[i];
        w.Sy = Sy[i];
        w.Sz = Sz[i];
        return w;
    }
};

// The lanes, as bits, that hold the nearest hit in (t_min, t_max) of the watertight test's
// results (edge functions U, V, W, determinant det, distance t) on lanes of triangles of
// type F: the lowest such lane, or none. Inclusive edge test: a ray through an edge or
// vertex hits every triangle sharing it. NaN lanes fail every comparison: a NaN t is never
// a hit. The nearest passing lane is found without a branch per lane (a lane loop cost 0.5
// mispredictions a block): passing lanes have a finite t (t < t_max), the others count as
// +inf.
template <typename F>
inline unsigned watertight_nearest(F U, F V, F W, F det, F t, double t_min, double t_max) {
    const auto any_neg = (U < 0.0) | (V < 0.0) | (W < 0.0);
    const auto any_pos = (U > 0.0) | (V > 0.0) | (W > 0.0);
    const MaskOf<F> ok = ((any_neg & any_pos) == 0) & (det != 0.0) & (t > t_min) & (t < t_max);
    const F candidate = ok ? t : broadcast<F>(kInf);
    return lane_mask(ok & (candidate == min_lane(candidate)));
}
// One triangle: its only lane, where it passes.
inline unsigned watertight_nearest(double U, double V, double W, double det, double t, double t_min, double t_max) {
    return lane_mask(!((U < 0.0 || V < 0.0 || W < 0.0) && (U > 0.0 || V > 0.0 || W > 0.0)) && det != 0.0 &&
                     t > t_min && t < t_max);
}
#if defined(__AVX512VL__)
// The same masks in mask registers, each "and" a masked compare: GCC combined the
// portable form's nine comparisons in general registers on AVX-512 (a dozen moves between
// the two kinds per block). ~(any_neg & any_pos) is "no edge function below zero, or none
// above", and the negated comparisons (not less, not greater) are true for NaN, as the
// portable form's negations are.
inline unsigned watertight_nearest(V4d U, V4d V, V4d W, V4d det, V4d t, double t_min, double t_max) {
    const __m256d U4 = reinterpret_cast<__m256d>(U), V4 = reinterpret_cast<__m256d>(V),
                  W4 = reinterpret_cast<__m256d>(W), zero = _mm256_setzero_pd();
    __mmask8 none_neg = _mm256_cmp_pd_mask(U4, zero, _CMP_NLT_UQ);
    none_neg = _mm256_mask_cmp_pd_mask(none_neg, V4, zero, _CMP_NLT_UQ);
    none_neg = _mm256_mask_cmp_pd_mask(none_neg, W4, zero, _CMP_NLT_UQ);
    __mmask8 none_pos = _mm256_cmp_pd_mask(U4, zero, _CMP_NGT_UQ);
    none_pos = _mm256_mask_cmp_pd_mask(none_pos, V4, zero, _CMP_NGT_UQ);
    none_pos = _mm256_mask_cmp_pd_mask(none_pos, W4, zero, _CMP_NGT_UQ);
    const __m256d T4 = reinterpret_cast<__m256d>(t);
    __mmask8 ok = _mm256_mask_cmp_pd_mask(none_neg | none_pos, reinterpret_cast<__m256d>(det), zero, _CMP_NEQ_UQ);
    ok = _mm256_mask_cmp_pd_mask(ok, T4, _mm256_set1_pd(t_min), _CMP_GT_OQ);
    ok = _mm256_mask_cmp_pd_mask(ok, T4, _mm256_set1_pd(t_max), _CMP_LT_OQ);
    const V4d candidate = reinterpret_cast<V4d>(_mm256_mask_blend_pd(ok, _mm256_set1_pd(kInf), T4));
    return _mm256_mask_cmp_pd_mask(ok, reinterpret_cast<__m256d>(candidate), _mm256_set1_pd(min_lane(candidate)),
                                   _CMP_EQ_OQ);
}
#endif

// Woop, Benthin and Wald's watertight test of one ray against lanes of triangles of type F
// (double: one triangle; V4d: a block's four), vertex(k, axis) giving vertex k's coordinate
// lanes: the bits of the lane of the nearest hit in (t_min, t_max) (watertight_nearest),
// each lane's distance in t. One body for every width, each lane doing the one triangle's
// operations in their order (and the build forbids FMA contraction), so that the edge
// functions of a shared edge are bit-identical whatever the width: the watertight
// guarantee holds across them. One triangle returns before its division where the edge
// test fails; a block's lanes cannot (a branch on all four would be unpredictable).
template <typename F, typename Vertex>
[[gnu::always_inline]] inline unsigned intersect_watertight_lanes(const Vertex& vertex, const Ray& r,
                                                                  const WatertightRay& w, double t_min,
                                                                  double t_max, F& t) {
    const double o[3] = {r.o.x, r.o.y, r.o.z};
    // Vertex coordinates relative to the origin, permuted so the ray runs along +z.
    auto rel = [&](int k, int axis) -> F { return vertex(k, axis) - o[axis]; };
    const F Akz = rel(0, w.kz), Bkz = rel(1, w.kz), Ckz = rel(2, w.kz);
    const F Ax = rel(0, w.kx) - w.Sx * Akz, Ay = rel(0, w.ky) - w.Sy * Akz;
    const F Bx = rel(1, w.kx) - w.Sx * Bkz, By = rel(1, w.ky) - w.Sy * Bkz;
    const F Cx = rel(2, w.kx) - w.Sx * Ckz, Cy = rel(2, w.ky) - w.Sy * Ckz;
    const F U = Cx * By - Cy * Bx;
    const F V = Ax * Cy - Ay * Cx;
    const F W = Bx * Ay - By * Ax;
    if constexpr (kLanesOf<F> == 1) {
        if ((U < 0.0 || V < 0.0 || W < 0.0) && (U > 0.0 || V > 0.0 || W > 0.0)) return 0;
    }
    const F det = U + V + W;
    const F T = U * (w.Sz * Akz) + V * (w.Sz * Bkz) + W * (w.Sz * Ckz);
    t = T / det;
    return watertight_nearest(U, V, W, det, t, t_min, t_max);
}

inline bool intersect_watertight(const Triangle& tri, const Ray& r, const WatertightRay& w,
                                 double t_min, double t_max, double& t_hit) {
    const Vec3* v[3] = {&tri.a, &tri.b, &tri.c};
    double t;
    if (intersect_watertight_lanes([&](int k, int axis) { return (*v[k])[axis]; }, r, w, t_min, t_max, t) == 0)
        return false;
    t_hit = t;
    return true;
}

// Four triangles of a BVH leaf in structure-of-arrays form, in leaf order (no indirection
// through the BVH's primitive order), tested together by intersect_watertight4. Padding
// lanes repeat the first triangle: a duplicate can only tie with lane 0, and ties go to
// the lowest lane, so padding never changes the answer.
//
// Two storages of the same block: double (any vertex), and float where every vertex of
// the scene's triangles is exactly a float (meshes read from PLY/OBJ files, the ray
// benchmark's torus). Widening a float to double is exact, so the float block feeds the
// double test the very same values: the test, and every hit, is bit-identical, while a
// block takes 3 cache lines instead of 5. On large meshes a ray's leaf visits are cache
// misses, and the lines a block spans (and how many blocks the caches hold) are what
// they cost.
// The four lanes of a row, as double (exact for float rows: one vcvtps2pd with AVX).
inline V4d widen(const V4d& row) { return row; }
inline V4d widen(const V4f& row) {
#ifdef __AVX__
    return reinterpret_cast<V4d>(_mm256_cvtps_pd(reinterpret_cast<__m128>(row)));
#else
    return __builtin_convertvector(row, V4d);
#endif
}

template <typename Scalar> struct Lanes4;
template <> struct Lanes4<double> { using type = V4d; };
template <> struct Lanes4<float> { using type = V4f; };

template <typename Scalar>
struct alignas(64) TriangleBlock4 {  // cache-line aligned: a block never straddles an extra line
    using Row = typename Lanes4<Scalar>::type;
    Row v[3][3];           // [vertex a, b, c][axis x, y, z], one lane per triangle
    uint32_t prim[4];      // scene primitive ids
    // Kept here (it fits the alignment padding) so that filling in a hit needs nothing
    // beyond the block just tested: on large meshes the triangle array is a cache miss.
    uint32_t material[4];

    // Whether a triangle's vertices are stored exactly by this storage.
    static bool exact(const Triangle& t) {
        for (const Vec3* p : {&t.a, &t.b, &t.c})
            for (int axis = 0; axis < 3; ++axis)
                if (!(static_cast<double>(static_cast<Scalar>((*p)[axis])) == (*p)[axis])) return false;
        return true;
    }
    // Stores triangle t in a lane (exactly: the caller checked exact(t)).
    void set(int lane, const Triangle& t, uint32_t prim_id) {
        for (int axis = 0; axis < 3; ++axis) {
            v[0][axis][lane] = static_cast<Scalar>(t.a[axis]);
            v[1][axis][lane] = static_cast<Scalar>(t.b[axis]);
            v[2][axis][lane] = static_cast<Scalar>(t.c[axis]);
        }
        prim[lane] = prim_id;
        material[lane] = t.material;
    }
    // Row `axis` of `vertex`, as double.
    V4d row(int vertex, int axis) const { return widen(v[vertex][axis]); }
    // The triangle of a lane, exactly as it was set.
    Triangle triangle(int lane) const {
        auto vertex = [&](int k) {
            return Vec3{double(v[k][0][lane]), double(v[k][1][lane]), double(v[k][2][lane])};
        };
        return {vertex(0), vertex(1), vertex(2), material[lane]};
    }
};
using Triangle4 = TriangleBlock4<double>;
using Triangle4f = TriangleBlock4<float>;
static_assert(sizeof(Triangle4) == 320, "Triangle4: ten 32-byte rows, five cache lines");
static_assert(sizeof(Triangle4f) == 192, "Triangle4f: nine 16-byte rows and the ids, three cache lines");

// The watertight test on the four triangles of a block (intersect_watertight_lanes on
// V4d, in double): the lane of the nearest hit in (t_min, t_max) (lowest lane on ties, as
// testing the triangles one after another with a shrinking t_max would), or -1.
template <typename Block>
inline int intersect_watertight4(const Block& q, const Ray& r, const WatertightRay& w,
                                 double t_min, double t_max, double& t_hit) {
    V4d t;
    const unsigned nearest =
        intersect_watertight_lanes([&](int k, int axis) { return q.row(k, axis); }, r, w, t_min, t_max, t);
    if (nearest == 0) return -1;
    const int best = __builtin_ctz(nearest);
    t_hit = t[best];
    return best;
}

template <typename Real>
inline bool intersect_cramer(const Triangle& tri, const Ray& r, double t_min, double t_max, double& t_hit) {
    struct V3 { Real x, y, z; };
    auto sub = [](const Vec3& p, const Vec3& q) { return V3{Real(p.x) - Real(q.x), Real(p.y) - Real(q.y), Real(p.z) - Real(q.z)}; };
    auto crs = [](const V3& p, const V3& q) { return V3{p.y * q.z - p.z * q.y, p.z * q.x - p.x * q.z, p.x * q.y - p.y * q.x}; };
    auto dt = [](const V3& p, const V3& q) { return p.x * q.x + p.y * q.y + p.z * q.z; };
    const V3 e1 = sub(tri.b, tri.a), e2 = sub(tri.c, tri.a), s = sub(r.o, tri.a);
    const V3 d{Real(r.d.x), Real(r.d.y), Real(r.d.z)};
    // Cramer's rule for [-d, e1, e2] (t, b1, b2)^T = s: each unknown is a ratio of
    // determinants, the determinants written as triple products.
    const V3 p = crs(d, e2);
    const Real det = dt(e1, p);
    if (det == Real(0)) return false;
    const Real inv = Real(1) / det;
    const Real b1 = dt(s, p) * inv;
    if (b1 < Real(0) || b1 > Real(1)) return false;
    const V3 q = crs(s, e1);
    const Real b2 = dt(d, q) * inv;
    if (b2 < Real(0) || b1 + b2 > Real(1)) return false;
    const double t = double(dt(e2, q) * inv);
    if (!(t > t_min && t < t_max)) return false;
    t_hit = t;
    return true;
}

}  // namespace rt
