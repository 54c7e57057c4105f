// Batch probes of the sampling routines, for their chi-square tests (benchmarks/chi2).
//
// Each function runs the tracer's own inline routine - sampling/warp.h, and the material
// dispatch of materials/material.h (rt::bsdf_sample, rt::bsdf_eval, rt::bsdf_pdf, which is
// what the integrator calls) - once per row of a numpy array, and returns numpy arrays.
// Nothing is re-implemented here except the support of the constant densities (the warp
// header gives their value, not where they vanish) and the disk's density 1/pi, which is
// the definition of the target rather than code under test. Light sampling needs a scene
// and is probed through the existing Scene.sample_lights / Scene.light_pdf (bindings.cpp),
// i.e. the scene's real LightSampler.
//
//   warp_sample(name, u (n, 2), param=0, packed=False) -> (n, 3) unit vectors; (n, 2) points
//       for the disk; packed: the wavefront's pack version (the cosine warp only)
//   warp_pdf(name, points, param=0)      -> (n,) density (solid angle; area for the disk)
//   bsdf_sample(material, wo (3,), u (n, 3), albedo (3,), param, eta=, specular=, nonlinear=)
//       -> dict of arrays
//   bsdf_eval_pdf(material, wo (3,), wi (n, 3), albedo (3,), param, eta=, specular=, nonlinear=)
//       -> dict of arrays
//   rough_plastic_table(distribution, alpha, eta) -> dict: the coating's transmittance
//       table (64,) and internal reflectance, as a scene's rough plastic uses them
//
// Warp names: uniform_hemisphere, cosine_hemisphere, uniform_sphere, uniform_cone (param =
// 1 - cos(theta_max), as square_to_uniform_cone takes it), concentric_disk (the concentric
// map of square_to_cosine_hemisphere, which inlines it: the disk point is the direction's
// (x, y) - Malley's method lifts it to the hemisphere without changing it).
// Materials: lambertian, rough_conductor and rough_conductor_beckmann (param = alpha), dielectric and
// dielectric_schlick (param = ior), metal (param = fuzz), plastic, rough_plastic (GGX) and
// rough_plastic_beckmann (param = alpha; albedo = diffuse_reflectance; eta = int_ior /
// ext_ior, specular = specular_reflectance and nonlinear as Mitsuba's, its defaults when
// not given), rough_dielectric (GGX) and rough_dielectric_beckmann (param = alpha, eta =
// int_ior / ext_ior; wo and the directions on either side of the surface, +z outside).
// Directions are in the local shading frame (+z = normal), as the routines take them.
#include "sampling_probe.h"

#include <cmath>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <nanobind/ndarray.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/string.h>

#include "materials/material.h"
#include "materials/rough_conductor_pack.h"
#include "sampling/warp.h"

namespace nb = nanobind;
using namespace nb::literals;

