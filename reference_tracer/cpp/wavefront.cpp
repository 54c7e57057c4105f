// The wavefront integrator (wavefront.h). Every step mirrors Integrator::Li and
// render_pixel statement for statement, calling the same helpers: the order of the random
// draws and of the floating-point operations is theirs, which is what keeps the images
// identical (tests/reference_tracer/test_wavefront.py compares them on every suite scene and strategy).
#include "wavefront.h"

#include <tuple>

#include "integrator_impl.h"
#include "materials/rough_conductor_pack.h"

namespace rt {

WavefrontIntegrator::WavefrontIntegrator(const Integrator<Mutant::None>& integrator, const RenderJob& job)
    : integrator_(integrator), scene_(*job.scene), job_(job), smooth_(job.scene->has_shading_normals()) {
    const bool light_samples = integrator_.strategy_ == Strategy::MIS && !scene_.lights().empty();
    for (uint32_t id = 0; id < scene_.material_count(); ++id) {
        const Material& m = scene_.material(id);
        material_flags_.push_back(static_cast<uint8_t>((m.emits() ? kEmits : 0) |
                                                       (scatters_diffusely(m) ? kScattersDiffusely : 0) |
                                                       (light_samples && !m.is_delta() ? kTakesLightSample : 0) |
                                                       (is_diffuse(m) ? kDiffuse : 0) |
                                                       (samples_ggx(m) ? kSamplesGGX : 0)));
    }
}

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
    // A thin lens's aperture numbers, as render_pixel draws them.
    if (scene_.camera().thin_lens()) {
        lane.lens[0] = lane.rng.next_double();
        lane.lens[1] = lane.rng.next_double();
    }
    lane.L = Vec3(0.0);
    lane.beta = Vec3(1.0);
    lane.eta = 1.0;
    lane.prev = PrevVertex();
    lane.depth = 0;
    lane.path_done = false;
}

void WavefrontIntegrator::camera_rays(Lane* const* lanes, int n) const {
    const Camera& camera = scene_.camera();
    if (!camera.plain()) {  // clip planes, a lens or an orthographic view: a ray at a time
        for (int l = 0; l < n; ++l) {
            Lane& lane = *lanes[l];
            lane.ray = camera.generate(lane.film[0], lane.film[1], lane.lens, lane.reach);
        }
        return;
    }
    for (int base = 0; base < n; base += kPackWidth) {
        const int m = std::min(kPackWidth, n - base);
        VPd film[2];
        gather_members<2>(lanes + base, m, [](const Lane& lane) { return lane.film; }, film);
        VPd d[3];
        camera.direction(film[0], film[1], d[0], d[1], d[2]);
        for (int l = 0; l < m; ++l) lanes[base + l]->ray = Ray{camera.origin, Vec3(d[0][l], d[1][l], d[2][l])};
    }
}

bool WavefrontIntegrator::shade(Lane& lane, bool hit, uint64_t& rays) const {
    const Integrator<Mutant::None>& li = integrator_;
    const Interaction& it = lane.it;
    const SceneSettings& cfg = scene_.settings();
    if (!hit) {
        if (scene_.has_background())
            lane.L += lane.beta * scene_.background(lane.ray.d) * li.background_weight(lane.prev, lane.ray.d);
        lane.path_done = true;
        return false;
    }
    const Material& m = scene_.material(it.material);
    const unsigned flags = material_flags_[it.material];
    const bool front = dot(lane.ray.d, it.ns) < 0.0;
    if (front && (flags & kEmits)) lane.L += lane.beta * m.radiance * li.emitter_weight(lane.prev, lane.ray, it);
    if (lane.depth + 1 >= cfg.max_depth) {
        lane.path_done = true;
        return false;
    }
    if (flags & kScattersDiffusely) {
        // Vertex's constructor less its frame's tangents, which only scatter_diffuse() needs
        // (and builds a pack at a time): the shading normal, wo's local z and whether the
        // path can scatter here (PERFORMANCE.md, Ideas tried).
        lane.normal = front ? it.ns : -it.ns;
        lane.wo_z = dot_fused(-lane.ray.d, lane.normal);
        if (!(m.reflects && (front || m.two_sided) && lane.wo_z != 0.0)) {
            lane.path_done = true;
            return false;
        }
        return true;  // the reference point: next_events() and scatter_diffuse(), a pack at a time
    }
    lane.vertex.emplace(it, m.textured() ? scene_.shade(m, it, *lane.textured) : m, lane.ray.d, front);
    const Vertex& v = *lane.vertex;
    if (!v) {
        lane.path_done = true;
        return false;
    }
    lane.normal = v.frame.n;
    lane.wo_z = v.wo.z;

    Vec3& ref = lane.ref;
    ref = Vec3();
    if (!m.is_delta()) {
        ref = li.reference_point(v);
        if (li.strategy_ == Strategy::Light) {  // the path ends with one query of its own
            if (const std::optional<Vec3> Ld = li.light_only(v, ref, lane.beta, lane.rng, rays)) lane.L += *Ld;
            lane.path_done = true;
            return false;
        }
    }

    return true;
}

