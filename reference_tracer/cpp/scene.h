// The scene the integrator renders: world-space primitives, materials, a BVH over all
// primitives, the light sampler, the camera and the integrator settings.
// Primitive ids are global: spheres first, then quads, then triangles.
#pragma once

#include <vector>

#include "wide_bvh.h"
#include "materials/material.h"
#include "sampling/lights.h"
#include "shapes/quad.h"
#include "shapes/sphere.h"
#include "shapes/triangle.h"

namespace rt {

// Pinhole camera; pixel (0, 0) is the top-left corner, +x right, +y down in the image.
struct Camera {
    Vec3 origin, forward, right, up;
    double half_width = 1, half_height = 1;
    int width = 1, height = 1;

    Camera() = default;
    Camera(const Vec3& lookfrom, const Vec3& lookat, const Vec3& vup, double vfov_deg, int w, int h)
        : origin(lookfrom), width(w), height(h) {
        forward = normalize(lookat - lookfrom);
        right = normalize(cross(forward, vup));
        up = cross(right, forward);
        half_height = std::tan(0.5 * vfov_deg * kPi / 180.0);
        half_width = half_height * double(w) / double(h);
    }

    // Ray through the film point (px, py), in pixel units from the top-left corner.
    Ray generate(double px, double py) const {
        const double sx = (2.0 * px / width - 1.0) * half_width;
        const double sy = (1.0 - 2.0 * py / height) * half_height;
        return Ray{origin, normalize(forward + sx * right + sy * up)};
    }
};

struct Interaction {
    double t = kInf;
    Vec3 p;          // hit point
    Vec3 n;          // unit normal of the primitive's front side
    uint32_t prim = 0;
    uint32_t material = 0;
};

struct SceneSettings {
    Vec3 background;
    int max_depth = 50;     // path segments, as Mitsuba's path integrator counts them
    int rr_depth = -1;      // -1: no Russian roulette
    TriangleTest triangle_test = TriangleTest::Watertight;
};

class Scene {
public:
    Scene(Camera camera, std::vector<Material> materials, std::vector<Sphere> spheres,
          std::vector<Quad> quads, std::vector<Triangle> triangles, SceneSettings settings);
    // Copies would leave the light sampler pointing into the source's arrays.
    Scene(const Scene&) = delete;
    Scene& operator=(const Scene&) = delete;

    // Closest hit with t in (0, t_max).
    bool intersect(const Ray& ray, Interaction& it, double t_max = kInf) const;
    // Closest hits (t in (0, inf)) of rays ray_at(0 .. n-1), traversed interleaved
    // (WideBVH::traverse_interleaved, for throughput on large meshes): done(i, hit, it)
    // receives each result, the same as intersect(ray_at(i), it) gives.
    template <typename RayAt, typename Done>
    void intersect_stream(size_t n, RayAt&& ray_at, Done&& done) const;
    // Whether anything lies on the ray with t in (0, t_max) (shadow rays).
    bool occluded(const Ray& ray, double t_max = kInf) const;
    // The same by testing every primitive (a reference for BVH tests).
    bool intersect_brute_force(const Ray& ray, Interaction& it, double t_max = kInf) const;

