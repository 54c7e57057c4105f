// Warps from the unit square to directions, with their densities (solid angle measure).
// All directions are in a local frame whose +z axis is the surface normal.
#pragma once

#include <vector>

#include "../math.h"
#include "../simd.h"

namespace rt {

// sin and cos of x for |x| <= pi/4 from their Taylor series in Horner form, each step one
// mul_add (fused where the CPU has FMA: half the instructions and half the latency of
// the chain). The first omitted terms, x^17/17! and x^18/18!, are below 5e-17 there, and
// the result is within 1 ulp of std::sin / std::cos (tests/benchmarks/chi2/test_chi2.py checks the warps
// built on it against extended precision). Inline and without range reduction it costs a
// fraction of a general sincos call, and the concentric map below only ever needs angles
// in this interval. T is double, or VPd for a pack of lanes (each lane computes exactly
// what the double version does).
template <typename T>
[[gnu::always_inline]] inline void sincos_quarter(T x, T& s, T& c) {
    const T z = x * x;
    const auto k = [&z](double v) { return as_lanes(v, z); };
    T ps = mul_add(z, k(-1.0 / 1307674368000.0), k(1.0 / 6227020800.0));
    ps = mul_add(z, ps, k(-1.0 / 39916800.0));
    ps = mul_add(z, ps, k(1.0 / 362880.0));
    ps = mul_add(z, ps, k(-1.0 / 5040.0));
    ps = mul_add(z, ps, k(1.0 / 120.0));
    ps = mul_add(z, ps, k(-1.0 / 6.0));
    ps = mul_add(z, ps, k(1.0));
    s = x * ps;
    T pc = mul_add(z, k(1.0 / 20922789888000.0), k(-1.0 / 87178291200.0));
    pc = mul_add(z, pc, k(1.0 / 479001600.0));
    pc = mul_add(z, pc, k(-1.0 / 3628800.0));
    pc = mul_add(z, pc, k(1.0 / 40320.0));
    pc = mul_add(z, pc, k(-1.0 / 720.0));
    pc = mul_add(z, pc, k(1.0 / 24.0));
    pc = mul_add(z, pc, k(-0.5));
    c = mul_add(z, pc, k(1.0));
}

// sin and cos of 2 pi u for u in [0, 1]: u is split into its nearest quarter turn q/4 and
// the rest u - q/4 in [-1/8, 1/8] (exact: Sterbenz's lemma), whose angle is within
// [-pi/4, pi/4] for sincos_quarter; the quarter turns swap and negate the pair, chosen
// without branches (the quadrant of a random angle is unpredictable). Within about 1 ulp
// of std::sin / std::cos of the angle, at a fraction of a libm call (which cost 7% of the
// instructions of the furnace and glossy_plates scenes, through sphere lights and GGX).
// F: double, or a pack of lanes (simd.h), each lane computing what the double does.
inline int64_t integer_lanes(double q) { return static_cast<int64_t>(q); }
template <typename F> inline MaskOf<F> integer_lanes(F q) { return __builtin_convertvector(q, MaskOf<F>); }
template <typename F>
inline void sincos_turn(F u, F& s, F& c) {
    const F q = floor_of(4.0 * u + 0.5);
    F sx, cx;
    sincos_quarter((2.0 * kPi) * (u - 0.25 * q), sx, cx);
    const auto k = integer_lanes(q) & 3;
    const auto odd = (k & 1) != 0;
    const F a = odd ? cx : sx, b = odd ? sx : cx;
    s = (k & 2) != 0 ? -a : a;
    c = ((k + 1) & 2) != 0 ? -b : b;
}

// The point p of the unit sphere at height z and azimuth 2 pi u.
template <typename F>
inline void sphere_point_at_height(F z, F u, F (&p)[3]) {
    const F r = safe_sqrt_of(1.0 - z * z);
    F sin_phi, cos_phi;
    sincos_turn(u, sin_phi, cos_phi);
    p[0] = r * cos_phi;
    p[1] = r * sin_phi;
    p[2] = z;
}
inline Vec3 sphere_point_at_height(double z, double u) {
    double p[3];
    sphere_point_at_height(z, u, p);
    return {p[0], p[1], p[2]};
}

// Heights uniform in [0, 1] (hemisphere) or [-1, 1] (sphere): uniform in solid angle
// (Archimedes' hat-box theorem).
inline Vec3 square_to_uniform_hemisphere(double u1, double u2) { return sphere_point_at_height(u1, u2); }
constexpr double kUniformHemispherePdf = 1.0 / (2.0 * kPi);

inline Vec3 square_to_uniform_sphere(double u1, double u2) { return sphere_point_at_height(1.0 - 2.0 * u1, u2); }
constexpr double kUniformSpherePdf = 1.0 / (4.0 * kPi);

// Cosine-weighted hemisphere (Malley's method through a concentric disk). Both branches
// of the concentric map need the sine and cosine of an angle in [-pi/4, pi/4]: the second
// one's angle pi/2 - phi' is taken as cos/sin of phi' with the roles swapped. The branch
// is a selection (its condition is random: a branch would be mispredicted half the time),
// so the same code serves one sample (T = double) or a pack of lanes (T = VPd).
template <typename T>
[[gnu::always_inline]] inline void square_to_cosine_hemisphere(T u1, T u2, T& x, T& y, T& z) {
    const T a = 2.0 * u1 - 1.0, b = 2.0 * u2 - 1.0;
    const auto first = a * a > b * b;
    // At a = b = 0 the angle is 0 / 0; that lane's point is the centre, selected below.
    T s, c;
    sincos_quarter((kPi / 4.0) * ((first ? b : a) / (first ? a : b)), s, c);
    const auto centre = (a == 0.0) & (b == 0.0);
    const T zero = as_lanes(0.0, a);
    x = centre ? zero : (first ? a * c : b * s);
    y = centre ? zero : (first ? a * s : b * c);
    const T r2 = 1.0 - x * x - y * y;
    z = sqrt_of(r2 > 0.0 ? r2 : zero);  // safe_sqrt
}
[[gnu::always_inline]] inline Vec3 square_to_cosine_hemisphere(double u1, double u2) {
    Vec3 w;
    square_to_cosine_hemisphere(u1, u2, w.x, w.y, w.z);
    return w;
}
// Its density (lane-wise for packs, as the warp above).
template <typename F>
inline F cosine_hemisphere_pdf(F cos_theta) {
    return cos_theta > 0.0 ? cos_theta * kInvPi : as_lanes(0.0, cos_theta);
}

// Uniform direction w in the cone of half-angle theta_max about +z, given
// one_minus_cos_max = 1 - cos(theta_max) (passed directly: it is tiny for small, far lights
// and 1 - cos would cancel).
template <typename F>
inline void square_to_uniform_cone(F u1, F u2, F one_minus_cos_max, F (&w)[3]) {
    const F one_minus_cos = u1 * one_minus_cos_max;
    const F cos_theta = 1.0 - one_minus_cos;
    const F sin_theta = safe_sqrt_of(one_minus_cos * (2.0 - one_minus_cos));
    F sin_phi, cos_phi;
    sincos_turn(u2, sin_phi, cos_phi);
    w[0] = sin_theta * cos_phi;
    w[1] = sin_theta * sin_phi;
    w[2] = cos_theta;
}
inline Vec3 square_to_uniform_cone(double u1, double u2, double one_minus_cos_max) {
    double w[3];
    square_to_uniform_cone(u1, u2, one_minus_cos_max, w);
    return {w[0], w[1], w[2]};
}
template <typename F> inline F uniform_cone_pdf(F one_minus_cos_max) { return 1.0 / (2.0 * kPi * one_minus_cos_max); }

// Discrete distribution over n items proportional to non-negative weights.
class DiscreteDistribution {
public:
    DiscreteDistribution() = default;
    explicit DiscreteDistribution(const std::vector<double>& weights) {
        cdf_.resize(weights.size() + 1, 0.0);
        for (size_t i = 0; i < weights.size(); ++i) cdf_[i + 1] = cdf_[i] + weights[i];
        total_ = cdf_.back();
        pmf_.resize(weights.size());
        for (size_t i = 0; i < weights.size(); ++i) pmf_[i] = total_ > 0 ? weights[i] / total_ : 0.0;
        first_nonzero_.resize(weights.size());
        for (size_t i = 0; i < weights.size(); ++i) {
            size_t j = i;
            while (pmf_[j] == 0.0 && j + 1 < pmf_.size()) ++j;
            first_nonzero_[i] = j;
        }
    }
    bool empty() const { return pmf_.empty() || !(total_ > 0); }
    size_t size() const { return pmf_.size(); }
    double pmf(size_t i) const { return pmf_[i]; }