bool WavefrontIntegrator::queue_vertex(Lane& lane, VertexQueue& q, int k) const {
    const Material& m = scene_.material(lane.it.material);
    const unsigned flags = material_flags_[lane.it.material];
    // sample_ld's light sample (`mis`, a non-delta vertex), and sample_material's path to
    // lambertian::sample (a diffuse vertex of `cosine` or `mis`).
    const bool light = flags & kTakesLightSample;
    const bool scatter = flags & kScattersDiffusely;
    if (!light && !scatter) return false;
    // Their draws, in Li's order: the light sample's u0, u1, u2, then sample_material's
    // u2, u1, u0 (u0 drawn and not used). Other vertices draw in scatter(), after
    // next_event() has used their throughput.
    // (draw_queued() makes them for the whole queue at once, where it runs.)
    if constexpr (!kPackedDraws) {
        if (light)
            for (int a = 0; a < 3; ++a) q.u[a][k] = lane.rng.next_double();
        if (scatter) {
            q.su[1][k] = lane.rng.next_double();
            q.su[0][k] = lane.rng.next_double();
            lane.rng.next_double();
        }
    }
    q.lanes[k] = &lane;
    q.light[k] = light ? 1.0 : 0.0;
    q.diffuse[k] = (flags & kDiffuse) ? 1.0 : 0.0;
    q.scatter[k] = scatter ? 1.0 : 0.0;
    // A textured material's reflectance at the hit (the diffuse packs read it as the albedo).
    const Vec3 albedo = m.textured() ? scene_.reflectance(m, lane.it) : m.albedo;
    for (int a = 0; a < 3; ++a) {
        q.n[a][k] = lane.normal[a];
        q.albedo[a][k] = albedo[a];
        q.beta[a][k] = lane.beta[a];
        q.p[a][k] = lane.it.p[a];
    }
    q.wo_z[k] = lane.wo_z;
    if (smooth_) {
        // The normal its rays are offset along: the geometric one at a smooth triangle,
        // elsewhere the frame's (what offset_origin takes in Integrator::Li).
        const Interaction& it = lane.it;
        q.smooth[k] = it.smooth ? 1.0 : 0.0;
        for (int a = 0; a < 3; ++a) q.g[a][k] = it.smooth ? it.n[a] : lane.normal[a];
    }
    return true;
}

void WavefrontIntegrator::draw_queued(VertexQueue& q, int n) const {
    using VPu = uint64_t __attribute__((vector_size(8 * kPackWidth)));
    for (int base = 0; base < n; base += kPackWidth) {
        const int m = std::min(kPackWidth, n - base);
        VPu s0 = {}, inc = {};
        for (int l = 0; l < m; ++l) {
            const PCG64& rng = q.lanes[base + l]->rng;
            s0[l] = rng.state();
            inc[l] = rng.increment();
        }
        // The states after 0..6 steps, each straight from s0 (no chain of dependent
        // multiplies), and the draws of the first six.
        VPu s[7];
        VPd u[6];
        for (int j = 0; j <= 6; ++j) s[j] = s0 * PCG64::jump_multiplier(j) + inc * PCG64::jump_increment(j);
        for (int j = 0; j < 6; ++j) u[j] = PCG64::to_double<VPd>(PCG64::output(s[j]));
        // A lane draws the light sample's three first where it takes one, then the diffuse
        // direction's three (u2, u1, and u0 unused) where it scatters diffusely.
        const VPl light = load_pack(q.light + base) != 0.0, scatter = load_pack(q.scatter + base) != 0.0;
        for (int a = 0; a < 3; ++a) store_pack(q.u[a] + base, u[a]);
        store_pack(q.su[1] + base, light ? u[3] : u[0]);
        store_pack(q.su[0] + base, light ? u[4] : u[1]);
        const VPu state = (light & scatter) ? s[6] : s[3];
        for (int l = 0; l < m; ++l) q.lanes[base + l]->rng.set_state(state[l]);
    }
}

