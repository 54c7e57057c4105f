// The scene the integrator renders: world-space primitives, materials, a BVH over all
// primitives, the light sampler, the camera and the integrator settings.
// Primitive ids are global: spheres first, then quads, then triangles.
#pragma once

#include <algorithm>
#include <cmath>
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
    // Closest hits (t in (0, inf)) of rays ray_at(0 .. n-1), for throughput on large
    // meshes: runs of coherent rays as packets (WideBVH::traverse_packet), the others
    // interleaved (WideBVH::traverse_interleaved). done(i, hit, it) receives each result,
    // the same as intersect(ray_at(i), it) gives. Returns how many rays went in packets.
    template <typename RayAt, typename Done>
    size_t intersect_stream(size_t n, RayAt&& ray_at, Done&& done) const;
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
    // Whether rays[0 .. m) may be traced as a packet: directions in one octant (the same
    // near and far box planes for all) and close in direction (components within half the
    // first ray's largest component of its own), origins within 1% of the scene's extent.
    // Camera rays through neighbouring pixels are; random rays almost never (one octant
    // alone: probability 8^-7). Only speed depends on it, never a result.
    static bool coherent(const Ray* rays, int m, double origin_radius) {
        const Vec3& d0 = rays[0].d;
        const double spread = 0.5 * std::max({std::abs(d0.x), std::abs(d0.y), std::abs(d0.z)});
        for (int r = 1; r < m; ++r)
            for (int a = 0; a < 3; ++a) {
                if (std::signbit(rays[r].d[a]) != std::signbit(d0[a])) return false;
                if (!(std::abs(rays[r].d[a] - d0[a]) <= spread)) return false;
                if (!(std::abs(rays[r].o[a] - rays[0].o[a]) <= origin_radius)) return false;
            }
        return true;
    }
    bool coherent(const Ray* rays, int m) const { return coherent(rays, m, coherent_origin_radius_); }
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
    double coherent_origin_radius_ = 0.0;  // 1% of the diagonal of the scene's bounds
};

template <typename RayAt, typename Done>
size_t Scene::intersect_stream(size_t n, RayAt&& ray_at, Done&& done) const {
    constexpr int kLanes = kWidth;
    // Per lane: the ray and what intersect() keeps in locals.
    struct Context {
        Ray ray;
        WatertightRay wray;
        uint32_t best = 0;
        int32_t best_block = -1;
        int best_lane = 0;
    };
    auto lane_begin = [&](Context& c, const Ray& ray) {
        c.ray = ray;
        c.wray = triangles_.empty() ? WatertightRay() : WatertightRay(ray.d);
        c.best_block = -1;
    };
    auto lane_test = [&](Context& c, uint32_t prim, double& t_max) {
        if (!hit_primitive(prim, c.ray, c.wray, t_max, c.best)) return false;
        c.best_block = -1;
        return true;
    };
    auto lane_test_block = [&](Context& c, uint32_t block, double& t_max) {
        const int lane = hit_block(block, c.ray, c.wray, t_max, c.best);
        if (lane < 0) return false;
        c.best_block = static_cast<int32_t>(block);
        c.best_lane = lane;
        return true;
    };
    auto lane_finish = [&](const Context& c, size_t i, bool hit, double t) {
        Interaction it;
        if (hit) fill_hit(c.ray, t, c.best, c.best_block, c.best_lane, it);
        done(i, hit, it);
    };

    // Runs of kLanes consecutive rays that are coherent go through the BVH as packets;
    // the rest are traced one ray per lane, interleaved.
    struct PacketQuery {
        decltype(lane_test)& test_fn;
        decltype(lane_test_block)& test_block_fn;
        const Scene& scene;
        Context* ctx;
        bool test(int r, uint32_t prim, double& t_max) { return test_fn(ctx[r], prim, t_max); }
        bool test_block(int r, uint32_t block, double& t_max) { return test_block_fn(ctx[r], block, t_max); }
        void prefetch_block(uint32_t block) { scene.prefetch_block(block); }
    };
    Context packet_ctx[kLanes];
    PacketQuery packet{lane_test, lane_test_block, *this, packet_ctx};
    std::vector<size_t> scattered;
    size_t in_packets = 0;
    for (size_t base = 0; base < n; base += kLanes) {
        const int m = static_cast<int>(std::min<size_t>(kLanes, n - base));
        Ray rays[kLanes];
        for (int r = 0; r < m; ++r) rays[r] = ray_at(base + r);
        if (!coherent(rays, m)) {
            for (int r = 0; r < m; ++r) scattered.push_back(base + r);
            continue;
        }
        RaySlabs slabs[kLanes];
        double t_max[kLanes];
        bool hit[kLanes] = {};
        for (int r = 0; r < kLanes; ++r) {
            slabs[r] = RaySlabs(rays[r < m ? r : 0]);
            t_max[r] = kInf;
            lane_begin(packet_ctx[r], rays[r < m ? r : 0]);
        }
        bvh_.traverse_packet(slabs, (1u << m) - 1u, t_max, hit, packet);
        for (int r = 0; r < m; ++r) lane_finish(packet_ctx[r], base + r, hit[r], t_max[r]);
        in_packets += m;
    }
    if (scattered.empty()) return in_packets;

    struct InterleavedQuery {
        decltype(lane_test)& test_fn;
        decltype(lane_test_block)& test_block_fn;
        decltype(lane_begin)& begin_fn;
        decltype(lane_finish)& finish_fn;
        RayAt& ray_at;
        const std::vector<size_t>& index;
        const Scene& scene;
        Context ctx[kLanes];

        Ray ray(size_t k) { return ray_at(index[k]); }
        void begin(int s, size_t k) { begin_fn(ctx[s], ray_at(index[k])); }
        bool test(int s, uint32_t prim, double& t_max) { return test_fn(ctx[s], prim, t_max); }
        bool test_block(int s, uint32_t block, double& t_max) { return test_block_fn(ctx[s], block, t_max); }
        void prefetch_block(uint32_t block) { scene.prefetch_block(block); }
        void finish(int s, size_t k, bool hit, double t) { finish_fn(ctx[s], index[k], hit, t); }
    };
    InterleavedQuery query{lane_test, lane_test_block, lane_begin, lane_finish, ray_at, scattered, *this, {}};
    bvh_.traverse_interleaved<kLanes>(scattered.size(), query);
    return in_packets;
}

}  // namespace rt
