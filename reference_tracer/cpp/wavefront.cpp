// The wavefront integrator (wavefront.h). Every step mirrors Integrator::Li and
// render_pixel statement for statement, calling the same helpers: the order of the random
// draws and of the floating-point operations is theirs, which is what keeps the images
// identical (tests/test_wavefront.py compares them on every suite scene and strategy).
#include "wavefront.h"

#include <tuple>

#include "integrator_impl.h"

namespace rt {

bool WavefrontIntegrator::start_pixel(Lane& lane, TileCursor& pixels) const {
    int x, y;
    lane.busy = pixels.next(x, y);
    if (!lane.busy) return false;
    lane.x = x;
    lane.y = y;
    lane.rng = pixel_rng(job_.seed, uint64_t(y) * uint64_t(scene_.camera().width) + uint64_t(x));
    lane.samples_left = job_.spp;
    for (int c = 0; c < 3; ++c) lane.s[c] = lane.s2[c] = 0.0;
    lane.tails = detail::TailSums();
    return true;
}

void WavefrontIntegrator::start_sample(Lane& lane) const {
    --lane.samples_left;
    // Box filter, as render_pixel: a sample jittered in the pixel.
    lane.film[0] = lane.x + lane.rng.next_double();
    lane.film[1] = lane.y + lane.rng.next_double();
    lane.L = Vec3(0.0);
    lane.beta = Vec3(1.0);
    lane.eta = 1.0;
    lane.prev = PrevVertex();
    lane.depth = 0;
    lane.path_done = false;
    lane.shadow = false;
}

void WavefrontIntegrator::camera_rays(Lane* const* lanes, int n) const {
    const Camera& camera = scene_.camera();
    for (int base = 0; base < n; base += kPackWidth) {
        const int m = std::min(kPackWidth, n - base);
        VPd px, py;
        pack_pairs(lanes + base, m, [](const Lane& lane) { return lane.film; }, px, py);
        VPd d[3];
        camera.direction(px, py, d[0], d[1], d[2]);
        for (int l = 0; l < m; ++l) lanes[base + l]->ray = Ray{camera.origin, Vec3(d[0][l], d[1][l], d[2][l])};
    }
}

bool WavefrontIntegrator::shade(Lane& lane, bool hit, uint64_t& rays) const {
    const Integrator<Mutant::None>& li = integrator_;
    const Interaction& it = lane.it;
    const SceneSettings& cfg = scene_.settings();
    if (!hit) {
        if (max_component(cfg.background) > 0.0)
            lane.L += lane.beta * cfg.background * li.background_weight(lane.prev);
        lane.path_done = true;
        return false;
    }
    const Material& m = scene_.material(it.material);
    const bool front = dot(lane.ray.d, it.n) < 0.0;
    if (front && m.emits()) lane.L += lane.beta * m.radiance * li.emitter_weight(lane.prev, lane.ray, it);
    if (lane.depth + 1 >= cfg.max_depth) {
        lane.path_done = true;
        return false;
    }
    lane.vertex.emplace(it, m, lane.ray.d, front);
    const Vertex& v = *lane.vertex;
    if (!v) {
        lane.path_done = true;
        return false;
    }

    Vec3& ref = lane.ref;
    ref = Vec3();
    if (!m.is_delta()) {
        ref = offset_origin(it.p, v.frame.n, v.frame.n);
        if (li.strategy_ == Strategy::Light) {  // the path ends with one query of its own
            if (const std::optional<Vec3> Ld = li.light_only(v, ref, lane.beta, lane.rng, rays)) lane.L += *Ld;
            lane.path_done = true;
            return false;
        }
    }

    return true;
}

bool WavefrontIntegrator::draw_light_uniforms(Lane& lane) const {
    const Integrator<Mutant::None>& li = integrator_;
    // sample_ld's first step: its three uniforms, where it would draw them.
    if (li.strategy_ != Strategy::MIS || lane.vertex->m.is_delta() || scene_.lights().empty()) return false;
    for (double& u : lane.light_u) u = lane.rng.next_double();
    return true;
}

void WavefrontIntegrator::sample_lights(Lane* const* lanes, int n) const {
    const LightSampler& lights = scene_.lights();
    if (!lights.packed_sampling()) {
        for (int k = 0; k < n; ++k)
            lanes[k]->light = lights.sample(lanes[k]->ref, lanes[k]->light_u[0], lanes[k]->light_u[1],
                                            lanes[k]->light_u[2]);
        return;
    }
    lights.sample_packed(n, [lanes](int k) {
        Lane& lane = *lanes[k];
        return std::tuple<const Vec3&, const double*, LightSample*>(lane.ref, lane.light_u, &lane.light);
    });
}

void WavefrontIntegrator::next_event(Lane& lane, uint64_t& rays) const {
    // The shadow ray joins the batch's; its value is added after the batch, before
    // anything else touches L, so the sum keeps Li's order.
    const auto queue = [&lane](const Ray& r, double t_max) {
        lane.shadow = true;
        lane.shadow_ray = r;
        lane.shadow_t_max = t_max;
        return false;
    };
    if (const std::optional<Vec3> Ld = integrator_.estimate_ld(*lane.vertex, lane.beta, lane.light, rays, lane.ref, queue))
        lane.shadow_value = *Ld;
}

void WavefrontIntegrator::scatter(Lane& lane) const {
    continue_path(lane, integrator_.sample_scatter(*lane.vertex, lane.ref, lane.rng));
}

bool WavefrontIntegrator::draw_diffuse_uniforms(Lane& lane) const {
    // sample_scatter's path to lambertian::sample (sample_material at a diffuse vertex),
    // with sample_material's draws in its order (u0 is drawn and not used).
    const Strategy strategy = integrator_.strategy_;
    const MaterialType type = lane.vertex->m.type;
    if (!(strategy == Strategy::Cosine || strategy == Strategy::MIS) ||
        !(type == MaterialType::Lambertian || type == MaterialType::DiffuseLight))
        return false;
    lane.scatter_u[1] = lane.rng.next_double();  // u2
    lane.scatter_u[0] = lane.rng.next_double();  // u1
    lane.rng.next_double();                      // u0
    return true;
}

void WavefrontIntegrator::scatter_diffuse(Lane* const* lanes, int n) const {
    for (int base = 0; base < n; base += kPackWidth) {
        const int m = std::min(kPackWidth, n - base);
        VPd u1, u2;
        pack_pairs(lanes + base, m, [](const Lane& lane) { return lane.scatter_u; }, u1, u2);
        VPd w[3];
        square_to_cosine_hemisphere(u1, u2, w[0], w[1], w[2]);
        for (int l = 0; l < m; ++l) {
            // The rest of lambertian::sample and sample_material, lane by lane.
            Lane& lane = *lanes[base + l];
            const Vertex& v = *lane.vertex;
            const BSDFSample bs = lambertian::sample_with(v.m.albedo, v.wo, Vec3(w[0][l], w[1][l], w[2][l]));
            continue_path(lane, Integrator<Mutant::None>::scatter_of(v, bs));
        }
    }
}

void WavefrontIntegrator::continue_path(Lane& lane, const std::optional<Integrator<Mutant::None>::Scatter>& s) const {
    const Integrator<Mutant::None>& li = integrator_;
    const Vertex& v = *lane.vertex;
    const Material& m = v.m;
    const Interaction& it = lane.it;
    const Vec3& ref = lane.ref;
    if (!s) {
        lane.path_done = true;
        return;
    }
    lane.beta *= s->weight;
    lane.eta *= s->eta;
    lane.prev = PrevVertex{m.is_delta(), s->pdf, ref};
    lane.ray = Ray{offset_origin(it.p, m.is_delta() ? it.n : v.frame.n, s->wi), s->wi};
    if (!li.survives(lane.depth + 1, lane.eta, lane.beta, lane.rng)) {
        lane.path_done = true;
        return;
    }
    ++lane.depth;
}

void WavefrontIntegrator::add_sample(Lane& lane, bool tails, uint64_t& nonfinite) {
    const Vec3& L = lane.L;
    if (!is_finite(L)) {  // counted and reported, as render_pixel does
        ++nonfinite;
        return;
    }
    for (int c = 0; c < 3; ++c) {
        lane.s[c] += L[c];
        lane.s2[c] += L[c] * L[c];
    }
    if (tails) lane.tails.add(L);
}

void WavefrontIntegrator::write_pixel(const Lane& lane, RenderOutput& out) const {
    const PixelSums px = pixel_sums(out, job_.moments, scene_.camera().width, lane.x, lane.y);
    for (int c = 0; c < 3; ++c) {
        px.sum[c] = lane.s[c];
        px.sum_sq[c] = lane.s2[c];
    }
    if (job_.moments) lane.tails.write(px);
}

void WavefrontIntegrator::run(TileCursor& pixels, RenderOutput& out, const std::atomic<bool>& cancel,
                              std::atomic<uint64_t>& pixels_done, uint64_t& rays, uint64_t& nonfinite) const {
    std::vector<Lane> lanes(kLanes);
    // The batch's queries, compacted: the busy lanes, and those with a shadow ray.
    Lane* active[kLanes];
    Lane* shadowed[kLanes];
    // The lanes of the pack passes (light samples, diffuse directions, camera rays), and those
    // that scatter otherwise.
    Lane* grouped[kLanes];
    Lane* diffuse[kLanes];
    Lane* others[kLanes];
    int n_start = 0;
    for (Lane& lane : lanes)
        if (start_pixel(lane, pixels)) {
            start_sample(lane);
            grouped[n_start++] = &lane;
        }
    camera_rays(grouped, n_start);

    // The queries' rays and hits stay in the lanes; the batch holds pointers to them.
    const Ray* batch[kLanes];
    Interaction* hits[kLanes];
    bool hit[kLanes];
    double t_max[kLanes];

    for (;;) {
        // A cancelled render's image is discarded: stop at the next bounce.
        if (cancel.load(std::memory_order_relaxed)) return;
        int n = 0;
        for (Lane& lane : lanes)
            if (lane.busy) {
                active[n] = &lane;
                batch[n] = &lane.ray;
                hits[n++] = &lane.it;
            }
        if (n == 0) return;

        rays += uint64_t(n);
        scene_.intersect_batch(size_t(n), batch, hit, hits);
        int n_shadow = 0;
        int n_light = 0, n_diffuse = 0, n_others = 0;
        for (int k = 0; k < n; ++k) {
            Lane& lane = *active[k];
            if (!shade(lane, hit[k], rays)) continue;
            // The lane's draws in Li's order: the light sample's uniforms, then a diffuse
            // direction's (one loop: as passes of their own they cost 2% of cornell_box's
            // instructions, PERFORMANCE.md round 16). Other lanes draw in scatter(), after
            // next_event() has used their throughput.
            if (draw_light_uniforms(lane)) grouped[n_light++] = &lane;
            if (draw_diffuse_uniforms(lane))
                diffuse[n_diffuse++] = &lane;
            else
                others[n_others++] = &lane;
        }
        sample_lights(grouped, n_light);
        for (int k = 0; k < n_light; ++k) {
            Lane& lane = *grouped[k];
            next_event(lane, rays);
            if (lane.shadow) {  // only next_event() queues shadow rays
                shadowed[n_shadow] = &lane;
                batch[n_shadow] = &lane.shadow_ray;
                t_max[n_shadow++] = lane.shadow_t_max;
            }
        }
        for (int k = 0; k < n_others; ++k) scatter(*others[k]);
        scatter_diffuse(diffuse, n_diffuse);
        if (n_shadow > 0) {
            scene_.occluded_batch(size_t(n_shadow), batch, t_max, hit);
            for (int k = 0; k < n_shadow; ++k) {
                Lane& lane = *shadowed[k];
                if (!hit[k]) lane.L += lane.shadow_value;
                lane.shadow = false;
            }
        }

        // Paths that ended hand their lane to the pixel's next sample, or to a new pixel.
        n_start = 0;
        for (int k = 0; k < n; ++k) {
            Lane& lane = *active[k];
            if (!lane.path_done) continue;
            add_sample(lane, job_.moments, nonfinite);
            if (lane.samples_left == 0) {
                write_pixel(lane, out);
                pixels_done.fetch_add(1, std::memory_order_relaxed);
                if (!start_pixel(lane, pixels)) continue;
            }
            start_sample(lane);
            grouped[n_start++] = &lane;
        }
        camera_rays(grouped, n_start);
    }
}

void render_wavefront(const Integrator<Mutant::None>& integrator, const RenderJob& job, TileCursor& pixels,
                      RenderOutput& out, const std::atomic<bool>& cancel, std::atomic<uint64_t>& pixels_done,
                      uint64_t& rays, uint64_t& nonfinite) {
    WavefrontIntegrator(integrator, job).run(pixels, out, cancel, pixels_done, rays, nonfinite);
}

}  // namespace rt