int WavefrontIntegrator::next_events(VertexQueue& q, int n, Lane** shadowed, const Ray** rays_out, double* t_max,
                                     uint64_t& rays) const {
    // kOverlapPacks packs' light samples and estimates, then their lanes' shadow rays (simd.h).
    struct Estimated {
        LightSamplePack ls;
        VPd ref[3], value[3], t_far;
        unsigned light, diffuse, shadow;
    };
    constexpr int kGroup = kOverlapPacks;
    int n_shadow = 0;
    for (int group = 0; group < n; group += kGroup * kPackWidth) {
        Estimated packs[kGroup];
        const int end = std::min(n, group + kGroup * kPackWidth);
        for (int base = group, k = 0; base < end; base += kPackWidth, ++k) {
            Estimated& e = packs[k];
            const unsigned present = (1u << std::min(kPackWidth, n - base)) - 1u;
            e.light = lane_mask(load_pack(q.light + base) != 0.0) & present;
            if (e.light == 0) continue;
            VPd p[3], nv[3], u[3];
            for (int a = 0; a < 3; ++a) {
                p[a] = load_pack(q.p[a] + base);
                nv[a] = load_pack(q.n[a] + base);
                u[a] = load_pack(q.u[a] + base);
            }
            if (smooth_) {
                VPd g[3];
                for (int a = 0; a < 3; ++a) g[a] = load_pack(q.g[a] + base);
                offset_toward(p, g, nv, offset_epsilon(p), e.ref);  // Integrator::reference_point
            } else {
                offset_toward(p, nv, nv, offset_epsilon(p), e.ref);
            }
            scene_.lights().sample_pack(e.ref, u, e.light, e.ls);
            e.diffuse = lane_mask(load_pack(q.diffuse + base) != 0.0) & e.light;
            e.shadow = e.diffuse != 0 ? estimate_diffuse(q, base, e.ls, e.diffuse, e.value, e.t_far) : 0u;
        }
        for (int base = group, k = 0; base < end; base += kPackWidth, ++k) {
            const Estimated& e = packs[k];
            if (e.light == 0) continue;
            // The diffuse vertices with a shadow ray, then the other vertices lane by lane: a
            // loop over each set's bits, not a test of each lane's verdict, which the CPU
            // cannot predict. (The order of the batch's shadow rays changes no result.)
            rays += uint64_t(__builtin_popcount(e.shadow));
            for (unsigned left = e.shadow; left != 0; left &= left - 1) {
                const int l = __builtin_ctz(left);
                Lane& lane = *q.lanes[base + l];
                // What estimate_ld does after its checks: count the shadow ray (above) and queue it.
                const Vec3 wi(e.ls.wi[0][l], e.ls.wi[1][l], e.ls.wi[2][l]);
                lane.shadow_ray = Ray{Vec3(e.ref[0][l], e.ref[1][l], e.ref[2][l]), wi};
                if (smooth_ && q.smooth[base + l] != 0.0)  // Integrator::shadow_origin
                    lane.shadow_ray.o = offset_origin(lane.it.p, lane.it.n, wi);
                lane.shadow_t_max = e.t_far[l];
                lane.shadow_value = Vec3(e.value[0][l], e.value[1][l], e.value[2][l]);
                shadowed[n_shadow] = &lane;
                rays_out[n_shadow] = &lane.shadow_ray;
                t_max[n_shadow++] = lane.shadow_t_max;
            }
            for (unsigned left = e.light & ~e.diffuse; left != 0; left &= left - 1) {
                const int l = __builtin_ctz(left);
                Lane& lane = *q.lanes[base + l];
                if (!next_event(lane, e.ls.lane(l), rays)) continue;
                shadowed[n_shadow] = &lane;
                rays_out[n_shadow] = &lane.shadow_ray;
                t_max[n_shadow++] = lane.shadow_t_max;
            }
        }
    }
    return n_shadow;
}