    // Index with probability pmf(i); u is re-used by the caller only through `u_remapped`.
    size_t sample(double u, double* u_remapped = nullptr) const {
        const double target = u * total_;
        size_t lo = 0, hi = pmf_.size() - 1;
        while (lo < hi) {  // first i with cdf_[i + 1] > target
            const size_t mid = (lo + hi) / 2;
            if (cdf_[mid + 1] > target) hi = mid; else lo = mid + 1;
        }
        while (pmf_[lo] == 0.0 && lo + 1 < pmf_.size()) ++lo;  // never return a zero-weight item
        if (u_remapped) {
            const double w = cdf_[lo + 1] - cdf_[lo];
            *u_remapped = w > 0 ? std::min((target - cdf_[lo]) / w, std::nextafter(1.0, 0.0)) : 0.0;
        }
        return lo;
    }

    // sample(u[l]) for every lane l of a pack, into index[l]. Up to kCountedItems items, by
    // counting the cumulative sums at or below each lane's target (the first i with
    // cdf_[i + 1] > target, as sample()'s search finds it: the sums never decrease) and the
    // next item of non-zero weight (first_nonzero_), without the search's branches on each
    // lane's random target; beyond, sample() lane by lane (PERFORMANCE.md, Ideas tried).
    static constexpr size_t kCountedItems = 16;
    template <typename F>
    void sample_lanes(F u, size_t (&index)[kLanesOf<F>]) const {
        if (pmf_.size() > kCountedItems) {
            for (int l = 0; l < kLanesOf<F>; ++l) index[l] = sample(u[l]);
            return;
        }
        const F target = u * total_;
        MaskOf<F> count{};
        for (size_t i = 0; i + 1 < pmf_.size(); ++i) count -= cdf_[i + 1] <= target;  // true lanes are -1
        for (int l = 0; l < kLanesOf<F>; ++l) index[l] = first_nonzero_[size_t(count[l])];
    }

private:
    std::vector<double> cdf_, pmf_;
    std::vector<size_t> first_nonzero_;  // sample()'s skip of zero-weight items, from each i
    double total_ = 0.0;
};

// Power heuristic with beta = 2 (Veach 1997), as Mitsuba's path integrator; lane-wise for
// packs. A weight that is not finite (both densities 0 or infinite) is 0.
template <typename F>
inline F power_heuristic(F pdf_a, F pdf_b) {
    const F a2 = pdf_a * pdf_a, b2 = pdf_b * pdf_b;
    const F w = a2 / (a2 + b2);
    return finite_lanes(w) ? w : as_lanes(0.0, w);
}

// power_heuristic(pdf_a, pdf_b) / pdf_a, the factor of a sample of density pdf_a in an MIS
// estimate, as pdf_a / (pdf_a^2 + pdf_b^2): one division where the weight and then the
// quotient took two in a chain. Not finite (both densities 0 or infinite): 0.
template <typename F>
inline F power_heuristic_over(F pdf_a, F pdf_b) {
    const F s = pdf_a / (pdf_a * pdf_a + pdf_b * pdf_b);
    return finite_lanes(s) ? s : as_lanes(0.0, s);
}

}  // namespace rt
