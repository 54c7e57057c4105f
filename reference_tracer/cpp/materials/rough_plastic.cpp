// The rough coating's transmittance table and internal reflectance (rough_plastic.h).
//
// Mitsuba defines both through its visible-normal sampler: T(cos_i) is the mean, over
// visible microfacet normals m, of the share 1 - F(wi.m) that refracts through m and is
// not masked on the way out, G1(wt, m); the reflectance R(cos_i) likewise with F and the
// mirrored direction. As the sampler maps the unit square onto the visible normals with
// their density, each mean is an integral over the square, which Mitsuba takes with an
// N x N tensor Gauss-Legendre rule and we do too (the same rule gives the same table to
// ~1e-6 where the samplers are the same, Beckmann's; GGX's map the square differently, to
// the same density, and the rules' errors differ by ~1e-5). The internal reflectance Fi is
// Mitsuba's 2 * mean_k R(mu_k) mu_k over the table's 64 cosines, seen from inside (1 / eta).
#include "rough_plastic.h"

#include <cmath>
#include <map>
#include <mutex>
#include <tuple>
#include <vector>

namespace rt::rough_plastic {
namespace {

// Nodes and weights of the n-point Gauss-Legendre rule on [-1, 1] (Newton's method on
// the Legendre polynomial from the usual asymptotic guesses).
void gauss_legendre(int n, std::vector<double>& x, std::vector<double>& w) {
    x.assign(n, 0.0);
    w.assign(n, 0.0);
    for (int i = 0; i < (n + 1) / 2; ++i) {
        double z = std::cos(kPi * (i + 0.75) / (n + 0.5)), dp = 0.0;
        for (int iter = 0; iter < 100; ++iter) {
            double p0 = 1.0, p1 = 0.0;
            for (int j = 1; j <= n; ++j) {
                const double p2 = p1;
                p1 = p0;
                p0 = ((2.0 * j - 1.0) * z * p1 - (j - 1.0) * p2) / j;
            }
            dp = n * (z * p0 - p1) / (z * z - 1.0);
            const double step = p0 / dp;
            z -= step;
            if (std::abs(step) < 1e-15) break;
        }
        x[i] = -z;
        x[n - 1 - i] = z;
        w[i] = w[n - 1 - i] = 2.0 / ((1.0 - z * z) * dp * dp);
    }
}

// The mean over visible normals m of f(m): the tensor rule on the sampler's square.
template <typename F>
double visible_normal_mean(const Microfacet& mf, const Vec3& wi, int n, F&& f) {
    std::vector<double> x, w;
    gauss_legendre(n, x, w);
    double sum = 0.0;
    for (int a = 0; a < n; ++a)
        for (int b = 0; b < n; ++b) {
            const Vec3 m = mf.sample_visible(wi, 0.5 * x[a] + 0.5, 0.5 * x[b] + 0.5);
            sum += f(m) * (w[a] * w[b] * 0.25);  // the square's area is a quarter of [-1, 1]^2
        }
    return sum;
}

Vec3 incidence(double cos_i) { return Vec3(safe_sqrt(1.0 - cos_i * cos_i), 0.0, cos_i); }

}  // namespace

double coating_transmittance(const Microfacet& mf, double eta, double cos_i) {
    const Vec3 wi = incidence(cos_i);
    return visible_normal_mean(mf, wi, eta > 1.0 ? 32 : 128, [&](const Vec3& m) {
        const double c = dot(wi, m);
        const dielectric::Fresnel f = dielectric::fresnel(c, eta);
        // Snell's law through m; the transmitted cosine has the sign opposite to wi's.
        const double cos_t = c >= 0.0 ? -f.cos_t : f.cos_t;
        const Vec3 wt = m * (c * f.eta_ti + cos_t) - wi * f.eta_ti;
        if (!(wt.z * wi.z < 0.0)) return 0.0;  // it must come out on the other side
        return mf.g1(wt, m) * (1.0 - f.F);
    });
}

double coating_reflectance(const Microfacet& mf, double eta, double cos_i) {
    const Vec3 wi = incidence(cos_i);
    return visible_normal_mean(mf, wi, eta > 1.0 ? 32 : 128, [&](const Vec3& m) {
        const double c = dot(wi, m);
        const Vec3 wr = 2.0 * c * m - wi;
        if (!(wr.z > 0.0 && wi.z > 0.0)) return 0.0;
        return mf.g1(wr, m) * dielectric::fresnel(c, eta).F;
    });
}

std::shared_ptr<const Transmittance> transmittance(const Microfacet& mf, double eta) {
    static std::mutex mutex;
    static std::map<std::tuple<int, double, double>, std::shared_ptr<const Transmittance>> cache;
    const auto key = std::make_tuple(int(mf.distribution), mf.alpha, eta);
    {
        const std::lock_guard<std::mutex> lock(mutex);
        const auto found = cache.find(key);
        if (found != cache.end()) return found->second;
    }
    auto t = std::make_shared<Transmittance>();
    double sum = 0.0;
    for (int k = 0; k < Transmittance::kSize; ++k) {
        const double mu = std::max(1e-6, double(k) / double(Transmittance::kSize - 1));
        t->table[k] = coating_transmittance(mf, eta, mu);
        sum += coating_reflectance(mf, 1.0 / eta, mu) * mu;
    }
    t->internal_reflectance = 2.0 * sum / Transmittance::kSize;
    const std::lock_guard<std::mutex> lock(mutex);
    return cache.emplace(key, std::move(t)).first->second;
}

}  // namespace rt::rough_plastic