unsigned WavefrontIntegrator::estimate_diffuse(const VertexQueue& q, int base, const LightSamplePack& ls,
                                               unsigned lanes, VPd (&value)[3], VPd& t_max) {
    VPd n[3], albedo[3], beta[3];
    for (int a = 0; a < 3; ++a) {
        n[a] = load_pack(q.n[a] + base);
        albedo[a] = load_pack(q.albedo[a] + base);
        beta[a] = load_pack(q.beta[a] + base);
    }
    const VPd wo_z = load_pack(q.wo_z + base);
    // The sample's local z, frame.to_local(wi).z (dot_fused): all that Lambertian
    // evaluation and density read of it.
    const VPd cos_i = mul_add(ls.wi[2], n[2], mul_add(ls.wi[1], n[1], ls.wi[0] * n[0]));
    VPd f[3];
    lambertian::eval_z(albedo, wo_z, cos_i, f);
    // No shadow ray for an invalid sample, or a direction the BSDF ignores (is_black(f)).
    const unsigned shadow = lanes & ls.valid & ~lane_mask((f[0] == 0.0) & (f[1] == 0.0) & (f[2] == 0.0));
    // The segment ends just short of the sampled point (kShadowEpsilon), at infinity for
    // the background.
    t_max = lanes_of_bits(ls.background) ? splat(kInf) : ls.dist * (1.0 - kShadowEpsilon);
    VPd scale = power_heuristic_over(ls.pdf, lambertian::pdf_z(wo_z, cos_i));
    if (ls.delta != 0) scale = lanes_of_bits(ls.delta) ? 1.0 / ls.pdf : scale;  // a delta light's: weight 1
    // beta * f * radiance * (weight / pdf), in estimate_ld's order.
    for (int c = 0; c < 3; ++c) value[c] = ((beta[c] * f[c]) * ls.radiance[c]) * scale;
    return shadow;
}

bool WavefrontIntegrator::next_event(Lane& lane, const LightSample& light, uint64_t& rays) const {
    // The shadow ray joins the batch's; its value is added after the batch, before
    // anything else touches L, so the sum keeps Li's order. estimate_ld returns a value
    // exactly where it queued the ray (it reports it unoccluded).
    const auto queue = [&lane](const Ray& r, double t_max) {
        lane.shadow_ray = r;
        lane.shadow_t_max = t_max;
        return false;
    };
    const std::optional<Vec3> Ld = integrator_.estimate_ld(*lane.vertex, lane.beta, light, rays, lane.ref, queue);
    if (Ld) lane.shadow_value = *Ld;
    return Ld.has_value();
}

void WavefrontIntegrator::scatter(Lane& lane) const {
    continue_path(lane, integrator_.sample_scatter(*lane.vertex, lane.ref, lane.rng));
}

void WavefrontIntegrator::scatter_ggx(Lane* const* lanes, int n) const {
    for (int base = 0; base < n; base += kPackWidth) {
        const int m = std::min(kPackWidth, n - base);
        Lane* const* pack = lanes + base;
        // The frame (s, t, n) and wo: twelve consecutive doubles of the vertex.
        static_assert(offsetof(Frame, t) == 3 * sizeof(double) && offsetof(Frame, n) == 6 * sizeof(double) &&
                          offsetof(Vertex, wo) == offsetof(Vertex, frame) + sizeof(Frame),
                      "scatter_ggx gathers a vertex's frame and wo as twelve consecutive doubles");
        VPd fv[12], p[3];
        gather_members<12>(pack, m, [](const Lane& lane) { return &lane.vertex->frame.s.x; }, fv);
        gather_members<3>(pack, m, [](const Lane& lane) { return &lane.it.p.x; }, p);
        alignas(64) double u1[kPackWidth], u2[kPackWidth], alpha[kPackWidth], albedo[3][kPackWidth],
            g[3][kPackWidth];
        for (int l = 0; l < kPackWidth; ++l) {
            Lane& lane = *pack[l < m ? l : 0];
            if (l < m) {
                // sample_material's draws, last first; u0 drawn and not used.
                u2[l] = lane.rng.next_double();
                u1[l] = lane.rng.next_double();
                lane.rng.next_double();
            } else {
                u1[l] = u2[l] = 0.5;
            }
            const Vertex& v = *lane.vertex;
            alpha[l] = v.m.param;
            // The normal the continuation leaves along (Integrator::continuation_origin).
            const Vec3& offset_n = v.it.smooth ? v.it.n : v.frame.n;
            for (int a = 0; a < 3; ++a) {
                albedo[a][l] = v.m.albedo[a];
                g[a][l] = offset_n[a];
            }
        }
        const VPd wo[3] = {fv[9], fv[10], fv[11]};
        VPd alb[3], gn[3];
        for (int a = 0; a < 3; ++a) {
            alb[a] = load_pack(albedo[a]);
            gn[a] = load_pack(g[a]);
        }
        VPd local[3], weight[3], pdf;
        const unsigned valid = rough_conductor::sample_pack(alb, load_pack(alpha), wo, load_pack(u1),
                                                            load_pack(u2), local, weight, pdf) &
                               ((1u << m) - 1u);
        // scatter_of: Frame::to_world(wi); then continuation_origin's offset_origin.
        VPd wi[3], origin[3];
        for (int a = 0; a < 3; ++a) wi[a] = mul_add(fv[6 + a], local[2], mul_add(fv[3 + a], local[1], fv[a] * local[0]));
        offset_toward(p, gn, wi, offset_epsilon(p), origin);
        // continue_path, lane by lane. The sample's eta is 1 (eta *= 1 changes nothing).
        for (int l = 0; l < m; ++l) {
            Lane& lane = *pack[l];
            if (!((valid >> l) & 1u)) {
                lane.path_done = true;
                continue;
            }
            lane.beta *= Vec3(weight[0][l], weight[1][l], weight[2][l]);
            lane.prev = PrevVertex{false, pdf[l], lane.ref};
            lane.ray = Ray{Vec3(origin[0][l], origin[1][l], origin[2][l]), Vec3(wi[0][l], wi[1][l], wi[2][l])};
            const bool goes_on = integrator_.survives(lane.depth + 1, lane.eta, lane.beta, lane.rng);
            lane.path_done = !goes_on;
            lane.depth += goes_on;
        }
    }
}

