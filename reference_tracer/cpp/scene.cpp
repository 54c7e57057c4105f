#include "scene.h"

#include <cstddef>
#include <memory>
#include <stdexcept>

namespace rt {

namespace {

Vec3 project_to_plane(const Vec3& p, const Vec3& point_on_plane, const Vec3& unit_normal) {
    return p - unit_normal * dot(p - point_on_plane, unit_normal);
}

// b grown far beyond the rounding of a pack's slab test (PackSlabs) and of the primitives'
// bounds, so that a ray that can meet a primitive inside b is never judged to miss b.
AABB padded(AABB b) {
    const Vec3 pad = Vec3(1e-7 * max_abs_component(b.extent()) + 1e-300) + 1e-12 * vmax(b.lo * -1.0, b.hi);
    b.lo = b.lo - pad;
    b.hi = b.hi + pad;
    return b;
}

}  // namespace

Scene::Scene(Camera camera, std::vector<Material> materials, std::vector<Sphere> spheres,
             std::vector<Quad> quads, std::vector<Triangle> triangles, SceneSettings settings,
             std::vector<TriangleNormals> normals, std::vector<DeltaLight> deltas,
             std::unique_ptr<EnvironmentMap> environment, SceneTextures textures)
    : camera_(camera), materials_(std::move(materials)), spheres_(std::move(spheres)),
      quads_(std::move(quads)), triangles_(std::move(triangles)), normals_(std::move(normals)),
      textures_(std::move(textures)), settings_(settings), deltas_(std::move(deltas)),
      environment_(std::move(environment)) {
    if (environment_ != nullptr && max_component(settings_.background) > 0.0)
        throw std::invalid_argument("a scene has one environment: an environment map or a constant background");
    if (environment_ != nullptr && !environment_->lit()) environment_.reset();  // black: no light
    has_background_ = environment_ != nullptr || max_component(settings_.background) > 0.0;
    quad_base_ = static_cast<uint32_t>(spheres_.size());
    tri_base_ = quad_base_ + static_cast<uint32_t>(quads_.size());

    std::vector<AABB> boxes;
    boxes.reserve(primitive_count());
    for (const Sphere& s : spheres_) boxes.push_back(s.bounds());
    for (const Quad& q : quads_) boxes.push_back(q.bounds());
    for (const Triangle& t : triangles_) {
        // Zero-area triangles can never be hit: an empty box keeps them out of the BVH.
        boxes.push_back(t.degenerate() ? AABB() : t.bounds());
    }
    // Leaves made only of triangles are packed into SoA blocks of four, tested together;
    // the Cramer variants (kept to measure their leaks) test one triangle at a time.
    const bool pack = settings_.triangle_test == TriangleTest::Watertight;
    AABB world;
    for (const AABB& b : boxes)
        if (b.valid() && is_finite(b.lo) && is_finite(b.hi)) world.expand(b);
    if (world.valid()) coherent_origin_radius_ = 0.01 * length(world.hi - world.lo);
    // A handful of spheres and quads (the furnace: one sphere) are tested directly: the
    // tree's set-up and 8-wide root test cost more per ray than the primitives themselves.
    // Finite bounds for every sphere and quad (the tests that skip the tree need them).
    const bool finite = std::all_of(boxes.begin(), boxes.begin() + tri_base_, [](const AABB& b) {
        return b.valid() && is_finite(b.lo) && is_finite(b.hi);
    });
    direct_ = triangles_.empty() && primitive_count() <= kDirectTestLimit && finite;
    // Packs of rays (simd.h: 4, or 8 with AVX-512) tested against every sphere and quad:
    // one vector test serves the whole pack, which beats descending the tree ray by ray
    // up to a few dozen of them.
    batch_direct_ = tri_base_ <= kBatchTestLimit && finite;
    const auto packable = [&](uint32_t prim) { return pack && prim >= tri_base_; };
    bvh_ = WideBVH(BVH(boxes, packable), packable);
    float_blocks_ = std::all_of(triangles_.begin(), triangles_.end(), &Triangle4f::exact);
    auto fill_blocks = [&](const WideBVH& tree, auto& blocks) {
        blocks.resize(tree.blocks().size());
        for (size_t b = 0; b < blocks.size(); ++b) {
            const WideBVH::BlockLeaf& leaf = tree.blocks()[b];
            for (uint32_t lane = 0; lane < 4; ++lane) {
                const uint32_t prim = tree.order()[leaf.first + (lane < leaf.count ? lane : 0)];
                blocks[b].set(int(lane), triangles_[prim - tri_base_], prim);
            }
        }
    };
    if (float_blocks_) {
        fill_blocks(bvh_, tri4f_);
    } else {
        fill_blocks(bvh_, tri4_);
    }
    if (batch_direct_ && tri_base_ > 0 && !triangles_.empty() && triangles_.size() <= kMeshTreeLimit) {
        // The triangles alone: empty boxes keep the spheres and quads out of this tree.
        std::vector<AABB> mesh_boxes(boxes);
        std::fill(mesh_boxes.begin(), mesh_boxes.begin() + tri_base_, AABB());
        mesh_bvh_ = WideBVH(BVH(mesh_boxes, packable), packable);
        for (size_t i = tri_base_; i < boxes.size(); ++i)
            if (boxes[i].valid()) mesh_bounds_.expand(boxes[i]);
        // Padded far beyond the error of the slab test in PackSlabs.
        mesh_bounds_ = padded(mesh_bounds_);
        if (float_blocks_) {
            fill_blocks(mesh_bvh_, mesh_tri4f_);
        } else {
            fill_blocks(mesh_bvh_, mesh_tri4_);
        }
    }
    // Triangles that the packs cannot reach (too many for a second tree): through the main
    // tree, a batch's rays interleaved.
    batch_direct_ = batch_direct_ && (triangles_.empty() || !mesh_bvh_.empty());
    if (batch_direct_) choose_quad_runs(world);
    pack_slabs_ = !mesh_bvh_.empty() ||
                  std::any_of(quad_runs_.begin(), quad_runs_.end(), [](const QuadRun& r) { return r.boxed; });

    std::vector<Emitter> emitters;
    for (uint32_t i = 0; i < spheres_.size(); ++i)
        if (materials_[spheres_[i].material].emits())
            emitters.push_back({EmitterKind::Sphere, i, i, materials_[spheres_[i].material].radiance});
    for (uint32_t i = 0; i < quads_.size(); ++i)
        if (materials_[quads_[i].material].emits())
            emitters.push_back({EmitterKind::Quad, quad_base_ + i, i, materials_[quads_[i].material].radiance});
    for (uint32_t i = 0; i < triangles_.size(); ++i)
        if (materials_[triangles_[i].material].emits() && !triangles_[i].degenerate())
            emitters.push_back({EmitterKind::Triangle, tri_base_ + i, i, materials_[triangles_[i].material].radiance});
    // The radius of the scene's bounding sphere (a directional light's power).
    const double radius = world.valid() && is_finite(world.lo) && is_finite(world.hi)
                              ? 0.5 * length(world.hi - world.lo) : 0.0;
    lights_ = LightSampler(std::move(emitters), &spheres_, &quads_, &triangles_, settings_.background,
                           primitive_count(), &normals_, environment_.get(), &deltas_,
                           radius > 0.0 ? radius : 1.0);
}

void Scene::choose_quad_runs(const AABB& world) {
    // A boxed run of k quads saves their k tests in the packs where no lane meets its box,
    // and costs the box test (about half a quad test: the pack's reciprocal directions are
    // shared) in every pack. A ray crossing the scene meets a box with probability about
    // its surface area over the scene's (the surface-area heuristic's estimate), so a pack
    // of W lanes skips the run with probability (1 - p)^W. The runs are those that save
    // the most, found over the partitions of the quads' id order into consecutive runs
    // (dynamic programming; the order must stay, for ties). cornell_box: its two boxes,
    // six quads each; the walls and the light alone.
    constexpr double kBoxTestCost = 0.5;  // in quad tests
    const uint32_t n = static_cast<uint32_t>(quads_.size());
    const double world_area = world.surface_area();
    std::vector<double> saved(n + 1, 0.0);   // saved[i]: the best saving over quads [0, i)
    std::vector<uint32_t> start(n + 1, 0);  // where the last run of that partition starts
    for (uint32_t i = 1; i <= n; ++i) {
        saved[i] = saved[i - 1];  // quad i - 1 tested in every pack
        start[i] = i - 1;
        AABB b = quads_[i - 1].bounds();
        for (uint32_t j = i - 1; j-- > 0;) {  // the run [j, i)
            b.expand(quads_[j].bounds());
            const double p = world_area > 0.0 ? std::min(1.0, b.surface_area() / world_area) : 1.0;
            const double saving = double(i - j) * std::pow(1.0 - p, kPackWidth) - kBoxTestCost;
            if (saved[j] + saving > saved[i]) {
                saved[i] = saved[j] + saving;
                start[i] = j;
            }
        }
    }
    quad_runs_.clear();
    for (uint32_t i = n; i > 0; i = start[i]) {
        QuadRun run;
        run.first = start[i];
        run.count = i - start[i];
        run.boxed = run.count > 1;
        if (run.boxed) {
            for (uint32_t q = run.first; q < i; ++q) run.bounds.expand(quads_[q].bounds());
            run.bounds = padded(run.bounds);
        } else if (!quad_runs_.empty() && !quad_runs_.back().boxed) {
            --quad_runs_.back().first;  // joins the unboxed run after it (walking backwards)
            ++quad_runs_.back().count;
            continue;
        }
        quad_runs_.push_back(run);
    }
    std::reverse(quad_runs_.begin(), quad_runs_.end());
}

bool Scene::hit_other(uint32_t prim, const Ray& ray, const WatertightRay& wray, double& t_max,
                      uint32_t& best) const {
    double t;
    bool hit;
    if (prim < quad_base_) {
        hit = spheres_[prim].intersect(ray, 0.0, t_max, t);
    } else {
        const Triangle& tri = triangles_[prim - tri_base_];
        switch (settings_.triangle_test) {
            case TriangleTest::Watertight: hit = intersect_watertight(tri, ray, wray, 0.0, t_max, t); break;
            case TriangleTest::Cramer: hit = intersect_cramer<double>(tri, ray, 0.0, t_max, t); break;
            default: hit = intersect_cramer<float>(tri, ray, 0.0, t_max, t); break;
        }
    }
    if (hit) { t_max = t; best = prim; }
    return hit;
}

void Scene::texture_uv(const Interaction& it, double& u, double& v) const {
    const uint32_t prim = it.prim;
    if (prim < quad_base_) {
        // Mitsuba's sphere: the spherical angles of the hit's direction in the sphere's frame.
        const Sphere& s = spheres_[prim];
        const double* m = textures_.spheres[prim].m;
        const Vec3 d = it.p - s.center;
        Vec3 local(m[0] * d.x + m[1] * d.y + m[2] * d.z, m[3] * d.x + m[4] * d.y + m[5] * d.z,
                   m[6] * d.x + m[7] * d.y + m[8] * d.z);
        const double len = length(local);
        local = len > 0.0 ? local / len : Vec3(0.0, 0.0, 1.0);
        const double theta = std::acos(std::min(1.0, std::max(-1.0, local.z)));
        double phi = std::atan2(local.y, local.x);
        if (phi < 0.0) phi += 2.0 * kPi;
        u = phi * (0.5 * kInvPi);
        v = theta * kInvPi;
    } else if (prim < tri_base_) {
        // The quad's own planar coordinates (its intersection test's), mapped affinely.
        const Quad& q = quads_[prim - quad_base_];
        const QuadUV& m = textures_.quads[prim - quad_base_];
        const Vec3 d = it.p - q.Q;
        const double s = dot(d, q.ea), t = dot(d, q.eb);
        u = m.a[0] + s * m.b[0] + t * m.c[0];
        v = m.a[1] + s * m.b[1] + t * m.c[1];
    } else {
        // The corners' coordinates interpolated by the barycentrics (Mitsuba's mesh).
        const uint32_t i = prim - tri_base_;
        double w[3];
        triangles_[i].barycentrics(it.p, w);
        const TriangleUV& c = textures_.triangles[i];
        u = c.uv[2][0] * w[2] + (c.uv[1][0] * w[1] + c.uv[0][0] * w[0]);
        v = c.uv[2][1] * w[2] + (c.uv[1][1] * w[1] + c.uv[0][1] * w[0]);
    }
}

Vec3 Scene::texture_at(const Texture& t, const Interaction& it, double& u, double& v, bool& have_uv) const {
    if (t.kind == TextureKind::MeshAttribute) {
        // bound to a mesh's triangles (the Python layer gives no other shape such a texture)
        if (it.prim < tri_base_) return Vec3(0.0);
        const uint32_t i = it.prim - tri_base_;
        double w[3];
        triangles_[i].barycentrics(it.p, w);
        return t.attribute(i, w);
    }
    if (!have_uv) {
        texture_uv(it, u, v);
        have_uv = true;
    }
    return t.eval(u, v);
}

Vec3 Scene::texture_value(const Material& m, const Interaction& it) const {
    if (m.texture < 0) return m.albedo;  // textured in its opacity only
    double u = 0.0, v = 0.0;
    bool have_uv = false;
    return texture_at(textures_.textures[size_t(m.texture)], it, u, v, have_uv);
}

const Material& Scene::shade_textured(const Material& m, const Interaction& it,
                                      std::optional<Material>& local) const {
    double u = 0.0, v = 0.0;
    bool have_uv = false;
    local.emplace(m);
    if (m.texture >= 0) local->set_reflectance(texture_at(textures_.textures[size_t(m.texture)], it, u, v, have_uv));
    // Mitsuba's eval_opacity: clip(opacity.eval_1, 0, 1). The Python layer gives the
    // texture eval_1's values (one channel: a colour bitmap's luminance; a checkerboard's
    // colour means), so eval_1 is the lookup's first channel; std::min and std::max in this
    // order send a NaN to 0.
    if (m.opacity_texture >= 0)
        local->opacity = std::min(1.0, std::max(0.0, texture_at(textures_.textures[size_t(m.opacity_texture)], it, u, v, have_uv).x));
    return *local;
}

void Scene::fill_interaction(const Ray& ray, double t, uint32_t prim, Interaction& it) const {
    it.t = t;
    it.prim = prim;
    if (prim < quad_base_) {
        const Sphere& s = spheres_[prim];
        s.surface(ray.at(t), it.p, it.n);
        it.ns = it.n;
        it.smooth = false;  // the batch queries reuse their interactions
        it.material = s.material;
    } else if (prim < tri_base_) {
        const Quad& q = quads_[prim - quad_base_];
        // o + t d carries the error of the ray's origin (large for a distant camera);
        // projecting onto the plane leaves only a few ulps of |p| off the surface.
        it.p = project_to_plane(ray.at(t), q.Q, q.normal);
        it.n = it.ns = q.normal;
        it.smooth = false;
        it.material = q.material;
    } else {
        fill_triangle(ray, t, triangles_[prim - tri_base_], it);
        if (!normals_.empty()) shade_smooth(it);
    }
}

void Scene::fill_sphere_pack(const RayPack& r, VPd t, VPl prim, unsigned lanes, Interaction* const* it) const {
    VPd center[3], radius, sign;
    if (spheres_.size() == 1) {
        const Sphere& s = spheres_[0];
        for (int a = 0; a < 3; ++a) center[a] = splat(s.center[a]);
        radius = splat(s.radius);
        sign = splat(s.normal_sign);
    } else {
        for (int l = 0; l < kPackWidth; ++l) {  // every lane: the others' values are not used
            const Sphere& s = spheres_[((lanes >> l) & 1u) ? size_t(prim[l]) : 0];
            for (int a = 0; a < 3; ++a) center[a][l] = s.center[a];
            radius[l] = s.radius;
            sign[l] = s.normal_sign;
        }
    }
    // ray.at(t), o + t d, lane-wise.
    const VPd at[3] = {r.ox + r.dx * t, r.oy + r.dy * t, r.oz + r.dz * t};
    VPd p[3], n[3];
    Sphere::surface_lanes(at, center, radius, sign, p, n);
    for (unsigned left = lanes; left != 0; left &= left - 1) {
        const int l = __builtin_ctz(left);
        Interaction& hit = *it[l];
        hit.t = t[l];
        hit.prim = static_cast<uint32_t>(prim[l]);
        hit.p = Vec3(p[0][l], p[1][l], p[2][l]);
        hit.n = hit.ns = Vec3(n[0][l], n[1][l], n[2][l]);
        hit.smooth = false;
        hit.material = spheres_[hit.prim].material;
    }
}

void Scene::fill_triangle(const Ray& ray, double t, const Triangle& tri, Interaction& it) {
    it.n = it.ns = tri.normal();
    it.smooth = false;
    it.p = project_to_plane(ray.at(t), tri.a, it.n);
    it.material = tri.material;
}

bool Scene::intersect(const Ray& ray, Interaction& it, double t_max) const {
    // Three divisions per ray that only triangle tests use.
    const WatertightRay wray = triangles_.empty() ? WatertightRay() : WatertightRay(ray.d);
    ClosestHit best;
    double t = t_max;
    if (direct_) {
        bool hit = false;
        for (uint32_t prim = 0; prim < quad_base_ + quads_.size(); ++prim)
            hit |= closest_primitive(prim, ray, wray, t, best);
        if (hit) fill_hit(ray, t, best, it);
        return hit;
    }
    const bool hit = bvh_.traverse<false>(
        ray, t, [&](uint32_t prim, double& tm) { return closest_primitive(prim, ray, wray, tm, best); },
        [&](uint32_t block, double& tm) { return closest_block(block, ray, wray, tm, best); },
        [&](uint32_t block) { prefetch_block(block); });
    if (hit) fill_hit(ray, t, best, it);
    return hit;
}

bool Scene::occluded(const Ray& ray, double t_max) const {
    const WatertightRay wray = triangles_.empty() ? WatertightRay() : WatertightRay(ray.d);
    uint32_t unused = 0;
    if (direct_) {
        for (uint32_t prim = 0; prim < quad_base_ + quads_.size(); ++prim)
            if (hit_primitive(prim, ray, wray, t_max, unused)) return true;
        return false;
    }
    return bvh_.traverse<true>(
        ray, t_max, [&](uint32_t prim, double& tm) { return hit_primitive(prim, ray, wray, tm, unused); },
        [&](uint32_t block, double& tm) { return hit_block(block, ray, wray, tm, unused) >= 0; },
        [&](uint32_t block) { prefetch_block(block); });
}

namespace {

// Rays rays[0 .. m) (m <= kPackWidth) as a pack; absent lanes repeat ray 0. Gathered field
// by field (simd.h): written lane by lane, the pack's wide reloads waited on the narrow
// stores, 5% of the closest-hit packs' time on cornell_box (PERFORMANCE.md, Ideas tried).
static_assert(sizeof(Vec3) == 3 * sizeof(double) && offsetof(Ray, d) == sizeof(Vec3),
              "pack_rays gathers a ray as six consecutive doubles");
RayPack pack_rays(const Ray* const* rays, size_t m) {
#if RT_PACK == 8 && defined(__AVX512F__)
    VPd v[6];  // o and d: six consecutive doubles (static_assert above)
    gather_members<6>(rays, static_cast<int>(m), [](const Ray& r) { return &r.o.x; }, v);
    return RayPack{v[0], v[1], v[2], v[3], v[4], v[5]};
#else
    // Lane by lane into the pack itself: through gather_members' array, one more copy of
    // the pack (+1.3% AVX2 instructions on cornell_box).
    RayPack p;
    for (size_t l = 0; l < size_t(kPackWidth); ++l) {
        const Ray& r = *rays[l < m ? l : 0];
        p.ox[l] = r.o.x; p.oy[l] = r.o.y; p.oz[l] = r.o.z;
        p.dx[l] = r.d.x; p.dy[l] = r.d.y; p.dz[l] = r.d.z;
    }
    return p;
#endif
}

// A pack's slab tests against boxes (mesh_bvh_'s bounds, the boxed quad runs), with the
// reciprocal directions estimated once per pack (simd.h: relative error below 2^-14; three
// exact divisions of eight lanes cost 4% of cornell_box's time on AVX-512).
// may_hit(b, t_max): the lanes (bits) that may meet box b at a distance in [0, t_max]; the
// far distance is widened by 1e-3 of itself, far beyond the estimate's error (every
// distance is within 2^-13 of its exact value, relative) and the rounding, so that a test
// only saves work and never loses a hit. A lane whose arithmetic gives NaN (an origin on
// a slab plane, the direction parallel to it) counts as a maybe.
struct PackSlabs {
    VPd o[3], inv[3];

