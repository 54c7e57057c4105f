// Definitions of rt::Integrator<M> (integrator.h), included by integrator.cpp (the tracer,
// Mutant::None) and mutants.cpp (the self-test's seeded bugs). Every seeded line is an
// `if constexpr` (or a constant chosen at compile time) on M.
#pragma once

#include "integrator.h"

namespace rt {

// Relative gap left before a sampled light point by shadow rays: far above the relative
// error of the sampled point (~1e-15 in double), far below any modelled geometry gap.
constexpr double kShadowEpsilon = 1e-7;
// Mutant::ShadowEpsilonLeak: a "safe" 1% that lets occluders near the light leak (Mitsuba's
// shadow epsilon is ~9e-4 relative, in single precision).
constexpr double kLeakyShadowEpsilon = 1e-2;

// Glass keeps its front normal (inside/outside matters); reflectors are black from the
// back unless two-sided, in which case the frame flips; a masked surface scatters from
// both sides (its null lobe), in the front frame unless its nested material is two-sided. Front and back are those of the
// shading normal it.ns (Mitsuba's BSDFs test only the cosines of its shading frame, with
// no check against the geometric normal: a smooth triangle's light leaks and black
// regions stay as Mitsuba has them).
// Always inline here, in sample_scatter and sample_material: with two callers (Li and the wavefront
// integrator) GCC left both out of line, +4% instructions per sample.
template <Mutant M>
[[gnu::always_inline]] inline Integrator<M>::Vertex::Vertex(const Interaction& it_, const Material& m_, const Vec3& d, bool front)
    : it(it_), m(m_), frame(front || m_.keeps_front_frame() ? it_.ns : -it_.ns), wo(frame.to_local(-d)),
      can_scatter(m_.reflects && (front || m_.is_glass() || m_.two_sided || m_.masked()) &&
                  (wo.z != 0.0 || m_.is_glass())) {}  // exactly grazing: no reflection

template <Mutant M>
double Integrator<M>::emitter_weight(const PrevVertex& prev, const Ray& ray, const Interaction& it) const {
    // Only `mis` samples lights and directions both, and only at non-delta vertices.
    if (strategy_ != Strategy::MIS || prev.delta) return 1.0;
    if constexpr (M == Mutant::EmitterWeightOne) return 1.0;  // seeded bug: NEE and BSDF hits both count fully
    return power_heuristic(prev.pdf, scene_.lights().pdf_emitter(prev.ref, ray.d, it.prim, it.p, it.ns));
}

template <Mutant M>
double Integrator<M>::background_weight(const PrevVertex& prev, const Vec3& d) const {
    if (strategy_ != Strategy::MIS || prev.delta) return 1.0;
    return power_heuristic(prev.pdf, scene_.lights().background_pdf(d));
}

template <Mutant M>
template <typename Occluded>
std::optional<Vec3> Integrator<M>::sample_ld(const Vertex& v, const Vec3& ref, const Vec3& beta, PCG64& rng,
                                             uint64_t& rays, Occluded&& occluded) const {
    const LightSampler& lights = scene_.lights();
    if (lights.empty()) return std::nullopt;
    const double u0 = rng.next_double(), u1 = rng.next_double(), u2 = rng.next_double();
    return estimate_ld(v, beta, lights.sample<M>(ref, u0, u1, u2), rays, ref, occluded);
}

template <Mutant M>
template <typename Occluded>
std::optional<Vec3> Integrator<M>::estimate_ld(const Vertex& v, const Vec3& beta, const LightSample& ls,
                                               uint64_t& rays, const Vec3& ref, Occluded&& occluded) const {
    if (!ls.valid) return std::nullopt;
    const Vec3 local = v.frame.to_local(ls.wi);
    const Vec3 f = bsdf_eval<M>(v.m, v.wo, local);
    if (is_black(f)) return std::nullopt;  // no shadow ray for a direction the BSDF ignores
    ++rays;
    // The shadow ray stops just short of the sampled point, so the emitter itself does not
    // count as an occluder.
    constexpr double eps = M == Mutant::ShadowEpsilonLeak ? kLeakyShadowEpsilon : kShadowEpsilon;
    const double t_max = ls.background ? kInf : ls.dist * (1.0 - eps);
    if (occluded(Ray{shadow_origin(v, ref, ls.wi), ls.wi}, t_max)) return std::nullopt;
    // The MIS weight over the density; a delta light's sample is weighted 1: no BSDF sample
    // can meet it (Mitsuba's ds.delta).
    const double scale = ls.delta ? 1.0 / ls.pdf : power_heuristic_over(ls.pdf, bsdf_pdf<M>(v.m, v.wo, local));
    // beta enters the product first: the order fixes the rounding, which the wavefront
    // integrator's packs repeat (estimate_diffuse).
    return beta * f * ls.radiance * scale;
}

template <Mutant M>
std::optional<Vec3> Integrator<M>::light_only(const Vertex& v, const Vec3& ref, const Vec3& beta, PCG64& rng,
                                              uint64_t& rays) const {
    const LightSampler& lights = scene_.lights();
    if (lights.empty()) return std::nullopt;
    const double u0 = rng.next_double(), u1 = rng.next_double(), u2 = rng.next_double();
    const LightSample ls = lights.sample<M>(ref, u0, u1, u2);
    if (!ls.valid) return std::nullopt;
    const Vec3 f = bsdf_eval<M>(v.m, v.wo, v.frame.to_local(ls.wi));
    if (is_black(f)) return std::nullopt;
    if (ls.delta) {
        // A delta light: only this sample reaches it (no direction has a density of it), so
        // its estimate is what it brings over its selection's probability, if unoccluded.
        ++rays;
        const double t_max = ls.background ? kInf : ls.dist * (1.0 - kShadowEpsilon);
        if (scene_.occluded(Ray{shadow_origin(v, ref, ls.wi), ls.wi}, t_max)) return std::nullopt;
        return beta * f * ls.radiance * (1.0 / ls.pdf);
    }
    // The density of the direction is that of the whole light sampler (every emitter the
    // line meets could have produced it), and the radiance is whatever the ray meets first.
    const double pdf = lights.pdf_all(ref, ls.wi);
    if (!(pdf > 0.0)) return std::nullopt;
    return beta * f * direct_emission(shadow_origin(v, ref, ls.wi), ls.wi, rays) / pdf;
}

template <Mutant M>
[[gnu::always_inline]] inline auto Integrator<M>::sample_scatter(const Vertex& v, const Vec3& ref, PCG64& rng) const
    -> std::optional<Scatter> {
    // At a delta vertex every strategy samples the material's lobe, as `cosine` does. One
    // call site for sample_material keeps it inline: with two, GCC left it out of line,
    // returning its sample through memory.
    switch (v.m.is_delta() ? Strategy::Cosine : strategy_) {
        case Strategy::Uniform: return sample_uniform(v, rng);
        case Strategy::Cosine:
        case Strategy::MIS: return sample_material(v, rng);
        case Strategy::Mixture: return sample_mixture(v, ref, rng);
        case Strategy::Light: break;  // its paths end at the first non-delta vertex (light_only)
    }
    return std::nullopt;
}

template <Mutant M>
[[gnu::always_inline]] inline auto Integrator<M>::sample_material(const Vertex& v, PCG64& rng) -> std::optional<Scatter> {
    // The three uniforms are drawn last first. Earlier versions passed three
    // rng.next_double() calls straight as bsdf_sample's arguments, whose evaluation order
    // C++ leaves to the compiler, and GCC evaluates them right to left. Drawing them
    // explicitly in that order keeps every image bit-identical to the earlier ones, and
    // the order no longer depends on the compiler.
    const double u2 = rng.next_double(), u1 = rng.next_double(), u0 = rng.next_double();
    return scatter_of(v, bsdf_sample<M>(v.m, v.wo, u0, u1, u2));
}

template <Mutant M>
auto Integrator<M>::sample_uniform(const Vertex& v, PCG64& rng) -> std::optional<Scatter> {
    const double u2 = rng.next_double(), u1 = rng.next_double();  // last first, as sample_material
    if (v.m.has_delta_lobe()) return sample_uniform_beside_delta(v, u1, u2, rng);
    if (v.m.has_glossy_transmission()) {
        const Vec3 local = square_to_uniform_sphere(u1, u2);
        const Vec3 f = bsdf_eval<M>(v.m, v.wo, local);
        if (is_black(f)) return std::nullopt;
        const double eta = rough_dielectric::eta_crossed(v.m.rough_dielectric(), v.wo, local);
        return Scatter{v.frame.to_world(local), f * (1.0 / kUniformSpherePdf), kUniformSpherePdf, eta};
    }
    const Vec3 local = square_to_uniform_hemisphere(u1, u2);
    const Vec3 f = bsdf_eval<M>(v.m, v.wo, local);
    if (is_black(f)) return std::nullopt;
    return Scatter{v.frame.to_world(local), f * (1.0 / kUniformHemispherePdf), kUniformHemispherePdf};
}

template <Mutant M>
auto Integrator<M>::sample_uniform_beside_delta(const Vertex& v, double u1, double u2, PCG64& rng)
    -> std::optional<Scatter> {
    const double u0 = rng.next_double();
    const double p_delta = bsdf_delta_probability(v.m, v.wo);
    // The material's sample with the same u0 is its Dirac lobe, weighted by 1 / p_delta.
    if (u0 < p_delta) return scatter_of(v, bsdf_sample<M>(v.m, v.wo, u0, u1, u2));
    if (v.m.has_glossy_transmission()) {  // rough glass under a mask: the whole sphere
        const Vec3 local = square_to_uniform_sphere(u1, u2);
        const Vec3 f = bsdf_eval<M>(v.m, v.wo, local);
        if (is_black(f)) return std::nullopt;
        const double pdf = (1.0 - p_delta) * kUniformSpherePdf;
        const double eta = rough_dielectric::eta_crossed(v.m.rough_dielectric(), v.wo, local);
        return Scatter{v.frame.to_world(local), f * (1.0 / pdf), pdf, eta};
    }
    const Vec3 local = square_to_uniform_hemisphere(u1, u2);
    const Vec3 f = bsdf_eval<M>(v.m, v.wo, local);
    if (is_black(f)) return std::nullopt;
    const double pdf = (1.0 - p_delta) * kUniformHemispherePdf;
    return Scatter{v.frame.to_world(local), f * (1.0 / pdf), pdf};
}

template <Mutant M>
auto Integrator<M>::sample_mixture(const Vertex& v, const Vec3& ref, PCG64& rng) const
    -> std::optional<Scatter> {
    const LightSampler& lights = scene_.lights();
    const bool has_lights = !lights.empty();
    // The same three uniforms serve whichever half is chosen. All four are drawn in every
    // case (also without lights), as before: the count fixes the pixel's later samples.
    const double u0 = rng.next_double(), u1 = rng.next_double(), u2 = rng.next_double();
    const double choose = rng.next_double();
    Vec3 wi, local;
    if (has_lights && choose < 0.5) {
        const LightSample ls = lights.sample<M>(ref, u0, u1, u2);
        // A delta light's direction has no density to continue the path with: the sample
        // fails (`mixture` cannot see delta lights; rt.render refuses such scenes for it).
        if (!ls.valid || ls.delta) return std::nullopt;
        wi = ls.wi;
        local = v.frame.to_local(wi);
    } else {
        const BSDFSample bs = bsdf_sample<M>(v.m, v.wo, u0, u1, u2);
        if (!bs.valid) return std::nullopt;
        // A Dirac lobe beside the others (smooth plastic): only this half meets it, so its
        // probability is the material's times this half's.
        if (bs.delta)
            return Scatter{v.frame.to_world(bs.wi), bs.weight * (has_lights ? 2.0 : 1.0), bs.pdf, bs.eta, true};
        local = bs.wi;
        wi = v.frame.to_world(local);
    }
    const Vec3 f = bsdf_eval<M>(v.m, v.wo, local);
    if (is_black(f)) return std::nullopt;
    // One-sample estimator: divide by the density of the whole procedure, half of each
    // (all of the material's where there is nothing to light-sample).
    const double pdf_m = bsdf_pdf<M>(v.m, v.wo, local);
    const double pdf = has_lights ? 0.5 * lights.pdf_all(ref, wi) + 0.5 * pdf_m : pdf_m;
    if (!(pdf > 0.0)) return std::nullopt;
    // Rough glass: the index crossed, as its own samples report it (Russian roulette).
    if (v.m.has_glossy_transmission())
        return Scatter{wi, f / pdf, pdf, rough_dielectric::eta_crossed(v.m.rough_dielectric(), v.wo, local)};
    return Scatter{wi, f / pdf, pdf};
}

template <Mutant M>
Vec3 Integrator<M>::direct_emission(const Vec3& o, const Vec3& wi, uint64_t& rays) const {
    ++rays;
    Interaction it;
    if (!scene_.intersect(Ray{o, wi}, it)) return scene_.background(wi);
    const Material& m = scene_.material(it.material);
    if constexpr (M == Mutant::TwoSidedLight) return m.emits() ? m.radiance : Vec3(0.0);  // seeded bug
    return (m.emits() && dot(wi, it.ns) < 0.0) ? m.radiance : Vec3(0.0);
}

// Always inline: the wavefront integrator called it out of line, a call per vertex (1.2% of
// furnace's instructions in the call and its arguments).
template <Mutant M>
[[gnu::always_inline]] inline bool Integrator<M>::survives(int depth, double eta, Vec3& beta, PCG64& rng) const {
    const double beta_max = max_component(beta);
    if (!(beta_max > 0.0)) return false;  // black (or NaN): nothing more to carry
    const int rr_depth = scene_.settings().rr_depth;
    if (rr_depth < 0 || depth < rr_depth) return true;
    // Russian roulette, Mitsuba's rule: continue with probability
    // min(max(throughput) * eta^2, 0.95). eta^2 compensates the 1/eta^2 radiance scaling
    // at refraction (solid-angle compression), which is no loss of energy.
    const double q = std::min(beta_max * eta * eta, 0.95);
    if (rng.next_double() >= q) return false;
    if constexpr (M != Mutant::RouletteNoReweight) beta *= 1.0 / q;  // the mutant forgets it
    return true;
}

template <Mutant M>
Vec3 Integrator<M>::Li_path(Ray ray, PCG64& rng, uint64_t& rays, double reach) const {
    const SceneSettings& cfg = scene_.settings();
    Vec3 L(0.0), beta(1.0);
    double eta = 1.0;  // product of relative IORs crossed (Russian roulette)
    PrevVertex prev;

    for (int depth = 0;; ++depth) {
        ++rays;
        Interaction it;
        // reach: the camera ray's (inf for the plain pinhole and for every later segment:
        // their hits are what they always were).
        if (!scene_.intersect(ray, it) || !(it.t < reach)) {
            if (scene_.has_background()) L += beta * scene_.background(ray.d) * background_weight(prev, ray.d);
            return L;
        }
        const Material& m = scene_.material(it.material);
        const bool front = dot(ray.d, it.ns) < 0.0;
        // Emission is one-sided: front face only, as Mitsuba's area emitter (the front
        // of the shading normal). (Mutant::TwoSidedLight: the back emits too.)
        if ((front || M == Mutant::TwoSidedLight) && m.emits()) L += beta * m.radiance * emitter_weight(prev, ray, it);

        // Another segment is allowed only while depth + 1 < max_depth (Mitsuba's rule).
        // (Mutant::MaxDepthOffByOne: `>` for `>=`, one segment more.)
        if (M == Mutant::MaxDepthOffByOne ? depth + 1 > cfg.max_depth : depth + 1 >= cfg.max_depth) return L;
        std::optional<Material> textured;  // the material with its texture's value at the hit, where it has one
        const Vertex v(it, scene_.shade(m, it, textured), ray.d, front);
        if (!v) return L;

        // Light sampling, at non-delta vertices only (it could never meet a Dirac lobe).
        Vec3 ref;
        if (!m.is_delta()) {
            // Reference point for light sampling: just off the surface on the reflecting
            // side, so sphere lights are seen from the correct side (along the geometric
            // normal: reference_point).
            ref = reference_point(v);
            if (strategy_ == Strategy::Light) {  // all of `light`'s estimate: its path ends here
                if (const std::optional<Vec3> Ld = light_only(v, ref, beta, rng, rays)) L += *Ld;
                return L;
            }
            if (strategy_ == Strategy::MIS) {
                const auto occluded = [this](const Ray& r, double t_max) { return scene_.occluded(r, t_max); };
                if (const std::optional<Vec3> Ld = sample_ld(v, ref, beta, rng, rays, occluded)) L += *Ld;
            }
        }

        const std::optional<Scatter> s = sample_scatter(v, ref, rng);
        if (!s) return L;
        beta *= s->weight;
        eta *= s->eta;
        // Whether the sample is a Dirac lobe's, not whether the material has one: the
        // same for the mirror and glass (all delta) and the others (none), but per
        // sample for smooth plastic, whose specular bounce is a mirror's to the next
        // vertex (an emitter hit there is not weighted: no light sample could have met it).
        prev = PrevVertex{s->delta, s->pdf, ref};
        ray = Ray{continuation_origin(v, s->wi, s->delta), s->wi};
        reach = kInf;
        if (!survives(depth + 1, eta, beta, rng)) return L;
    }
}

}  // namespace rt

#include "integrator_direct.h"
