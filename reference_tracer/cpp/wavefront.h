// The wavefront integrator: the path integrator of integrator.h run on a batch of paths
// at once, so that each bounce's intersection queries (closest hits, then shadow rays)
// go to the scene as one batch, which it answers several rays per instruction
// (Scene::intersect_batch / occluded_batch).
//
// Each lane of the batch owns one pixel and runs that pixel's samples one after the
// other, drawing from the pixel's own random stream in the same order as render_pixel
// and Integrator::Li do; a lane whose path ends starts the pixel's next sample (or a new
// pixel) before the next bounce, so lanes never idle while work is left (the "busy
// lanes" loss of a packet that runs until its longest path ends: PERFORMANCE.md, Ideas tried).
// Every sample is therefore the very number the scalar integrator computes, summed in
// the same order: the two integrators' images are the same bit for bit.
//
// Besides the queries, the steps that run a pack of lanes at a time are the camera rays,
// the light samples and, at diffuse vertices of `cosine` and `mis`, next-event estimation
// and the continuation (VertexQueue): lane-wise, with the scalar code's operations in its
// order, so that each lane's result is still the scalar integrator's bit for bit
// (tests/reference_tracer/test_wavefront.py checks both integrators' images on every suite scene and
// strategy). The other materials' vertices run the scalar integrator's own code lane by
// lane.
#pragma once

#include <atomic>
#include <cstdint>
#include <optional>
#include <vector>

#include "render_pixel.h"

namespace rt {

class WavefrontIntegrator {
public:
    // Paths in flight per worker: every lane is refilled each bounce, so the batches are
    // full packs (simd.h) but for the render's last pixels; few enough that the lanes, rays
    // and hits stay in L1. 16 and 64 measured slower than 32 (PERFORMANCE.md, Ideas tried).
    static constexpr int kLanes = 32;

    WavefrontIntegrator(const Integrator<Mutant::None>& integrator, const RenderJob& job);

    // Renders the pixels that `pixels` hands out into `out`, until none is left or
    // `cancel` is set; counts finished pixels in `pixels_done`, rays cast and discarded
    // non-finite samples in `rays` and `nonfinite`.
    void run(TileCursor& pixels, RenderOutput& out, const std::atomic<bool>& cancel,
             std::atomic<uint64_t>& pixels_done, uint64_t& rays, uint64_t& nonfinite) const;

private:
    using PrevVertex = Integrator<Mutant::None>::PrevVertex;
    using Vertex = Integrator<Mutant::None>::Vertex;

    // One lane: its pixel's running sums and the state of its current path, that is the
    // locals of render_pixel and Integrator::Li.
    struct Lane {
        bool busy = false;     // holds a pixel
        int x = 0, y = 0;
        int samples_left = 0;  // samples of the pixel still to start
        PCG64 rng{0, 0};
        double s[3] = {0, 0, 0}, s2[3] = {0, 0, 0};
        detail::TailSums tails;

        double film[2] = {0, 0};  // the sample's film point (px, py), until camera_rays()
        double lens[2] = {0, 0};  // a thin lens's aperture numbers, until camera_rays()
        Ray ray;               // the path's next segment
        double reach = kInf;   // the camera ray's (Camera::generate), while depth is 0
        Vec3 L, beta;
        double eta = 1.0;
        PrevVertex prev;
        int depth = 0;
        bool path_done = false;

        // The closest hit of `ray` (written there by the batch's query), and what
        // next_event() and scatter() need of shade(): the vertex and its light-sampling
        // reference point.
        Interaction it;
        std::optional<Vertex> vertex;  // not built where the vertex scatters diffusely
        Vec3 normal;           // the vertex's shading normal (its frame's n)
        double wo_z = 0.0;     // the local z of wo
        Vec3 ref;              // not set where the vertex scatters diffusely (the queue's packs compute it)

        // The shadow ray to trace before the next bounce, where next_events() listed one.
        Ray shadow_ray;
        double shadow_t_max = 0.0;
        Vec3 shadow_value;     // what it adds to L when unoccluded

        // Where the scene has textures, this lane's slot for a textured vertex's material
        // (Scene::shade), kept beside the lanes by run(): a pointer, so that a lane of a
        // scene without textures is no larger than it was (the lanes stay in L1).
        std::optional<Material>* textured = nullptr;
    };

