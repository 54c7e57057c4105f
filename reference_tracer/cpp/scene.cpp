#include "scene.h"

namespace rt {

namespace {

Vec3 project_to_plane(const Vec3& p, const Vec3& point_on_plane, const Vec3& unit_normal) {
    return p - unit_normal * dot(p - point_on_plane, unit_normal);
}

}  // namespace

Scene::Scene(Camera camera, std::vector<Material> materials, std::vector<Sphere> spheres,
             std::vector<Quad> quads, std::vector<Triangle> triangles, SceneSettings settings)
    : camera_(camera), materials_(std::move(materials)), spheres_(std::move(spheres)),
      quads_(std::move(quads)), triangles_(std::move(triangles)), settings_(settings) {
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
    const bool all_finite = std::all_of(boxes.begin(), boxes.end(), [](const AABB& b) {
        return b.valid() && is_finite(b.lo) && is_finite(b.hi);
    });
    direct_ = triangles_.empty() && primitive_count() <= kDirectTestLimit && all_finite;
    // Batches of four rays tested against every primitive: one vector quad test serves
    // four rays, which beats descending the tree ray by ray up to a few dozen quads.
    batch_direct_ = triangles_.empty() && primitive_count() <= kBatchTestLimit && all_finite;
    const auto packable = [&](uint32_t prim) { return pack && prim >= tri_base_; };
    bvh_ = WideBVH(BVH(boxes, packable), packable);
    float_blocks_ = std::all_of(triangles_.begin(), triangles_.end(), &Triangle4f::exact);
    auto fill_blocks = [&](auto& blocks) {
        blocks.resize(bvh_.blocks().size());
        for (size_t b = 0; b < blocks.size(); ++b) {
            const WideBVH::BlockLeaf& leaf = bvh_.blocks()[b];
            for (uint32_t lane = 0; lane < 4; ++lane) {
                const uint32_t prim = bvh_.order()[leaf.first + (lane < leaf.count ? lane : 0)];
                blocks[b].set(int(lane), triangles_[prim - tri_base_], prim);
            }
        }
    };
    if (float_blocks_) {
        fill_blocks(tri4f_);
    } else {
        fill_blocks(tri4_);
    }

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
    lights_ = LightSampler(std::move(emitters), &spheres_, &quads_, &triangles_, settings_.background,
                           primitive_count());
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

void Scene::fill_interaction(const Ray& ray, double t, uint32_t prim, Interaction& it) const {
    it.t = t;
    it.prim = prim;
    if (prim < quad_base_) {
        const Sphere& s = spheres_[prim];
        s.surface(ray.at(t), it.p, it.n);
        it.material = s.material;
    } else if (prim < tri_base_) {
        const Quad& q = quads_[prim - quad_base_];
        // o + t d carries the error of the ray's origin (large for a distant camera);
        // projecting onto the plane leaves only a few ulps of |p| off the surface.
        it.p = project_to_plane(ray.at(t), q.Q, q.normal);
        it.n = q.normal;
        it.material = q.material;
    } else {
        fill_triangle(ray, t, triangles_[prim - tri_base_], it);
    }
}

void Scene::fill_triangle(const Ray& ray, double t, const Triangle& tri, Interaction& it) {
    it.n = tri.normal();
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

// Rays rays[0 .. m) (m <= 4) as a pack; absent lanes repeat ray 0.
RayPack4 pack_rays(const Ray* rays, size_t m) {
    RayPack4 p;
    for (size_t l = 0; l < 4; ++l) {
        const Ray& r = rays[l < m ? l : 0];
        p.ox[l] = r.o.x; p.oy[l] = r.o.y; p.oz[l] = r.o.z;
        p.dx[l] = r.d.x; p.dy[l] = r.d.y; p.dz[l] = r.d.z;
    }
    return p;
}

}  // namespace

void Scene::intersect_batch(size_t n, const Ray* rays, bool* hit, Interaction* it) const {
    if (!batch_direct_) {
        for (size_t i = 0; i < n; ++i) hit[i] = intersect(rays[i], it[i]);
        return;
    }
    for (size_t base = 0; base < n; base += 4) {
        const size_t m = std::min<size_t>(4, n - base);
        const Ray* r = rays + base;
        const RayPack4 p = pack_rays(r, m);
        // Every primitive in id order (spheres, then quads), as Scene::intersect's direct
        // loop, four rays at a time.
        V4d t_max = V4d{} + kInf;
        V4l best = V4l{} - 1;
        for (uint32_t s = 0; s < spheres_.size(); ++s)
            best = spheres_[s].intersect4(p, t_max) ? V4l{} + int64_t(s) : best;
        for (uint32_t q = 0; q < quads_.size(); ++q)
            best = quads_[q].intersect4(p, t_max) ? V4l{} + int64_t(quad_base_ + q) : best;
        for (size_t l = 0; l < m; ++l) {
            hit[base + l] = best[l] >= 0;
            if (best[l] >= 0) fill_interaction(r[l], t_max[l], static_cast<uint32_t>(best[l]), it[base + l]);
        }
    }
}

void Scene::occluded_batch(size_t n, const Ray* rays, const double* t_max, bool* occluded) const {
    if (!batch_direct_) {
        for (size_t i = 0; i < n; ++i) occluded[i] = this->occluded(rays[i], t_max[i]);
        return;
    }
    for (size_t base = 0; base < n; base += 4) {
        const size_t m = std::min<size_t>(4, n - base);
        const Ray* r = rays + base;
        const RayPack4 p = pack_rays(r, m);
        // Absent lanes get t_max 0: nothing can block them.
        V4d tm;
        for (size_t l = 0; l < 4; ++l) tm[l] = l < m ? t_max[base + l] : 0.0;
        // Any hit answers, so a test's lowering of t_max changes no verdict.
        const unsigned all = (1u << m) - 1u;
        unsigned blocked = 0;
        for (uint32_t s = 0; s < spheres_.size() && blocked != all; ++s)
            blocked |= lane_mask4(spheres_[s].intersect4(p, tm));
        for (uint32_t q = 0; q < quads_.size() && blocked != all; ++q)
            blocked |= lane_mask4(quads_[q].intersect4(p, tm));
        for (size_t l = 0; l < m; ++l) occluded[base + l] = (blocked >> l) & 1u;
    }
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
