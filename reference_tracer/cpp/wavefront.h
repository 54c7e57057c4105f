// The wavefront integrator: the path integrator of integrator.h run on a batch of paths
// at once, so that each bounce's intersection queries (closest hits, then shadow rays)
// go to the scene as one batch, which it answers several rays per instruction
// (Scene::intersect_batch / occluded_batch).
//
// Each lane of the batch owns one pixel and runs that pixel's samples one after the
// other, drawing from the pixel's own random stream in the same order as render_pixel
// and Integrator::Li do; a lane whose path ends starts the pixel's next sample (or a new
// pixel) before the next bounce, so lanes never idle while work is left (the "busy
// lanes" loss of a packet that runs until its longest path ends, PERFORMANCE.md round 5).
// Every sample is therefore the very number the scalar integrator computes, summed in
// the same order: the two integrators' images are the same bit for bit.
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
    // and hits stay in L1. 16 and 64 measured slower than 32 (PERFORMANCE.md round 8).
    static constexpr int kLanes = 32;

    WavefrontIntegrator(const Integrator<Mutant::None>& integrator, const RenderJob& job)
        : integrator_(integrator), scene_(*job.scene), job_(job) {}

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
        Ray ray;               // the path's next segment
        Vec3 L, beta;
        double eta = 1.0;
        PrevVertex prev;
        int depth = 0;
        bool path_done = false;

        // The closest hit of `ray` (written there by the batch's query), and what
        // next_event() and scatter() need of shade(): the vertex and its light-sampling
        // reference point.
        Interaction it;
        std::optional<Vertex> vertex;
        Vec3 ref;

        double light_u[3] = {0, 0, 0};  // `mis`'s light sample: its uniforms, then
        LightSample light;               // the sample
        double scatter_u[2] = {0, 0};    // a diffuse vertex's uniforms u1, u2 for its next direction
        bool shadow = false;   // a shadow ray to trace before the next bounce
        Ray shadow_ray;
        double shadow_t_max = 0.0;
        Vec3 shadow_value;     // what it adds to L when unoccluded
    };

    // Takes the next pixel for `lane`; false (the lane idle) when none is left.
    bool start_pixel(Lane& lane, TileCursor& pixels) const;
    // Starts the pixel's next sample: its film point, as render_pixel draws it, and the
    // path's state; camera_rays() then gives a pack of such lanes their camera rays at once.
    void start_sample(Lane& lane) const;
    void camera_rays(Lane* const* lanes, int n) const;
    // One vertex of Integrator::Li's loop in parts, each run over the whole batch before
    // the next, so that the independent lanes overlap each part's long chains of dependent
    // arithmetic instead of waiting on them one lane after another (PERFORMANCE.md round 8:
    // cornell_box +8%, cornell_mesh +11%, furnace +5%).
    // shade(), after the closest hit of lane.ray (lane.it where `hit`): emission and the
    // vertex; returns whether the path goes on. draw_light_uniforms(): `mis`'s three
    // uniforms for the light sample (returns whether the vertex takes one); it and
    // draw_diffuse_uniforms() run in shade()'s loop, lane by lane (PERFORMANCE.md round 16).
    // sample_lights(): the light samples of those lanes, a pack of lanes at a time where the
    // lights allow it (PERFORMANCE.md rounds 9 and 13). next_event(): the rest of next-event
    // estimation up to its shadow ray (queued in the lane). scatter(): the next direction
    // and Russian roulette. They set path_done where Li would return; each lane's random
    // draws keep Li's order.
    bool shade(Lane& lane, bool hit, uint64_t& rays) const;
    bool draw_light_uniforms(Lane& lane) const;
    void sample_lights(Lane* const* lanes, int n) const;
    void next_event(Lane& lane, uint64_t& rays) const;
    void scatter(Lane& lane) const;
    // scatter() for diffuse vertices of `cosine` and `mis`, in two parts: the uniforms
    // (returns whether the vertex is one), then the cosine-weighted directions of a pack
    // of lanes at once (PERFORMANCE.md round 9).
    bool draw_diffuse_uniforms(Lane& lane) const;
    void scatter_diffuse(Lane* const* lanes, int n) const;
    // scatter()'s end, given the sampled continuation (none: the path ends). Always inline:
    // with two callers GCC left it out of line (+1.8% instructions on cornell_box); declared
    // inline too, as the attribute wants (else GCC warns it "might not be inlinable").
    [[gnu::always_inline]] inline void continue_path(Lane& lane, const std::optional<Integrator<Mutant::None>::Scatter>& s) const;
    // The pair of doubles that get(lane) points to, for lanes[0..m) of a pack pass: a lane
    // of the pack per lane of the batch (absent lanes, l >= m, repeat the first).
    template <typename Get>
    static void pack_pairs(Lane* const* lanes, int m, Get&& get, VPd& a, VPd& b) {
        for (int l = 0; l < kPackWidth; ++l) {
            const double* v = get(*lanes[l < m ? l : 0]);
            a[l] = v[0];
            b[l] = v[1];
        }
    }
    // Adds the finished path's radiance to the pixel's sums, as render_pixel does.
    static void add_sample(Lane& lane, bool tails, uint64_t& nonfinite);
    // Writes the pixel's sums into the image.
    void write_pixel(const Lane& lane, RenderOutput& out) const;

    const Integrator<Mutant::None>& integrator_;
    const Scene& scene_;
    const RenderJob& job_;
};

}  // namespace rt