    // The work queue of one bounce's vertices that run in packs: the lanes that take a light
    // sample (`mis` at a non-delta vertex) or scatter diffusely (`cosine` and `mis` at a
    // Lambertian vertex), in the order shade()'s loop finds them, with what those steps need
    // of each in structure-of-arrays form (position k: the k-th such lane). Their reference
    // point, offset_origin(p, n, n), is computed from p and n a pack at a time (math.h's
    // offset_toward on packs); shade() computes it only for the vertices that need it lane
    // by lane. The light samples, the whole estimate at diffuse vertices and their continuation then run a pack
    // of positions at a time and load their inputs as vectors: packs that gathered them from
    // the lanes' structures, field by field, cost what they saved (PERFORMANCE.md, Ideas
    // tried).
    struct VertexQueue {
        alignas(64) double light[kLanes];    // 1 where the vertex takes a light sample, else 0
        alignas(64) double diffuse[kLanes];  // 1 where its material is diffuse, else 0
        alignas(64) double scatter[kLanes];  // 1 where it scatters diffusely (scatter_diffuse)
        alignas(64) double u[3][kLanes];     // the light sample's uniforms u0, u1, u2
        alignas(64) double su[2][kLanes];    // the diffuse direction's uniforms u1, u2
        alignas(64) double n[3][kLanes];     // the vertex's shading normal (its frame's n)
        alignas(64) double wo_z[kLanes];     // the local z of wo
        alignas(64) double albedo[3][kLanes];
        alignas(64) double beta[3][kLanes];
        alignas(64) double p[3][kLanes];     // the hit point
        // Scenes with smooth triangles only (smooth_): 1 where the vertex is on one, else 0,
        // and the normal its rays are offset along (the geometric one there, elsewhere n).
        alignas(64) double smooth[kLanes];
        alignas(64) double g[3][kLanes];
        Lane* lanes[kLanes];
    };

    // What shade() and queue_vertex() ask of a vertex's material, decided once per render
    // for each material (bits of material_flags_): a few loads and tests a vertex otherwise.
    enum MaterialFlag : uint8_t {
        kEmits = 1,              // Material::emits()
        kScattersDiffusely = 2,  // scatters_diffusely()
        kTakesLightSample = 4,   // `mis`'s light sample at a non-delta vertex, lights present
        kDiffuse = 8,            // is_diffuse()
        kSamplesGGX = 16,        // scatter() samples plain GGX (samples_ggx): scatter_ggx()
    };

    static bool is_diffuse(const Material& m) {
        return m.type == MaterialType::Lambertian || m.type == MaterialType::DiffuseLight;
    }
    // Whether a vertex of material m scatters as lambertian::sample does, in
    // scatter_diffuse(): sample_material at a diffuse vertex of `cosine` or `mis`.
    bool scatters_diffusely(const Material& m) const {
        return is_diffuse(m) && (integrator_.strategy_ == Strategy::Cosine || integrator_.strategy_ == Strategy::MIS);
    }

    // Whether scatter() at a vertex of material m samples a rough conductor of plain GGX
    // and Fresnel 1 (sample_scatter's material sample: `cosine` and `mis`), which
    // scatter_ggx() does a pack of lanes at a time.
    bool samples_ggx(const Material& m) const {
        return m.type == MaterialType::RoughConductor && m.rough().plain_ggx() &&
               (integrator_.strategy_ == Strategy::Cosine || integrator_.strategy_ == Strategy::MIS);
    }