void WavefrontIntegrator::scatter_diffuse(const VertexQueue& q, int n) const {
    for (int base = 0; base < n; base += kPackWidth) {
        const unsigned present = (1u << std::min(kPackWidth, n - base)) - 1u;
        const unsigned lanes = lane_mask(load_pack(q.scatter + base) != 0.0) & present;
        if (lanes == 0) continue;
        VPd w[3];
        square_to_cosine_hemisphere(load_pack(q.su[0] + base), load_pack(q.su[1] + base), w[0], w[1], w[2]);
        // lambertian::sample_with: no sample seen from below the surface, nor of density 0
        // (the density cosine_hemisphere_pdf(w.z)); its weight is the albedo.
        const VPd pdf = cosine_hemisphere_pdf(w[2]);
        const unsigned valid = lanes & ~lane_mask(load_pack(q.wo_z + base) <= 0.0) & lane_mask(pdf > 0.0);
        // scatter_of: the direction in world space, Frame(n).to_world(w), with the frame
        // built as Frame's constructor builds it (math.h).
        VPd nv[3], p[3], beta[3];
        for (int a = 0; a < 3; ++a) {
            nv[a] = load_pack(q.n[a] + base);
            p[a] = load_pack(q.p[a] + base);
            beta[a] = load_pack(q.beta[a] + base) * load_pack(q.albedo[a] + base);  // beta *= weight
        }
        VPd fs[3], ft[3];
        frame_tangents(nv, fs, ft);
        VPd wi[3];
        for (int a = 0; a < 3; ++a) wi[a] = mul_add(nv[a], w[2], mul_add(ft[a], w[1], fs[a] * w[0]));
        // offset_origin(p, n, wi) (math.h), and the reference point offset_origin(p, n, n);
        // along the geometric normal g at smooth triangles (Integrator::continuation_origin,
        // reference_point).
        const VPd eps = offset_epsilon(p);
        VPd origin[3], ref[3];
        if (smooth_) {
            VPd g[3];
            for (int a = 0; a < 3; ++a) g[a] = load_pack(q.g[a] + base);
            offset_toward(p, g, wi, eps, origin);
            offset_toward(p, g, nv, eps, ref);
        } else {
            offset_toward(p, nv, wi, eps, origin);
            offset_toward(p, nv, nv, eps, ref);
        }
        // continue_path, lane by lane. The sample's eta is 1 (eta *= 1 changes nothing).
        for (unsigned left = lanes; left != 0; left &= left - 1) {
            const int l = __builtin_ctz(left);
            Lane& lane = *q.lanes[base + l];
            if (!((valid >> l) & 1u)) {
                lane.path_done = true;
                continue;
            }
            lane.beta = Vec3(beta[0][l], beta[1][l], beta[2][l]);
            lane.prev = PrevVertex{false, pdf[l], Vec3(ref[0][l], ref[1][l], ref[2][l])};
            lane.ray = Ray{Vec3(origin[0][l], origin[1][l], origin[2][l]), Vec3(wi[0][l], wi[1][l], wi[2][l])};
            // The verdict stored: the path's end is handled after the bounce, for the ended
            // lanes only.
            const bool goes_on = integrator_.survives(lane.depth + 1, lane.eta, lane.beta, lane.rng);
            lane.path_done = !goes_on;
            lane.depth += goes_on;
        }
    }
}