    const Camera& camera() const { return camera_; }
    const SceneSettings& settings() const { return settings_; }
    const Material& material(uint32_t id) const { return materials_[id]; }
    const LightSampler& lights() const { return lights_; }
    const WideBVH& bvh() const { return bvh_; }
    size_t primitive_count() const { return spheres_.size() + quads_.size() + triangles_.size(); }
    size_t sphere_count() const { return spheres_.size(); }
    size_t quad_count() const { return quads_.size(); }
    size_t triangle_count() const { return triangles_.size(); }

private:
    // Tests primitive `prim`; on a hit closer than t_max, lowers t_max and records it.
    bool hit_primitive(uint32_t prim, const Ray& ray, const WatertightRay& wray, double& t_max,
                       uint32_t& best) const {
        // Quads inline in the traversal loop (a call per primitive, with its argument
        // set-up and spills, cost ~3% of cornell_box); spheres and triangles out of line.
        if (prim >= quad_base_ && prim < tri_base_) {
            double t;
            if (!quads_[prim - quad_base_].intersect(ray, 0.0, t_max, t)) return false;
            t_max = t;
            best = prim;
            return true;
        }
        return hit_other(prim, ray, wray, t_max, best);
    }
    // hit_primitive for spheres and triangles.
    bool hit_other(uint32_t prim, const Ray& ray, const WatertightRay& wray, double& t_max,
                   uint32_t& best) const;
    // The same for the up to four triangles of block leaf `block`; returns the lane hit,
    // or -1.
    int hit_block(uint32_t block, const Ray& ray, const WatertightRay& wray, double& t_max,
                  uint32_t& best) const {
        const Triangle4& q = tri4_[block];
        double t;
        const int lane = intersect_watertight4(q, ray, wray, 0.0, t_max, t);
        if (lane < 0) return -1;
        t_max = t;
        best = q.prim[lane];
        return lane;
    }
    void prefetch_block(uint32_t block) const {
        const char* p = reinterpret_cast<const char*>(&tri4_[block]);
        for (size_t line = 0; line < sizeof(Triangle4); line += 64) __builtin_prefetch(p + line);
    }
    void fill_interaction(const Ray& ray, double t, uint32_t prim, Interaction& it) const;
    // The interaction of a closest hit: from the block just tested when it came from one
    // (block >= 0; it is in cache, the triangle array would be a miss on large meshes).
    void fill_hit(const Ray& ray, double t, uint32_t prim, int32_t block, int lane, Interaction& it) const {
        if (block >= 0) {
            it.t = t;
            it.prim = prim;
            fill_triangle(ray, t, tri4_[block].triangle(lane), it);
        } else {
            fill_interaction(ray, t, prim, it);
        }
    }
    static void fill_triangle(const Ray& ray, double t, const Triangle& tri, Interaction& it);

    Camera camera_;
    std::vector<Material> materials_;
    std::vector<Sphere> spheres_;
    std::vector<Quad> quads_;
    std::vector<Triangle> triangles_;
    SceneSettings settings_;
    WideBVH bvh_;
    std::vector<Triangle4> tri4_;  // the BVH's block leaves (watertight test only), in block order
    LightSampler lights_;
    uint32_t quad_base_ = 0, tri_base_ = 0;
};

template <typename RayAt, typename Done>
void Scene::intersect_stream(size_t n, RayAt&& ray_at, Done&& done) const {
    constexpr int kLanes = 8;
    // Per lane: the ray and what intersect() keeps in locals.
    struct Context {
        Ray ray;
        WatertightRay wray;
        uint32_t best = 0;
        int32_t best_block = -1;
        int best_lane = 0;
    };
    struct Query {
        const Scene& scene;
        RayAt& ray_at;
        Done& done;
        Context ctx[kLanes];

        Ray ray(size_t i) { return ray_at(i); }
        void begin(int s, size_t i) {
            Context& c = ctx[s];
            c.ray = ray_at(i);
            c.wray = scene.triangles_.empty() ? WatertightRay() : WatertightRay(c.ray.d);
            c.best_block = -1;
        }
        bool test(int s, uint32_t prim, double& t_max) {
            Context& c = ctx[s];
            if (!scene.hit_primitive(prim, c.ray, c.wray, t_max, c.best)) return false;
            c.best_block = -1;
            return true;
        }
        bool test_block(int s, uint32_t block, double& t_max) {
            Context& c = ctx[s];
            const int lane = scene.hit_block(block, c.ray, c.wray, t_max, c.best);
            if (lane < 0) return false;
            c.best_block = static_cast<int32_t>(block);
            c.best_lane = lane;
            return true;
        }
        void prefetch_block(uint32_t block) { scene.prefetch_block(block); }
        void finish(int s, size_t i, bool hit, double t) {
            Interaction it;
            if (hit) {
                const Context& c = ctx[s];
                scene.fill_hit(c.ray, t, c.best, c.best_block, c.best_lane, it);
            }
            done(i, hit, it);
        }
    };
    Query query{*this, ray_at, done, {}};
    bvh_.traverse_interleaved<kLanes>(n, query);
}

}  // namespace rt