    // Takes the next pixel for `lane`; false (the lane idle) when none is left.
    bool start_pixel(Lane& lane, TileCursor& pixels) const;
    // Starts the pixel's next sample: its film point, as render_pixel draws it, and the
    // path's state; camera_rays() then gives a pack of such lanes their camera rays at once.
    void start_sample(Lane& lane) const;
    void camera_rays(Lane* const* lanes, int n) const;
    // One vertex of Integrator::Li's loop in parts, each run over the whole batch before
    // the next, so that the independent lanes overlap each part's long chains of dependent
    // arithmetic instead of waiting on them one lane after another (cornell_box +8%,
    // cornell_mesh +11%, furnace +5%: PERFORMANCE.md, Ideas tried).
    // shade(), after the closest hit of lane.ray (lane.it where `hit`): emission and the
    // vertex; returns whether the path goes on. queue_vertex(): the lane's draws in Li's
    // order, `mis`'s three light-sample uniforms and a diffuse direction's, and its place in
    // the queue at position k where it takes either step (returns whether it did); it runs
    // in shade()'s loop, lane by lane (PERFORMANCE.md, Ideas tried). next_events(): the queue's
    // light samples a pack at a time (LightSampler::sample_pack), the estimates of its
    // diffuse vertices from them (estimate_diffuse), the others' by next_event(); lists the
    // lanes with a shadow ray. scatter(): the next direction and Russian roulette, for lanes
    // that do not scatter diffusely; scatter_diffuse() for those of the queue, a pack at a
    // time. They set path_done where Li would return; each lane's random draws keep Li's
    // order.
    // (shade: always inline in run()'s loop, its one caller; out of line, a call a lane and
    // bounce cost 4% of the wavefront's instructions on cornell_box.)
    [[gnu::always_inline]] inline bool shade(Lane& lane, bool hit, uint64_t& rays) const;
    bool queue_vertex(Lane& lane, VertexQueue& q, int k) const;
    // (next_events: never inline; inlined into run(), it took the inlining budget that keeps
    // scatter_ggx() there, cornell_box -1.7% and cornell_mesh -1.1% by paired A/B.)
    [[gnu::noinline]] int next_events(VertexQueue& q, int n, Lane** shadowed, const Ray** rays_out, double* t_max,
                    uint64_t& rays) const;
    // queue_vertex()'s draws for the whole queue, a pack of lanes at a time, where the build
    // has 64-bit multiplies of eight lanes (AVX-512DQ): each lane's generator jumped 1-6
    // steps ahead at once (PCG64::jump_multiplier), the same numbers as its next_double()
    // calls. Where it does not, queue_vertex() draws lane by lane.
#if defined(__AVX512DQ__) && RT_PACK == 8
    static constexpr bool kPackedDraws = true;
#else
    static constexpr bool kPackedDraws = false;
#endif
    void draw_queued(VertexQueue& q, int n) const;
    // Integrator::estimate_ld at the diffuse vertices (bits `lanes`) of the queue's pack at
    // `base`, given their light samples: lambertian::eval_z, pdf_z and power_heuristic_over, the
    // scalar code's own bodies, on the pack. Returns the lanes with a shadow ray; `value`
    // holds what each adds to L when unoccluded, t_max where its shadow ray ends.
    static unsigned estimate_diffuse(const VertexQueue& q, int base, const LightSamplePack& ls, unsigned lanes,
                                     VPd (&value)[3], VPd& t_max);
    // Integrator::estimate_ld for a vertex that is not diffuse, from its light sample;
    // returns whether it queued a shadow ray (lane.shadow_*).
    bool next_event(Lane& lane, const LightSample& light, uint64_t& rays) const;
    void scatter(Lane& lane) const;
    // scatter() for lanes[0 .. n), whose vertices sample plain GGX (kSamplesGGX): each
    // lane's draws as sample_material's, then rough_conductor::sample, the frame's to_world
    // and the ray's offset origin a pack of lanes at a time, lane-wise and bit for bit
    // (rough_conductor_pack.h); then each lane's throughput, previous vertex, ray and
    // Russian roulette, as continue_path.
    void scatter_ggx(Lane* const* lanes, int n) const;
    // sample_scatter at the queue's diffuse vertices: the cosine-weighted direction
    // (square_to_cosine_hemisphere; PERFORMANCE.md, Ideas tried), lambertian::sample_with, the
    // frame's to_world and the ray's offset origin lane-wise, bit for bit; then each lane's
    // throughput, previous vertex, ray and Russian roulette. Always inline into run(), its
    // one caller: its size sits at GCC's max-inline-insns-auto, and a few more estimated
    // instructions (the lane helpers of simd.h as templates) left it out of line (cornell_box
    // -1.7%, paired A/B).
    [[gnu::always_inline]] inline void scatter_diffuse(const VertexQueue& q, int n) const;
    // scatter()'s end, given the sampled continuation (none: the path ends). Always inline:
    // with two callers GCC left it out of line (+1.8% instructions on cornell_box); declared
    // inline too, as the attribute wants (else GCC warns it "might not be inlinable").
    [[gnu::always_inline]] inline void continue_path(Lane& lane, const std::optional<Integrator<Mutant::None>::Scatter>& s) const;
    // Adds the finished path's radiance to the pixel's sums, as render_pixel does.
    static void add_sample(Lane& lane, bool tails, uint64_t& nonfinite);
    // Writes the pixel's sums into the image.
    void write_pixel(const Lane& lane, RenderOutput& out) const;

    const Integrator<Mutant::None>& integrator_;
    const Scene& scene_;
    const RenderJob& job_;
    std::vector<uint8_t> material_flags_;  // MaterialFlag bits, by material id
    bool smooth_;  // the scene has smooth triangles (Scene::has_shading_normals)
};

}  // namespace rt