void WavefrontIntegrator::continue_path(Lane& lane, const std::optional<Integrator<Mutant::None>::Scatter>& s) const {
    const Integrator<Mutant::None>& li = integrator_;
    const Vertex& v = *lane.vertex;
    const Vec3& ref = lane.ref;
    if (!s) {
        lane.path_done = true;
        return;
    }
    lane.beta *= s->weight;
    lane.eta *= s->eta;
    // As Li: the sample's own delta flag (smooth plastic's specular bounce is a mirror's).
    lane.prev = PrevVertex{s->delta, s->pdf, ref};
    lane.ray = Ray{li.continuation_origin(v, s->wi, s->delta), s->wi};
    const bool goes_on = li.survives(lane.depth + 1, lane.eta, lane.beta, lane.rng);
    lane.path_done = !goes_on;
    lane.depth += goes_on;
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
    std::vector<std::optional<Material>> textured(scene_.has_textures() ? kLanes : 0);
    for (size_t i = 0; i < textured.size(); ++i) lanes[i].textured = &textured[i];
    // The batch's queries, compacted: the busy lanes, those with a shadow ray, and those
    // whose path ended.
    Lane* active[kLanes];
    Lane* shadowed[kLanes];
    Lane* ended[kLanes];
    // The vertices that run in packs (light samples, diffuse scattering), the lanes that
    // start a sample (their camera rays run in packs too), and those that scatter otherwise.
    VertexQueue queue{};
    Lane* grouped[kLanes];
    Lane* others[kLanes];
    Lane* ggx[kLanes];  // those that scatter by plain GGX (scatter_ggx)
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
        // A camera ray's hit at or beyond its reach is a miss, as in Integrator::Li.
        if (!scene_.camera().plain())
            for (int k = 0; k < n; ++k)
                if (active[k]->depth == 0 && !(active[k]->it.t < active[k]->reach)) hit[k] = false;
        int n_queued = 0, n_others = 0, n_ggx = 0;
        for (int k = 0; k < n; ++k) {
            Lane& lane = *active[k];
            if (!shade(lane, hit[k], rays)) continue;
            // One loop: as passes of their own, the draws cost 2% of cornell_box's
            // instructions (PERFORMANCE.md, Ideas tried).
            const bool queued = queue_vertex(lane, queue, n_queued);
            if (!(queued && queue.scatter[n_queued] != 0.0)) {
                if (material_flags_[lane.it.material] & kSamplesGGX)
                    ggx[n_ggx++] = &lane;
                else
                    others[n_others++] = &lane;
            }
            n_queued += queued;
        }
        if constexpr (kPackedDraws) draw_queued(queue, n_queued);
        const int n_shadow = next_events(queue, n_queued, shadowed, batch, t_max, rays);
        for (int k = 0; k < n_others; ++k) scatter(*others[k]);
        scatter_ggx(ggx, n_ggx);
        scatter_diffuse(queue, n_queued);
        if (n_shadow > 0) {
            scene_.occluded_batch(size_t(n_shadow), batch, t_max, hit);
            for (int k = 0; k < n_shadow; ++k) {
                Lane& lane = *shadowed[k];
                // A selection, not a branch (the verdicts are unpredictable); L + 0 would
                // turn a -0 into +0, so the sum is selected, not the term.
                lane.L = select_bits(hit[k], lane.L, lane.L + lane.shadow_value);
            }
        }

        // Paths that ended hand their lane to the pixel's next sample, or to a new pixel.
        // The ended paths listed first, without a branch a lane: whether a path ended is
        // the CPU's to guess, and a wrong guess a lane cost more than the list.
        int n_ended = 0;
        for (int k = 0; k < n; ++k) {
            ended[n_ended] = active[k];
            n_ended += active[k]->path_done;
        }
        n_start = 0;
        for (int k = 0; k < n_ended; ++k) {
            Lane& lane = *ended[k];
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