namespace rt {
namespace {

using Matrix = nb::ndarray<const double, nb::ndim<2>, nb::c_contig, nb::device::cpu>;
using Vector = nb::ndarray<const double, nb::ndim<1>, nb::c_contig, nb::device::cpu>;

template <typename T>
nb::ndarray<nb::numpy, T> to_numpy(std::vector<T>&& data, std::initializer_list<size_t> shape) {
    auto* heap = new std::vector<T>(std::move(data));
    nb::capsule owner(heap, [](void* p) noexcept { delete static_cast<std::vector<T>*>(p); });
    return nb::ndarray<nb::numpy, T>(heap->data(), shape, owner);
}

void require_columns(const Matrix& m, size_t cols, const char* name) {
    if (m.shape(1) != cols)
        throw std::invalid_argument(std::string(name) + ": expected " + std::to_string(cols) + " columns");
}

Vec3 vec3(const Vector& a, const char* name) {
    if (a.shape(0) != 3) throw std::invalid_argument(std::string(name) + ": expected a 3-vector");
    return {a(0), a(1), a(2)};
}

enum class Warp { UniformHemisphere, CosineHemisphere, UniformSphere, UniformCone, ConcentricDisk };

Warp warp_of(const std::string& name, double param) {
    Warp w;
    if (name == "uniform_hemisphere") w = Warp::UniformHemisphere;
    else if (name == "cosine_hemisphere") w = Warp::CosineHemisphere;
    else if (name == "uniform_sphere") w = Warp::UniformSphere;
    else if (name == "uniform_cone") w = Warp::UniformCone;
    else if (name == "concentric_disk") w = Warp::ConcentricDisk;
    else
        throw std::invalid_argument("unknown warp '" + name + "' (uniform_hemisphere, cosine_hemisphere, "
                                    "uniform_sphere, uniform_cone, concentric_disk)");
    if (w == Warp::UniformCone && !(param > 0.0 && param <= 2.0))
        throw std::invalid_argument("uniform_cone: param = 1 - cos(theta_max) must be in (0, 2]");
    return w;
}

nb::ndarray<nb::numpy, double> probe_warp_sample(const std::string& name, const Matrix& u, double param,
                                                 bool packed) {
    const Warp w = warp_of(name, param);
    require_columns(u, 2, "u");
    const size_t n = u.shape(0);
    const size_t dim = w == Warp::ConcentricDisk ? 2 : 3;
    std::vector<double> out(dim * n);
    if (packed) {
        // The pack version the wavefront integrator runs (the same template, T = VPd).
        if (w != Warp::CosineHemisphere && w != Warp::ConcentricDisk)
            throw std::invalid_argument(name + ": only cosine_hemisphere and concentric_disk have a packed version");
        nb::gil_scoped_release release;
        for (size_t base = 0; base < n; base += kPackWidth) {
            VPd u1, u2, d[3];
            for (int l = 0; l < kPackWidth; ++l) {  // absent lanes repeat the first
                const size_t i = base + size_t(base + l < n ? l : 0);
                u1[l] = u(i, 0);
                u2[l] = u(i, 1);
            }
            square_to_cosine_hemisphere(u1, u2, d[0], d[1], d[2]);
            for (size_t l = 0; l < size_t(kPackWidth) && base + l < n; ++l)
                for (size_t c = 0; c < dim; ++c) out[dim * (base + l) + c] = d[c][l];
        }
        return to_numpy(std::move(out), {n, dim});
    }
    {
        nb::gil_scoped_release release;
        for (size_t i = 0; i < n; ++i) {
            const double u1 = u(i, 0), u2 = u(i, 1);
            Vec3 d;
            switch (w) {
                case Warp::UniformHemisphere: d = square_to_uniform_hemisphere(u1, u2); break;
                case Warp::CosineHemisphere:
                case Warp::ConcentricDisk: d = square_to_cosine_hemisphere(u1, u2); break;
                case Warp::UniformSphere: d = square_to_uniform_sphere(u1, u2); break;
                case Warp::UniformCone: d = square_to_uniform_cone(u1, u2, param); break;
            }
            for (size_t c = 0; c < dim; ++c) out[dim * i + c] = d[int(c)];
        }
    }
    return to_numpy(std::move(out), {n, dim});
}

nb::ndarray<nb::numpy, double> probe_warp_pdf(const std::string& name, const Matrix& points, double param) {
    const Warp w = warp_of(name, param);
    require_columns(points, w == Warp::ConcentricDisk ? 2 : 3, "points");
    const size_t n = points.shape(0);
    std::vector<double> out(n);
    {
        nb::gil_scoped_release release;
        for (size_t i = 0; i < n; ++i) {
            double p = 0.0;
            if (w == Warp::ConcentricDisk) {
                const double x = points(i, 0), y = points(i, 1);
                p = x * x + y * y <= 1.0 ? kInvPi : 0.0;
            } else {
                const double z = points(i, 2);
                switch (w) {
                    case Warp::UniformHemisphere: p = z >= 0.0 ? kUniformHemispherePdf : 0.0; break;
                    case Warp::CosineHemisphere: p = cosine_hemisphere_pdf(z); break;
                    case Warp::UniformSphere: p = kUniformSpherePdf; break;
                    case Warp::UniformCone: p = z >= 1.0 - param ? uniform_cone_pdf(param) : 0.0; break;
                    case Warp::ConcentricDisk: break;
                }
            }
            out[i] = p;
        }
    }
    return to_numpy(std::move(out), {n});
}

// Mitsuba's default plastic coating: polypropylene (1.49) in air (1.000277).
constexpr double kPlasticEta = 1.49 / 1.000277;

Material material_of(const std::string& name, const Vector& albedo, double param, double eta = kPlasticEta,
                     const Vec3& specular = Vec3(1.0), bool nonlinear = false) {
    Material m;
    if (name == "lambertian") m.type = MaterialType::Lambertian;
    else if (name == "rough_conductor" || name == "rough_conductor_beckmann") m.type = MaterialType::RoughConductor;
    else if (name == "dielectric" || name == "dielectric_schlick") m.type = MaterialType::Dielectric;
    else if (name == "metal") m.type = MaterialType::Metal;
    else if (name == "plastic") m.type = MaterialType::Plastic;
    else if (name == "rough_plastic" || name == "rough_plastic_beckmann") m.type = MaterialType::RoughPlastic;
    else if (name == "rough_dielectric" || name == "rough_dielectric_beckmann") m.type = MaterialType::RoughDielectric;
    else
        throw std::invalid_argument("unknown material '" + name +
                                    "' (lambertian, rough_conductor, rough_conductor_beckmann, dielectric, "
                                    "dielectric_schlick, metal, plastic, rough_plastic, rough_plastic_beckmann, "
                                    "rough_dielectric, rough_dielectric_beckmann)");
    m.albedo = vec3(albedo, "albedo");
    m.param = param;
    m.schlick = name == "dielectric_schlick";
    if (name == "rough_conductor_beckmann" || name == "rough_plastic_beckmann" || name == "rough_dielectric_beckmann")
        m.distribution = Distribution::Beckmann;
    if ((m.type == MaterialType::RoughConductor || m.type == MaterialType::RoughPlastic ||
         m.type == MaterialType::RoughDielectric) && !(param > 0.0))
        throw std::invalid_argument("alpha must be > 0");
    if (m.type == MaterialType::RoughDielectric) {
        if (!(eta > 0.0) || !std::isfinite(eta) || eta == 1.0) throw std::invalid_argument("eta must be > 0 and != 1");
        m.eta = eta;
    }
    if (m.type == MaterialType::Dielectric && !(param > 0.0)) throw std::invalid_argument("ior must be > 0");
    if (m.type == MaterialType::Plastic || m.type == MaterialType::RoughPlastic) {
        if (!(eta > 0.0) || !std::isfinite(eta) || (m.type == MaterialType::RoughPlastic && eta == 1.0))
            throw std::invalid_argument("eta must be > 0 (and != 1 for a rough plastic)");
        make_plastic(m, specular, eta, nonlinear);
    }
    return m;
}

Vec3 specular_of(const std::optional<Vector>& specular) {
    return specular ? vec3(*specular, "specular") : Vec3(1.0);
}

Vec3 unit_wo(const Vector& wo) {
    const Vec3 v = vec3(wo, "wo");
    if (!(std::abs(length(v) - 1.0) < 1e-9)) throw std::invalid_argument("wo must be a unit vector");
    return v;
}

// rt::bsdf_sample for each row of u = (u0, u1, u2): u0 picks a lobe (glass), u1 and u2
// the direction.
// rough_conductor::sample_pack (plain GGX) on lanes of type F over the rows of u: the
// valid lanes' wi, weight and pdf.
template <typename F>
void rough_conductor_packs(const Vec3& wo, const Matrix& u, const Vector& albedo, double alpha, std::vector<double>& wi,
                           std::vector<double>& weight, std::vector<double>& pdf, std::vector<uint8_t>& valid) {
    constexpr int kWidth = kLanesOf<F>;
    const size_t n = u.shape(0);
    F w[3], alb[3];
    for (int a = 0; a < 3; ++a) {
        w[a] = broadcast<F>(wo[a]);
        alb[a] = broadcast<F>(albedo(a));
    }
    for (size_t base = 0; base < n; base += kWidth) {
        F u1, u2, out_wi[3], out_weight[3], out_pdf;
        for (int l = 0; l < kWidth; ++l) {  // absent lanes repeat the first
            const size_t i = base + size_t(base + size_t(l) < n ? l : 0);
            u1[l] = u(i, 1);
            u2[l] = u(i, 2);
        }
        const unsigned ok = rough_conductor::sample_pack(alb, broadcast<F>(alpha), w, u1, u2, out_wi, out_weight, out_pdf);
        for (size_t l = 0; l < size_t(kWidth) && base + l < n; ++l) {
            if (!((ok >> l) & 1u)) continue;
            for (int a = 0; a < 3; ++a) {
                wi[3 * (base + l) + size_t(a)] = out_wi[a][l];
                weight[3 * (base + l) + size_t(a)] = out_weight[a][l];
            }
            pdf[base + l] = out_pdf[l];
            valid[base + l] = 1;
        }
    }
}

nb::dict probe_bsdf_sample(const std::string& material, const Vector& wo_, const Matrix& u, const Vector& albedo,
                     double param, double coating_eta, const std::optional<Vector>& specular, bool nonlinear,
                     int width) {
    const Material m = material_of(material, albedo, param, coating_eta, specular_of(specular), nonlinear);
    const Vec3 wo = unit_wo(wo_);
    require_columns(u, 3, "u");
    const size_t n = u.shape(0);
    std::vector<double> wi(3 * n, 0.0), weight(3 * n, 0.0), pdf(n, 0.0), eta(n, 1.0);
    std::vector<uint8_t> delta(n, 0), valid(n, 0);
    if (width != 1) {
        if (material != "rough_conductor")
            throw std::invalid_argument(material + ": only rough_conductor (plain GGX) has a pack version");
        nb::gil_scoped_release release;
        if (width == 4)
            rough_conductor_packs<Vd<4>>(wo, u, albedo, param, wi, weight, pdf, valid);
        else if (width == 8)
            rough_conductor_packs<Vd<8>>(wo, u, albedo, param, wi, weight, pdf, valid);
        else
            throw std::invalid_argument("width must be one of LANE_WIDTHS (1, 4, 8)");
    } else {
        nb::gil_scoped_release release;
        for (size_t i = 0; i < n; ++i) {
            const BSDFSample s = rt::bsdf_sample(m, wo, u(i, 0), u(i, 1), u(i, 2));
            for (int c = 0; c < 3; ++c) {
                wi[3 * i + c] = s.wi[c];
                weight[3 * i + c] = s.weight[c];
            }
            pdf[i] = s.pdf;
            eta[i] = s.eta;
            delta[i] = s.delta;
            valid[i] = s.valid;
        }
    }
    nb::dict r;
    r["wi"] = to_numpy(std::move(wi), {n, 3});
    r["weight"] = to_numpy(std::move(weight), {n, 3});
    r["pdf"] = to_numpy(std::move(pdf), {n});
    r["eta"] = to_numpy(std::move(eta), {n});
    r["delta"] = to_numpy(std::move(delta), {n});
    r["valid"] = to_numpy(std::move(valid), {n});
    return r;
}

// rt::bsdf_eval (f * cos) and rt::bsdf_pdf for each row of wi; both zero for delta lobes.
nb::dict probe_bsdf_eval_pdf(const std::string& material, const Vector& wo_, const Matrix& wi, const Vector& albedo,
                       double param, double eta, const std::optional<Vector>& specular, bool nonlinear) {
    const Material m = material_of(material, albedo, param, eta, specular_of(specular), nonlinear);
    const Vec3 wo = unit_wo(wo_);
    require_columns(wi, 3, "wi");
    const size_t n = wi.shape(0);
    std::vector<double> value(3 * n, 0.0), pdf(n, 0.0);
    {
        nb::gil_scoped_release release;
        for (size_t i = 0; i < n; ++i) {
            const Vec3 d(wi(i, 0), wi(i, 1), wi(i, 2));
            const Vec3 f = rt::bsdf_eval(m, wo, d);
            for (int c = 0; c < 3; ++c) value[3 * i + c] = f[c];
            pdf[i] = rt::bsdf_pdf(m, wo, d);
        }
    }
    nb::dict r;
    r["value"] = to_numpy(std::move(value), {n, 3});
    r["pdf"] = to_numpy(std::move(pdf), {n});
    return r;
}

// The rough plastic coating's table, computed as make_plastic computes it for a scene.
nb::dict probe_rough_plastic_table(const std::string& distribution, double alpha, double eta) {
    rough_plastic::Microfacet mf;
    if (distribution == "ggx") mf.distribution = Distribution::GGX;
    else if (distribution == "beckmann") mf.distribution = Distribution::Beckmann;
    else throw std::invalid_argument("unknown distribution '" + distribution + "' (ggx, beckmann)");
    if (!(alpha > 0.0) || !(eta > 0.0) || eta == 1.0 || !std::isfinite(alpha) || !std::isfinite(eta))
        throw std::invalid_argument("alpha must be > 0 and eta > 0, != 1");
    mf.alpha = alpha;
    std::shared_ptr<const rough_plastic::Transmittance> t;
    {
        nb::gil_scoped_release release;
        t = rough_plastic::transmittance(mf, eta);
    }
    std::vector<double> table(t->table.begin(), t->table.end());
    nb::dict r;
    r["transmittance"] = to_numpy(std::move(table), {size_t(rough_plastic::Transmittance::kSize)});
    r["internal_reflectance"] = t->internal_reflectance;
    return r;
}

}  // namespace

void register_sampling_probe(nb::module_& m) {
    m.def("warp_sample", &probe_warp_sample, "name"_a, "u"_a, "param"_a = 0.0, "packed"_a = false,
          "Warp (n, 2) uniform numbers with a routine of sampling/warp.h: (n, 3) local directions, "
          "(n, 2) points for concentric_disk. param: 1 - cos(theta_max) for uniform_cone. packed: the "
          "pack version the wavefront integrator runs (cosine_hemisphere and concentric_disk only).");
    m.def("warp_pdf", &probe_warp_pdf, "name"_a, "points"_a, "param"_a = 0.0,
          "Density of warp_sample's output at (n, 3) directions (solid angle) or (n, 2) disk points (area).");
    m.def("bsdf_sample", &probe_bsdf_sample, "material"_a, "wo"_a, "u"_a, "albedo"_a, "param"_a,
          "eta"_a = kPlasticEta, "specular"_a = nb::none(), "nonlinear"_a = false, "width"_a = 1,
          "rt::bsdf_sample for each row (u0, u1, u2) of u; wo is the unit local outgoing direction. "
          "Returns dict wi (n, 3), weight (n, 3) = f cos / pdf, pdf (n,), eta (n,), delta (n,), valid (n,). "
          "eta, specular (3,) and nonlinear: the plastics' coating (Mitsuba's defaults when not given); eta: "
          "the rough dielectric's int_ior / ext_ior. width: 1, or 4 or 8 for rough_conductor's packs (the "
          "wavefront's plain-GGX sampler; only valid samples are filled), a testing seam.");
    m.def("bsdf_eval_pdf", &probe_bsdf_eval_pdf, "material"_a, "wo"_a, "wi"_a, "albedo"_a, "param"_a,
          "eta"_a = kPlasticEta, "specular"_a = nb::none(), "nonlinear"_a = false,
          "rt::bsdf_eval (f * cos, (n, 3)) and rt::bsdf_pdf ((n,)) for each row of wi: dict value, pdf.");
    m.def("rough_plastic_table", &probe_rough_plastic_table, "distribution"_a, "alpha"_a, "eta"_a,
          "The rough plastic coating's transmittance at the 64 cosines max(1e-6, k / 63) and its internal "
          "diffuse reflectance, as a scene's material computes them: dict transmittance (64,), "
          "internal_reflectance.");
}

}  // namespace rt
