// The path integrator: one radiance estimate per camera ray, with the direction sampling
// strategy at non-specular bounces chosen per render (README.md, Conventions).
#pragma once

#include <cstdint>
#include <optional>

#include "mutants.h"
#include "rng.h"
#include "scene.h"

namespace rt {

class WavefrontIntegrator;

enum class Strategy : int {
    Uniform = 0,  // uniform hemisphere, pdf 1/(2 pi); no light sampling
    Cosine = 1,   // the material's own sampling (cosine for Lambertian, visible GGX normals)
    Light = 2,    // toward emitters only: direct light at diffuse vertices; biased on purpose
    Mixture = 3,  // one direction from 0.5 light pdf + 0.5 material pdf
    MIS = 4,      // next-event estimation + material sampling, power heuristic (Mitsuba `path`)
};

// Mitsuba's `direct` integrator: what the camera ray sees, plus the direct light at its
// first surface from `emitter` light samples and `bsdf` direction samples. Both counts 0:
// the path integrator.
struct DirectCounts {
    int emitter = 0;
    int bsdf = 0;

    bool enabled() const { return emitter + bsdf > 0; }
};

// M: a self-test mutant (mutants.h). Integrator<Mutant::None> is the tracer; the others
// are instantiated only in the self-test's module (mutants.cpp).
template <Mutant M>
class Integrator {
public:
    Integrator(const Scene& scene, Strategy strategy, DirectCounts direct = {})
        : scene_(scene), strategy_(strategy), direct_(direct) {}

    // Radiance arriving along `ray`; `rays` counts every ray cast (camera, continuation,
    // shadow/light rays). A hit of the camera ray at or beyond `reach` (the camera's far clip
    // plane) is a miss.
    Vec3 Li(Ray ray, PCG64& rng, uint64_t& rays, double reach = kInf) const {
        return direct_.enabled() ? Li_direct(ray, rng, rays, reach) : Li_path(ray, rng, rays, reach);
    }

    // Whether this integrator is Mitsuba's `direct` (only the scalar steps implement it).
    bool is_direct() const { return direct_.enabled(); }

private:
    // The wavefront integrator (wavefront.h) runs the same steps as Li on batches of paths.
    friend class WavefrontIntegrator;

    // A surface point where the path may scatter, in the frame its BSDF works in. Like
    // pbrt's BSDF it tests false where the path cannot scatter: a surface that does not
    // reflect, the back of a one-sided reflector, exact grazing. Built in place in Li: a
    // std::optional<Vertex> returned by a function was copied through the stack twice
    // per bounce.
    struct Vertex {
        const Interaction& it;  // the hit (ray offsets of a smooth triangle's vertex)
        const Material& m;
        Frame frame;  // around the shading normal: the front normal, flipped on the back
                      // of a two-sided reflector
        Vec3 wo;      // toward the previous vertex, in `frame`
        bool can_scatter;

        Vertex(const Interaction& it, const Material& m, const Vec3& d, bool front);
        explicit operator bool() const { return can_scatter; }
    };

    // Origins of the rays that leave a vertex: pushed off the surface along the geometric
    // normal, to the side the ray goes (Mitsuba's spawn_ray). Where the surface is flat,
    // the frame's normal is the geometric one up to its sign, and these keep the
    // arithmetic flat scenes have always had, bit for bit.
    // The reference point of light sampling: off the surface on the side of the frame.
    [[gnu::always_inline]] static Vec3 reference_point(const Vertex& v) {
        return offset_origin(v.it.p, v.it.smooth ? v.it.n : v.frame.n, v.frame.n);
    }
    // A shadow ray's origin toward wi, given the reference point ref: ref itself, except at
    // a smooth triangle's vertex, where a light sample may lie below the geometric surface
    // while above the shading one (the ray then starts below the surface, as Mitsuba's
    // spawn_ray_to does), and at a vertex whose BSDF transmits with a density (rough glass),
    // where the light may be on either side: the ray starts on the light's.
    [[gnu::always_inline]] static Vec3 shadow_origin(const Vertex& v, const Vec3& ref, const Vec3& wi) {
        if (v.it.smooth) return offset_origin(v.it.p, v.it.n, wi);
        return v.m.has_glossy_transmission() ? offset_origin(v.it.p, v.frame.n, wi) : ref;
    }
    // The next segment's origin toward wi. Delta lobes leave along the geometric normal,
    // the others along the frame's (the two differ only on the back of two-sided metal, and
    // there only for a direction exactly in the tangent plane: offset_origin's tie); a
    // smooth triangle's vertex always along the geometric normal.
    [[gnu::always_inline]] static Vec3 continuation_origin(const Vertex& v, const Vec3& wi, bool delta) {
        return offset_origin(v.it.p, delta || v.it.smooth ? v.it.n : v.frame.n, wi);
    }

    // A sampled continuation of the path.
    struct Scatter {
        Vec3 wi;           // world direction of the next segment
        Vec3 weight;       // what the throughput is multiplied by: f |cos| / pdf
        double pdf = 0.0;  // solid-angle density of wi (MIS weight of an emitter hit next)
        double eta = 1.0;  // relative index of refraction crossed (Russian roulette)
        bool delta = false;  // a Dirac lobe's: the next vertex sees it as a mirror bounce
    };

