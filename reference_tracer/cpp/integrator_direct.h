// Mitsuba's `direct` integrator (src/integrators/direct.cpp), included by integrator_impl.h.
//
// One camera ray, its emission, and at the surface it hits n_e light samples and n_b
// direction samples, each kind averaged over its own count. With both kinds, a sample is
// weighted by the power heuristic on densities scaled by each technique's share of the
// samples, f_e = n_e / (n_e + n_b) and f_b = n_b / (n_e + n_b): the balance of Veach's
// multi-sample model, so that light sampling and BSDF sampling of the same direction
// together count once. Nothing is traced beyond the first surface and there is no Russian
// roulette.
#pragma once

#include "integrator.h"

namespace rt {

template <Mutant M>
Vec3 Integrator<M>::Li_direct(const Ray& ray, PCG64& rng, uint64_t& rays, double reach) const {
    ++rays;
    Interaction it;
    if (!scene_.intersect(ray, it) || !(it.t < reach)) return scene_.background(ray.d);
    std::optional<Material> textured;  // the material with its texture's value at the hit, where it has one
    const Material& m = scene_.shade(scene_.material(it.material), it, textured);
    const bool front = dot(ray.d, it.ns) < 0.0;
    Vec3 L = (front && m.emits()) ? m.radiance : Vec3(0.0);  // one-sided (shading normal), as the area emitter
    const Vertex v(it, m, ray.d, front);
    if (!v) return L;

    const double n_e = direct_.emitter, n_b = direct_.bsdf;
    const double frac_light = n_e / (n_e + n_b), frac_bsdf = n_b / (n_e + n_b);
    const Vec3 ref = reference_point(v);
    const LightSampler& lights = scene_.lights();

    // Light samples: only where the material has a lobe they could meet (not a Dirac one).
    if (!m.is_delta() && !lights.empty()) {
        for (int i = 0; i < direct_.emitter; ++i) {
            const double u0 = rng.next_double(), u1 = rng.next_double(), u2 = rng.next_double();
            const LightSample ls = lights.sample<M>(ref, u0, u1, u2);
            if (!ls.valid) continue;
            const Vec3 local = v.frame.to_local(ls.wi);
            const Vec3 f = bsdf_eval<M>(m, v.wo, local);
            if (is_black(f)) continue;
            ++rays;
            const double t_max = ls.background ? kInf : ls.dist * (1.0 - kShadowEpsilon);
            if (scene_.occluded(Ray{shadow_origin(v, ref, ls.wi), ls.wi}, t_max)) continue;
            if (ls.delta) {
                // A delta light's sample is weighted 1 and, as in Mitsuba 3.9.1's direct.cpp
                // (which leaves out its 1 / emitter_samples there), not averaged over n_e:
                // reproduced, so that imported scenes agree (docs/mitsuba.md, Known differences).
                L += f * ls.radiance * (1.0 / ls.pdf);
                continue;
            }
            const double w = power_heuristic(frac_light * ls.pdf, frac_bsdf * bsdf_pdf<M>(m, v.wo, local));
            L += f * ls.radiance * (w / (ls.pdf * n_e));
        }
    }

    // Direction samples, drawn by the strategy's technique (the material's for `mis`).
    for (int i = 0; i < direct_.bsdf; ++i) {
        const std::optional<Scatter> s = sample_scatter(v, ref, rng);
        if (s) L += direct_bsdf_sample(v, ref, *s, frac_light, frac_bsdf, rays) * (1.0 / n_b);
    }
    return L;
}

template <Mutant M>
Vec3 Integrator<M>::direct_bsdf_sample(const Vertex& v, const Vec3& ref, const Scatter& s, double frac_light,
                                       double frac_bsdf, uint64_t& rays) const {
    // A sample of a Dirac lobe (a mirror, glass, a smooth plastic's coating) could not come
    // from a light sample: its emission counts fully, as in Mitsuba.
    const bool delta = s.delta;
    const Ray ray{continuation_origin(v, s.wi, delta), s.wi};
    ++rays;
    Interaction hit;
    Vec3 Le;
    double light_pdf = 0.0;  // the light samples' density of this direction (none for a Dirac lobe)
    if (!scene_.intersect(ray, hit)) {
        Le = scene_.background(s.wi);
        if (!delta) light_pdf = scene_.lights().background_pdf(s.wi);
    } else {
        const Material& e = scene_.material(hit.material);
        if (!e.emits() || dot(s.wi, hit.ns) >= 0.0) return Vec3(0.0);  // no emitter, or its back
        Le = e.radiance;
        if (!delta) light_pdf = scene_.lights().pdf_emitter(ref, s.wi, hit.prim, hit.p, hit.ns);
    }
    if (is_black(Le)) return Vec3(0.0);
    const double w = strategy_ == Strategy::MIS ? power_heuristic(frac_bsdf * s.pdf, frac_light * light_pdf) : 1.0;
    return s.weight * Le * w;
}

}  // namespace rt
