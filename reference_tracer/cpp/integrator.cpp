#include "integrator.h"

namespace rt {

// Relative gap left before a sampled light point by shadow rays: far above the relative
// error of the sampled point (~1e-15 in double), far below any modelled geometry gap.
constexpr double kShadowEpsilon = 1e-7;

Vec3 Integrator::direct_emission(const Vec3& o, const Vec3& wi, uint64_t& rays) const {
    ++rays;
    Interaction it;
    if (!scene_.intersect(Ray{o, wi}, it)) return scene_.settings().background;
    const Material& m = scene_.material(it.material);
    return (m.emits() && dot(wi, it.n) < 0.0) ? m.radiance : Vec3(0.0);
}

Vec3 Integrator::Li(Ray ray, PCG32& rng, uint64_t& rays) const {
    const SceneSettings& cfg = scene_.settings();
    const LightSampler& lights = scene_.lights();
    const bool has_lights = !lights.empty();

    Vec3 L(0.0), beta(1.0);
    double eta = 1.0;           // product of relative IORs crossed (Russian roulette)
    bool prev_delta = true;     // the camera counts as a delta vertex: emission seen fully
    double prev_bsdf_pdf = 0.0; // for MIS weights of emitters hit by BSDF sampling
    Vec3 prev_ref;              // reference point of the previous vertex

    for (int depth = 0;; ) {
        ++rays;
        Interaction it;
        if (!scene_.intersect(ray, it)) {
            if (max_component(cfg.background) > 0.0) {
                double w = 1.0;
                if (strategy_ == Strategy::MIS && !prev_delta)
                    w = power_heuristic(prev_bsdf_pdf, lights.background_pdf());
                L += beta * cfg.background * w;
            }
            break;
        }
        const Material& m = scene_.material(it.material);
        const bool front = dot(ray.d, it.n) < 0.0;

        // Emission (one-sided: front face only, as Mitsuba's area emitter).
        if (front && m.emits()) {
            double w = 1.0;
            if (strategy_ == Strategy::MIS && !prev_delta)
                w = power_heuristic(prev_bsdf_pdf, lights.pdf_emitter(prev_ref, ray.d, it.prim, it.p, it.n));
            L += beta * m.radiance * w;
        }

        // Another segment is allowed only while depth + 1 < max_depth (Mitsuba's rule).
        if (depth + 1 >= cfg.max_depth || !m.reflects) break;

        // Shading frame: glass keeps its front normal (inside/outside matters); reflectors
        // are black from the back unless two-sided, in which case the frame flips.
        Vec3 n = it.n;
        if (!m.is_glass() && !front) {
            if (!m.two_sided) break;
            n = -n;
        }
        const Frame frame(n);
        const Vec3 wo = frame.to_local(-ray.d);
        if (wo.z == 0.0 && !m.is_glass()) break;  // exactly grazing: no reflection

        if (m.is_delta()) {
            const BSDFSample bs = bsdf_sample(m, wo, rng.next_double(), rng.next_double(), rng.next_double());
            if (!bs.valid) break;
            beta *= bs.weight;
            eta *= bs.eta;
            const Vec3 wi = frame.to_world(bs.wi);
            ray = Ray{offset_origin(it.p, it.n, wi), wi};
            prev_delta = true;
        } else {
            // Reference point for light sampling and the next ray: just off the surface on
            // the reflecting side, so sphere lights are seen from the correct side.
            const Vec3 ref = offset_origin(it.p, n, n);
            Vec3 wi;
            switch (strategy_) {
                case Strategy::Uniform: {
                    const Vec3 local = square_to_uniform_hemisphere(rng.next_double(), rng.next_double());
                    const Vec3 f = bsdf_eval(m, wo, local);
                    if (is_black(f)) goto done;
                    beta *= f * (1.0 / kUniformHemispherePdf);
                    wi = frame.to_world(local);
                    break;
                }
                case Strategy::Cosine: {
                    const BSDFSample bs = bsdf_sample(m, wo, rng.next_double(), rng.next_double(), rng.next_double());
                    if (!bs.valid) goto done;
                    beta *= bs.weight;
                    wi = frame.to_world(bs.wi);
                    break;
                }
                case Strategy::Light: {
                    // Direct light only: sample toward an emitter, take what arrives
                    // straight from it, and end the path (indirect light is missed).
                    if (!has_lights) goto done;
                    const double u0 = rng.next_double(), u1 = rng.next_double(), u2 = rng.next_double();
                    const LightSample ls = lights.sample(ref, u0, u1, u2);
                    if (!ls.valid) goto done;
                    const Vec3 f = bsdf_eval(m, wo, frame.to_local(ls.wi));
                    if (is_black(f)) goto done;
                    const double pdf = lights.pdf_all(ref, ls.wi);
                    if (pdf > 0.0) L += beta * f * direct_emission(ref, ls.wi, rays) / pdf;
                    goto done;
                }
                case Strategy::Mixture: {
                    const double u0 = rng.next_double(), u1 = rng.next_double(), u2 = rng.next_double();
                    const double choose = rng.next_double();
                    Vec3 local;
                    if (has_lights && choose < 0.5) {
                        const LightSample ls = lights.sample(ref, u0, u1, u2);
                        if (!ls.valid) goto done;
                        wi = ls.wi;
                        local = frame.to_local(wi);
                    } else {
                        const BSDFSample bs = bsdf_sample(m, wo, u0, u1, u2);
                        if (!bs.valid) goto done;
                        local = bs.wi;
                        wi = frame.to_world(local);
                    }
                    const Vec3 f = bsdf_eval(m, wo, local);
                    if (is_black(f)) goto done;
                    const double pdf_m = bsdf_pdf(m, wo, local);
                    const double pdf = has_lights ? 0.5 * lights.pdf_all(ref, wi) + 0.5 * pdf_m : pdf_m;
                    if (!(pdf > 0.0)) goto done;
                    beta *= f / pdf;
                    break;
                }
                case Strategy::MIS: {
                    if (has_lights) {  // next-event estimation
                        const double u0 = rng.next_double(), u1 = rng.next_double(), u2 = rng.next_double();
                        const LightSample ls = lights.sample(ref, u0, u1, u2);
                        if (ls.valid) {
                            const Vec3 local = frame.to_local(ls.wi);
                            const Vec3 f = bsdf_eval(m, wo, local);
                            if (!is_black(f)) {
                                ++rays;
                                // The shadow ray stops just short of the sampled point, so
                                // the emitter itself does not count as an occluder.
                                const double t_max = ls.background ? kInf : ls.dist * (1.0 - kShadowEpsilon);
                                if (!scene_.occluded(Ray{ref, ls.wi}, t_max)) {
                                    const double w = power_heuristic(ls.pdf, bsdf_pdf(m, wo, local));
                                    L += beta * f * ls.radiance * (w / ls.pdf);
                                }
                            }
                        }
                    }
                    const BSDFSample bs = bsdf_sample(m, wo, rng.next_double(), rng.next_double(), rng.next_double());
                    if (!bs.valid) goto done;
                    beta *= bs.weight;
                    prev_bsdf_pdf = bs.pdf;
                    wi = frame.to_world(bs.wi);
                    break;
                }
            }
            prev_delta = false;
            prev_ref = ref;
            ray = Ray{offset_origin(it.p, n, wi), wi};
        }

        ++depth;
        // Russian roulette, Mitsuba's rule: from depth rr_depth on, continue with
        // probability min(max(throughput) * eta^2, 0.95).
        const double beta_max = max_component(beta);
        if (!(beta_max > 0.0)) break;
        if (cfg.rr_depth >= 0 && depth >= cfg.rr_depth) {
            const double q = std::min(beta_max * eta * eta, 0.95);
            if (rng.next_double() >= q) break;
            beta *= 1.0 / q;
        }
    }
done:
    return L;
}

}  // namespace rt