    PackSlabs() = default;
    explicit PackSlabs(const RayPack& p)
        : o{p.ox, p.oy, p.oz},
          inv{reciprocal_estimate(p.dx), reciprocal_estimate(p.dy), reciprocal_estimate(p.dz)} {}

    unsigned may_hit(const AABB& b, VPd t_max) const {
        VPd t_near = VPd{}, t_far = t_max;
        VPl nan = VPl{};
        for (int a = 0; a < 3; ++a) {
            const VPd t0 = (b.lo[a] - o[a]) * inv[a], t1 = (b.hi[a] - o[a]) * inv[a];
            nan |= (t0 != t0) | (t1 != t1);
            const VPl order = t0 < t1;
            const VPd near = order ? t0 : t1, far = order ? t1 : t0;
            t_near = near > t_near ? near : t_near;
            t_far = far < t_far ? far : t_far;
        }
        const VPd abs_far = t_far < 0.0 ? -t_far : t_far;
        static_assert(1e-3 > 16 * kReciprocalEstimateError, "the widening must dwarf the estimate's error");
        return lane_mask(nan | (t_near <= t_far + abs_far * 1e-3));
    }
};

}  // namespace

void Scene::closest_mesh_hits(size_t count, const size_t* index, const Ray* const* rays, double* t_max,
                              uint32_t* best, bool* found) const {
    struct Query {
        const Scene& scene;
        const size_t* index;
        const Ray* const* rays;
        double* t_max;
        uint32_t* best;
        bool* found;
        struct Slot {
            const Ray* ray;
            WatertightRay wray;
            uint32_t best;
        } slots[kWidth];

        const Ray& begin(int s, size_t k) {
            Slot& slot = slots[s];
            slot.ray = rays[index[k]];
            slot.wray = WatertightRay(slot.ray->d);
            slot.best = best[index[k]];
            return *slot.ray;
        }
        double t_start(size_t k) const { return t_max[index[k]]; }
        bool test(int s, uint32_t prim, double& t) {
            return scene.hit_primitive(prim, *slots[s].ray, slots[s].wray, t, slots[s].best);
        }
        bool test_block(int s, uint32_t block, double& t) {
            return scene.hit_mesh_block(block, *slots[s].ray, slots[s].wray, t, slots[s].best) >= 0;
        }
        void prefetch_block(uint32_t block) { scene.prefetch_mesh_block(block); }
        void finish(int s, size_t k, bool hit, double t) {
            if (!hit) return;
            t_max[index[k]] = t;
            best[index[k]] = slots[s].best;
            found[index[k]] = true;
        }
    } query{*this, index, rays, t_max, best, found, {}};
    if (mesh_tree_bytes() <= kCachedTreeBytes) {
        mesh_bvh_.traverse_interleaved<kWidth, true>(count, query);
    } else {
        mesh_bvh_.traverse_interleaved<kWidth, false>(count, query);
    }
}

template <bool kMesh>
void Scene::occlusions(size_t count, const size_t* index, const Ray* const* rays, const double* t_max,
                       bool* occluded) const {
    struct Query {
        const Scene& scene;
        const size_t* index;
        const Ray* const* rays;
        const double* t_max;
        bool* occluded;
        struct Slot {
            const Ray* ray;
            WatertightRay wray;
        } slots[kWidth];
        uint32_t unused = 0;

        size_t at(size_t k) const { return index != nullptr ? index[k] : k; }
        const Ray& begin(int s, size_t k) {
            const Ray* ray = rays[at(k)];
            slots[s] = {ray, scene.triangles_.empty() ? WatertightRay() : WatertightRay(ray->d)};
            return *ray;
        }
        double t_start(size_t k) const { return t_max[at(k)]; }
        bool test(int s, uint32_t prim, double& t) {
            return scene.hit_primitive(prim, *slots[s].ray, slots[s].wray, t, unused);
        }
        bool test_block(int s, uint32_t block, double& t) {
            const Slot& slot = slots[s];
            return (kMesh ? scene.hit_mesh_block(block, *slot.ray, slot.wray, t, unused)
                          : scene.hit_block(block, *slot.ray, slot.wray, t, unused)) >= 0;
        }
        void prefetch_block(uint32_t block) {
            if (kMesh) {
                scene.prefetch_mesh_block(block);
            } else {
                scene.prefetch_block(block);
            }
        }
        void finish(int, size_t k, bool hit, double) {
            if (hit) occluded[at(k)] = true;
        }
    } query{*this, index, rays, t_max, occluded, {}};
    const WideBVH& tree = kMesh ? mesh_bvh_ : bvh_;
    if ((kMesh ? mesh_tree_bytes() : tree_bytes()) <= kCachedTreeBytes) {
        tree.traverse_interleaved<kWidth, true, true>(count, query);
    } else {
        tree.traverse_interleaved<kWidth, false, true>(count, query);
    }
}

void Scene::intersect_batch(size_t n, const Ray* const* rays, bool* hit, Interaction* const* it) const {
    if (!batch_direct_) {
        // Interleaved only: a packet may break an exact tie between two blocks' triangles
        // otherwise than intersect() (intersect_stream).
        intersect_stream(
            n, [rays](size_t i) -> const Ray& { return *rays[i]; },
            [hit, it](size_t i, bool found, const Interaction& x) {
                hit[i] = found;
                if (found) *it[i] = x;
            },
            false, false);
        return;
    }
    // kOverlapPacks packs are tested before any is filled (simd.h).
    struct Tested {
        RayPack p;
        VPd t_max;
        VPl best;
        unsigned mesh;
    };
    constexpr size_t kGroup = kOverlapPacks;
    for (size_t group = 0; group < n; group += kGroup * kPackWidth) {
        Tested tested[kGroup];
        const size_t packs = std::min(kGroup, (n - group + kPackWidth - 1) / kPackWidth);
        for (size_t k = 0; k < packs; ++k) {
            const size_t base = group + k * kPackWidth;
            const size_t m = std::min<size_t>(kPackWidth, n - base);
            // The pack's state where the fill below reads it (a copy a pack otherwise).
            Tested& x = tested[k];
            const RayPack& p = x.p = pack_rays(rays + base, m);
            // Every sphere and quad in id order, as Scene::intersect's direct loop, a pack of
            // rays at a time; then the triangles, below the distance found (after the loop).
            VPd& t_max = x.t_max = VPd{} + kInf;
            VPl& best = x.best = VPl{} - 1;
            if (!spheres_.empty()) {
                const VPd inv_a = Sphere::reciprocal_length_squared<VPd>({p.dx, p.dy, p.dz});
                for (uint32_t s = 0; s < spheres_.size(); ++s)
                    best = spheres_[s].intersect_pack(p, inv_a, t_max) ? VPl{} + int64_t(s) : best;
            }
            const PackSlabs slabs = pack_slabs_ ? PackSlabs(p) : PackSlabs();
            for (const QuadRun& run : quad_runs_) {
                if (run.boxed && slabs.may_hit(run.bounds, t_max) == 0) continue;  // no lane can meet its quads
                for (uint32_t q = run.first; q < run.first + run.count; ++q)
                    best = quads_[q].intersect_pack(p, t_max) ? VPl{} + int64_t(quad_base_ + q) : best;
            }
            // Present lanes only: the others repeat ray 0 (pack_rays).
            x.mesh = mesh_bvh_.empty() ? 0u : slabs.may_hit(mesh_bounds_, t_max) & ((1u << m) - 1u);
        }
        // The rays that may meet the mesh go through its tree together, interleaved: one
        // ray after another, each waited on its nodes' loads and its branches' outcomes.
        constexpr size_t kRays = kGroup * kPackWidth;
        double t_of[kRays];
        uint32_t prim_of[kRays];
        bool found_of[kRays];
        size_t meshed[kRays];
        if (!mesh_bvh_.empty()) {
            size_t n_meshed = 0;
            for (size_t k = 0; k < packs; ++k) {
                const Tested& x = tested[k];
                for (unsigned left = x.mesh; left != 0; left &= left - 1) {
                    const int l = __builtin_ctz(left);
                    const size_t r = k * kPackWidth + size_t(l);
                    t_of[r] = x.t_max[l];
                    prim_of[r] = static_cast<uint32_t>(x.best[l]);
                    found_of[r] = x.best[l] >= 0;
                    meshed[n_meshed++] = r;
                }
            }
            if (n_meshed > 0) closest_mesh_hits(n_meshed, meshed, rays + group, t_of, prim_of, found_of);
        }
        for (size_t k = 0; k < packs; ++k) {
            const size_t base = group + k * kPackWidth;
            const size_t m = std::min<size_t>(kPackWidth, n - base);
            const Tested& x = tested[k];
            // Packs whose every hit is a sphere's (every vertex of `furnace`) take their hit
            // points a pack at a time: a lane's square root and division otherwise wait on the
            // divider one lane after another.
            const unsigned present = (1u << m) - 1u;
            const unsigned found = lane_mask(x.best >= 0) & present;
            if (x.mesh == 0 && found != 0 && (lane_mask(x.best < int64_t(quad_base_)) & found) == found) {
                fill_sphere_pack(x.p, x.t_max, x.best, found, it + base);
                for (size_t l = 0; l < m; ++l) hit[base + l] = (found >> l) & 1u;
                continue;
            }
            for (size_t l = 0; l < m; ++l) {
                double t = x.t_max[l];
                uint32_t prim = static_cast<uint32_t>(x.best[l]);
                bool hit_l = x.best[l] >= 0;
                if ((x.mesh >> l) & 1u) {
                    const size_t r = k * kPackWidth + l;
                    t = t_of[r];
                    prim = prim_of[r];
                    hit_l = found_of[r];
                }
                hit[base + l] = hit_l;
                if (hit_l) fill_interaction(*rays[base + l], t, prim, *it[base + l]);
            }
        }
    }
}

void Scene::occluded_batch(size_t n, const Ray* const* rays, const double* t_max, bool* occluded) const {
    if (!batch_direct_) {
        for (size_t i = 0; i < n; ++i) occluded[i] = false;
        occlusions<false>(n, nullptr, rays, t_max, occluded);
        return;
    }
    // The rays that may meet the mesh, by index: on this call's stack for the wavefront
    // integrator's batches.
    constexpr size_t kInline = 64;
    size_t meshed_inline[kInline];
    const std::unique_ptr<size_t[]> meshed_heap(n > kInline ? new size_t[n] : nullptr);
    size_t* const meshed = n > kInline ? meshed_heap.get() : meshed_inline;
    size_t n_meshed = 0;
    for (size_t base = 0; base < n; base += kPackWidth) {
        const size_t m = std::min<size_t>(kPackWidth, n - base);
        const Ray* const* r = rays + base;
        const RayPack p = pack_rays(r, m);
        // Absent lanes get t_max 0: nothing can block them.
        VPd tm = load_partial(t_max + base, static_cast<int>(m));
        // Any hit answers, so a test's lowering of t_max changes no verdict.
        const unsigned all = (1u << m) - 1u;
        unsigned blocked = 0;
        if (!spheres_.empty()) {
            const VPd inv_a = Sphere::reciprocal_length_squared<VPd>({p.dx, p.dy, p.dz});
            for (uint32_t s = 0; s < spheres_.size() && blocked != all; ++s)
                blocked |= lane_mask(spheres_[s].intersect_pack(p, inv_a, tm));
        }
        const PackSlabs slabs = pack_slabs_ ? PackSlabs(p) : PackSlabs();
        for (size_t i = 0; i < quad_runs_.size() && blocked != all; ++i) {
            const QuadRun& run = quad_runs_[i];
            if (run.boxed && (slabs.may_hit(run.bounds, tm) & all & ~blocked) == 0) continue;
            for (uint32_t q = run.first; q < run.first + run.count && blocked != all; ++q) {
                if (((quads_[q].same_side_lanes(p, tm) | blocked) & all) == all) continue;  // no lane can cross it
                blocked |= lane_mask(quads_[q].intersect_pack(p, tm));
            }
        }
        const unsigned mesh =
            (mesh_bvh_.empty() || blocked == all) ? 0u : slabs.may_hit(mesh_bounds_, tm) & all & ~blocked;
        for (size_t l = 0; l < m; ++l) occluded[base + l] = (blocked >> l) & 1u;
        for (unsigned left = mesh; left != 0; left &= left - 1) meshed[n_meshed++] = base + size_t(__builtin_ctz(left));
    }
    // The rays that may meet the mesh go through its tree together, interleaved (as in
    // intersect_batch).
    if (n_meshed > 0) occlusions<true>(n_meshed, meshed, rays, t_max, occluded);
}

bool Scene::intersect_brute_force(const Ray& ray, Interaction& it, double t_max) const {
    const WatertightRay wray(ray.d);
    uint32_t best = 0;
    double t = t_max;
    bool hit = false;
    const uint32_t n = static_cast<uint32_t>(primitive_count());
    for (uint32_t prim = 0; prim < n; ++prim) {
        if (prim >= tri_base_ && triangles_[prim - tri_base_].degenerate()) continue;
        hit |= hit_primitive(prim, ray, wray, t, best);
    }
    if (hit) fill_interaction(ray, t, best, it);
    return hit;
}

}  // namespace rt