    // What the MIS weight of emission found by BSDF sampling needs of the vertex that
    // sampled it. The camera counts as a delta vertex: emission seen directly is not
    // weighted.
    struct PrevVertex {
        bool delta = true;
        double pdf = 0.0;  // its BSDF sample's density
        Vec3 ref;          // its reference point for light sampling
    };

    // MIS weights (1 unless `mis` after a non-delta vertex) of emission reached by the
    // previous vertex's BSDF sample: an emitter's surface at `it`, or the background.
    double emitter_weight(const PrevVertex& prev, const Ray& ray, const Interaction& it) const;
    // d: the escaping ray's direction (an environment map's density depends on it).
    double background_weight(const PrevVertex& prev, const Vec3& d) const;

    // Next-event estimation for `mis` (pbrt's SampleLd): beta times one light sample's
    // contribution at v, seen from ref; none if the sample brings nothing. `occluded(ray,
    // t_max)` answers its shadow ray: Scene::occluded in Li; the wavefront integrator
    // queues the ray instead (answering "not occluded") and applies the verdict later.
    template <typename Occluded>
    std::optional<Vec3> sample_ld(const Vertex& v, const Vec3& ref, const Vec3& beta, PCG64& rng, uint64_t& rays,
                                  Occluded&& occluded) const;
    // sample_ld after its light sample `ls` (drawn with three uniforms where the scene has
    // emitters): the wavefront integrator draws the uniforms, samples the lights for
    // several lanes at once and finishes each lane here.
    template <typename Occluded>
    std::optional<Vec3> estimate_ld(const Vertex& v, const Vec3& beta, const LightSample& ls, uint64_t& rays,
                                    const Vec3& ref, Occluded&& occluded) const;
    // The `light` strategy at a non-delta vertex, where its path ends: beta times the
    // radiance arriving straight along one direction sampled toward the emitters (or, for a
    // delta light's sample, what it brings, unless a shadow ray finds it occluded).
    std::optional<Vec3> light_only(const Vertex& v, const Vec3& ref, const Vec3& beta, PCG64& rng,
                                   uint64_t& rays) const;
    // The next direction: the material's own sampling at a delta vertex (whatever the
    // strategy: light sampling could never meet a Dirac lobe); elsewhere the strategy's.
    // A Dirac lobe beside other lobes (smooth plastic) is left to the material's sampling,
    // with its own probability, by every strategy but `light`, whose estimate at such a
    // vertex (light_only) is the other lobes' direct light alone.
    std::optional<Scatter> sample_scatter(const Vertex& v, const Vec3& ref, PCG64& rng) const;
    static std::optional<Scatter> sample_material(const Vertex& v, PCG64& rng);
    // The continuation of a material sample bs (local frame) at v; none if it failed.
    static std::optional<Scatter> scatter_of(const Vertex& v, const BSDFSample& bs) {
        if (!bs.valid) return std::nullopt;
        return Scatter{v.frame.to_world(bs.wi), bs.weight, bs.pdf, bs.eta, bs.delta};
    }
    // A direction uniform on the hemisphere of the frame's normal; on the whole sphere at a
    // vertex whose BSDF transmits with a density (rough glass).
    static std::optional<Scatter> sample_uniform(const Vertex& v, PCG64& rng);
    // sample_uniform at a vertex whose material has a Dirac lobe beside its others (smooth
    // plastic, a mask's null lobe), given the direction's uniforms: the Dirac lobe with the material's own
    // probability (no uniform direction can meet it), the uniform direction otherwise.
    static std::optional<Scatter> sample_uniform_beside_delta(const Vertex& v, double u1, double u2, PCG64& rng);
    std::optional<Scatter> sample_mixture(const Vertex& v, const Vec3& ref, PCG64& rng) const;

    // Radiance along (o, wi) that comes straight from an emitter or the background: the
    // emission of the first surface hit (front side only), or the background on escape.
    Vec3 direct_emission(const Vec3& o, const Vec3& wi, uint64_t& rays) const;

    // Whether the path goes on after its depth-th segment: not once the throughput is
    // black, and Russian roulette from rr_depth on (reweighting beta of the survivors).
    bool survives(int depth, double eta, Vec3& beta, PCG64& rng) const;

    // The path integrator (Mitsuba `path`) with the strategy at every non-delta vertex.
    Vec3 Li_path(Ray ray, PCG64& rng, uint64_t& rays, double reach) const;
    // Mitsuba's `direct` (integrator_direct.h): the strategy picks the direction sampling
    // of the `bsdf` samples; `mis` weighs them against the light samples.
    Vec3 Li_direct(const Ray& ray, PCG64& rng, uint64_t& rays, double reach) const;
    // The emission that arrives at v's reference point `ref` along the sampled direction
    // s->wi, weighted against the light samples' density (Li_direct's BSDF technique).
    Vec3 direct_bsdf_sample(const Vertex& v, const Vec3& ref, const Scatter& s, double frac_light,
                            double frac_bsdf, uint64_t& rays) const;

    const Scene& scene_;
    Strategy strategy_;
    DirectCounts direct_;
};

// Defined in integrator_impl.h: the tracer's instantiation in integrator.cpp, the mutants'
// in mutants.cpp.
extern template class Integrator<Mutant::None>;

}  // namespace rt
