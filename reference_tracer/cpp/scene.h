// The scene the integrator renders: world-space primitives, materials, a BVH over all
// primitives, the light sampler, the camera and the integrator settings.
// Primitive ids are global: spheres first, then quads, then triangles.
#pragma once

#include <algorithm>
#include <cmath>
#include <memory>
#include <optional>
#include <vector>

#include "packet_order.h"
#include "wide_bvh.h"
#include "materials/material.h"
#include "sampling/lights.h"
#include "shapes/quad.h"
#include "shapes/sphere.h"
#include "shapes/triangle.h"
#include "texture.h"

namespace rt {

// Mitsuba's perspective and orthographic sensors, the first with an optional thin lens
// (its thinlens); pixel (0, 0) is the top-left corner, +x right, +y down in the image.
enum class Projection { Perspective = 0, Orthographic = 1 };

struct Camera {
    Vec3 origin, forward, right, up;
    // Perspective: the half extents of the image plane at distance 1 (tan of half the field
    // of view); orthographic: the half extents of the view, in world units.
    double half_width = 1, half_height = 1;
    int width = 1, height = 1;
    Projection projection = Projection::Perspective;
    double aperture_radius = 0.0;  // > 0: a thin lens (perspective only)
    double focus_distance = 1.0;   // of a thin lens, along `forward`
    // Rays start on the near plane and end at the far one (distances along `forward`, as
    // Mitsuba's near_clip and far_clip); 0 and inf clip nothing.
    double near_clip = 0.0, far_clip = kInf;

    Camera() = default;
    Camera(const Vec3& lookfrom, const Vec3& lookat, const Vec3& vup, double vfov_deg, int w, int h)
        : origin(lookfrom), width(w), height(h) {
        basis(lookfrom, lookat, vup);
        half_height = std::tan(0.5 * vfov_deg * kPi / 180.0);
        half_width = half_height * double(w) / double(h);
    }
    // An orthographic camera whose view is view_width x view_height world units.
    static Camera orthographic(const Vec3& lookfrom, const Vec3& lookat, const Vec3& vup, double view_width,
                               double view_height, int w, int h) {
        Camera c;
        c.origin = lookfrom;
        c.width = w;
        c.height = h;
        c.basis(lookfrom, lookat, vup);
        c.projection = Projection::Orthographic;
        c.half_width = 0.5 * view_width;
        c.half_height = 0.5 * view_height;
        return c;
    }

    // The pinhole without clip planes: rays from the eye through the film, unbounded. Its
    // rays come from direction() alone, which the wavefront integrator runs a pack at a
    // time; every other camera goes through generate() one ray at a time.
    bool plain() const {
        return projection == Projection::Perspective && aperture_radius == 0.0 && near_clip == 0.0 &&
               far_clip == kInf;
    }
    // Whether a camera ray takes two uniform numbers for its point on the aperture (drawn
    // after the film point's two; the pinhole draws none, so its images stay as they were).
    bool thin_lens() const { return aperture_radius > 0.0; }

    // Ray through the film point (px, py), in pixel units from the top-left corner, for the
    // plain pinhole.
    Ray generate(double px, double py) const {
        Ray r{origin, Vec3()};
        direction(px, py, r.d.x, r.d.y, r.d.z);
        return r;
    }
    // Ray through the film point (px, py) of any camera, and how far it reaches (t_max: a
    // hit at or beyond it is a miss); `lens` holds the aperture's uniform numbers of a thin
    // lens (unused otherwise). The arithmetic of Mitsuba's sample_ray in double.
    Ray generate(double px, double py, const double (&lens)[2], double& t_max) const {
        if (plain()) {
            t_max = kInf;
            return generate(px, py);
        }
        const double sx = (2.0 * px / double(width) - 1.0) * half_width;
        const double sy = (1.0 - 2.0 * py / double(height)) * half_height;
        if (projection == Projection::Orthographic) {
            // The film point on the near plane, looking along `forward`.
            t_max = far_clip - near_clip;
            return Ray{origin + sx * right + sy * up + near_clip * forward, forward};
        }
        // Camera coordinates (right, up, forward): the film point's ray meets the plane in
        // focus at f * (sx, sy, 1); the ray leaves the aperture point a toward it.
        double ar = 0.0, au = 0.0, f = 1.0;
        if (thin_lens()) {
            double dx, dy;
            square_to_uniform_disk_concentric(lens[0], lens[1], dx, dy);
            // Mitsuba's camera x axis points left: its disk's x is our -right.
            ar = -aperture_radius * dx;
            au = aperture_radius * dy;
            f = focus_distance;
        }
        const double lx = f * sx - ar, ly = f * sy - au, lz = f;
        const double len = std::sqrt(lx * lx + ly * ly + lz * lz);
        const Vec3 d = normalize(lx * right + ly * up + lz * forward);
        // Clip distances are along `forward`: along the ray they are distance / cos.
        const double inv_z = len / lz;
        const double near_t = near_clip * inv_z;
        t_max = far_clip == kInf ? kInf : far_clip * inv_z - near_t;
        return Ray{origin + ar * right + au * up + near_t * d, d};
    }
    // Mitsuba's warp::square_to_uniform_disk_concentric (Shirley and Chiu's map).
    static void square_to_uniform_disk_concentric(double u1, double u2, double& x, double& y) {
        const double a = 2.0 * u1 - 1.0, b = 2.0 * u2 - 1.0;
        if (a == 0.0 && b == 0.0) {
            x = y = 0.0;
            return;
        }
        const bool quadrant_1_or_3 = std::abs(a) < std::abs(b);
        const double r = quadrant_1_or_3 ? b : a, rp = quadrant_1_or_3 ? a : b;
        double phi = 0.25 * kPi * rp / r;
        if (quadrant_1_or_3) phi = 0.5 * kPi - phi;
        x = r * std::cos(phi);
        y = r * std::sin(phi);
    }
    // The pinhole's unit direction, written once for a double and for a pack of them
    // (simd.h; the wavefront integrator starts several lanes' samples at once): every lane
    // performs the operations of normalize(forward + sx * right + sy * up) in their order.
    template <typename T>
    void direction(T px, T py, T& dx, T& dy, T& dz) const {
        const T sx = (2.0 * px / double(width) - 1.0) * half_width;
        const T sy = (1.0 - 2.0 * py / double(height)) * half_height;
        const T x = forward.x + sx * right.x + sy * up.x, y = forward.y + sx * right.y + sy * up.y,
                z = forward.z + sx * right.z + sy * up.z;
        const T inv = 1.0 / sqrt_of(x * x + y * y + z * z);  // Vec3 / double multiplies by the reciprocal
        dx = x * inv;
        dy = y * inv;
        dz = z * inv;
    }

private:
    void basis(const Vec3& lookfrom, const Vec3& lookat, const Vec3& vup) {
        forward = normalize(lookat - lookfrom);
        right = normalize(cross(forward, vup));
        up = cross(right, forward);
    }
};

struct Interaction {
    double t = kInf;
    Vec3 p;          // hit point
    Vec3 n;          // unit geometric normal of the primitive's front side (ray offsets)
    Vec3 ns;         // unit shading normal: n, or the interpolated vertex normals of a
                     // smooth triangle (BSDF frame, front side of emission and scattering)
    uint32_t prim = 0;
    uint32_t material = 0;
    bool smooth = false;  // ns comes from vertex normals (it may differ from n)
};

// A scene's textures and its primitives' texture coordinates (texture.h): one record per
// sphere, quad and triangle where `textures` is not empty; all empty in a scene without
// textures, which then stores and computes nothing for them.
struct SceneTextures {
    std::vector<Texture> textures;
    std::vector<SphereUV> spheres;
    std::vector<QuadUV> quads;
    std::vector<TriangleUV> triangles;
};

struct SceneSettings {
    Vec3 background;
    int max_depth = 50;     // path segments, as Mitsuba's path integrator counts them
    int rr_depth = -1;      // -1: no Russian roulette
    TriangleTest triangle_test = TriangleTest::Watertight;
};

class Scene {
public:
    // `normals`: the vertex normals of the smooth triangles, which refer to them by index
    // (Triangle::normals); none for a scene shaded flat.
    // `deltas`: point, spot and directional lights; `environment`: an environment map, in
    // place of the constant settings.background (which must then be black). `textures`: the
    // textures that materials refer to (Material::texture) and the primitives' texture
    // coordinates.
    Scene(Camera camera, std::vector<Material> materials, std::vector<Sphere> spheres,
          std::vector<Quad> quads, std::vector<Triangle> triangles, SceneSettings settings,
          std::vector<TriangleNormals> normals = {}, std::vector<DeltaLight> deltas = {},
          std::unique_ptr<EnvironmentMap> environment = nullptr, SceneTextures textures = {});
    // Copies would leave the light sampler pointing into the source's arrays.
    Scene(const Scene&) = delete;
    Scene& operator=(const Scene&) = delete;

    // Closest hit with t in (0, t_max).
    bool intersect(const Ray& ray, Interaction& it, double t_max = kInf) const;
    // Closest hits (t in (0, inf)) of rays ray_at(0 .. n-1), for throughput on large
    // meshes: runs of coherent rays as packets (WideBVH::traverse_packet), the others
    // interleaved (WideBVH::traverse_interleaved). done(i, hit, it) receives each result,
    // the same as intersect(ray_at(i), it) gives, but that of two triangles of the tree's
    // blocks hit at exactly one distance, a packet may report the other one (it orders a
    // node's children by the packet's nearest entry, not the ray's own); with `packets`
    // false every ray is interleaved, ties included as intersect(). With `preliminary`,
    // only it.t and it.prim are filled in (what Mitsuba's ray_intersect_preliminary
    // returns), not the point, normal and material. Returns how many rays went in packets.
    template <typename RayAt, typename Done>
    size_t intersect_stream(size_t n, RayAt&& ray_at, Done&& done, bool preliminary = false,
                            bool packets = true) const;
    // The order in which intersect_stream gathers rays ray_at(0 .. n-1) into packets: tiles
    // of an image's rows where the rays come row after row (packet_order.h).
    template <typename RayAt>
    PacketOrder packet_order(size_t n, RayAt&& ray_at) const {
        return PacketOrder(n, ray_at, coherent_at(ray_at), coherent_origin_radius_);
    }
    // The rows packet_order finds, without the order: for callers that split rays into
    // batches, so that each batch can hold whole bands of rows.
    template <typename RayAt>
    PacketOrder::Rows image_rows(size_t n, RayAt&& ray_at) const {
        return PacketOrder::find_rows(n, ray_at, coherent_at(ray_at), coherent_origin_radius_);
    }
    // Whether anything lies on the ray with t in (0, t_max) (shadow rays).
    bool occluded(const Ray& ray, double t_max = kInf) const;
    // The closest hits of *rays[0 .. n): hit[i] and *it[i] as intersect(*rays[i], *it[i])
    // gives them (of two primitives hit at exactly the same distance, either may be
    // reported). Scenes of a few dozen spheres and quads test a pack of rays (simd.h: 4,
    // or 8 with AVX-512) at a time against every primitive (the wavefront integrator's
    // batches), then any mesh through a tree of its own, the rays that may meet it
    // interleaved; others go through the scene's tree as intersect_stream. Rays and
    // hits by pointer: the wavefront integrator's lanes hold them, and copying them into
    // arrays and back cost 3% of its instructions (PERFORMANCE.md, Ideas tried).
    void intersect_batch(size_t n, const Ray* const* rays, bool* hit, Interaction* const* it) const;
    // occluded(*rays[i], t_max[i]) for i < n, into occluded[i], the same way.
    void occluded_batch(size_t n, const Ray* const* rays, const double* t_max, bool* occluded) const;
    // The same by testing every primitive (a reference for BVH tests).
    bool intersect_brute_force(const Ray& ray, Interaction& it, double t_max = kInf) const;

    const Camera& camera() const { return camera_; }
    const SceneSettings& settings() const { return settings_; }
    const Material& material(uint32_t id) const { return materials_[id]; }
    size_t material_count() const { return materials_.size(); }
    const LightSampler& lights() const { return lights_; }
    // Whether rays that escape carry light: a constant background or an environment map.
    bool has_background() const { return has_background_; }
    // The radiance an escaping ray in direction d carries (unit d; 0 where there is no
    // background).
    Vec3 background(const Vec3& d) const {
        return environment_ != nullptr ? environment_->eval(d) : settings_.background;
    }
    // Whether the scene has delta lights (point, spot, directional).
    bool has_delta_lights() const { return !deltas_.empty(); }
    const WideBVH& bvh() const { return bvh_; }
    // Whether the triangle blocks are stored in float (every vertex exactly a float).
    bool float_blocks() const { return float_blocks_; }
    // Bytes of the scene's tree: its nodes and triangle blocks (what a traversal reads).
    size_t tree_bytes() const {
        return bvh_.node_count() * sizeof(WideNode) + tri4f_.size() * sizeof(Triangle4f) +
               tri4_.size() * sizeof(Triangle4);
    }
    // Trees up to this size count as cache-resident for prefetching pushed entries
    // (WideBVH::traverse_interleaved): between the 6.5 MB of a 100k-triangle mesh, where the
    // prefetches paid, and the 20 MB of a 300k one, where they cost 15% (PERFORMANCE.md, Ideas tried).
    static constexpr size_t kCachedTreeBytes = size_t{8} << 20;
    size_t primitive_count() const { return spheres_.size() + quads_.size() + triangles_.size(); }
    size_t sphere_count() const { return spheres_.size(); }
    size_t quad_count() const { return quads_.size(); }
    size_t triangle_count() const { return triangles_.size(); }
    const Sphere& sphere(size_t i) const { return spheres_[i]; }
    const Quad& quad(size_t i) const { return quads_[i]; }
    const Triangle& triangle(size_t i) const { return triangles_[i]; }
    // Whether any triangle has vertex normals (smooth shading).
    bool has_shading_normals() const { return !normals_.empty(); }

    // Whether any material has a texture.
    bool has_textures() const { return !textures_.textures.empty(); }
    // The texture coordinates (u, v) of hit `it`, Mitsuba's parameterisation of its shape
    // (texture.h); a scene with textures only.
    void texture_uv(const Interaction& it, double& u, double& v) const;
    // The reflectance of material m at hit `it`: its texture's value there, else its albedo.
    // Only the test is inline: the lookup (scene.cpp) stays out of the integrators' loops,
    // which untextured materials run as before.
    Vec3 reflectance(const Material& m, const Interaction& it) const {
        if (__builtin_expect(!m.textured(), 1)) return m.albedo;
        return texture_value(m, it);
    }
    // The material whose BSDF scatters at hit `it`: m itself, or where m has a texture,
    // `local` made a copy of m with the texture's value there.
    const Material& shade(const Material& m, const Interaction& it, std::optional<Material>& local) const {
        if (__builtin_expect(!m.textured(), 1)) return m;
        return shade_textured(m, it, local);
    }

private:
    // m's texture at hit `it`, and m with that value in `local` (reflectance(), shade()).
    [[gnu::noinline]] Vec3 texture_value(const Material& m, const Interaction& it) const;
    // Texture t at hit `it`: a mesh attribute by the hit's triangle and barycentrics, another
    // texture at the hit's texture coordinates (u, v), computed once into them (have_uv).
    Vec3 texture_at(const Texture& t, const Interaction& it, double& u, double& v, bool& have_uv) const;
    [[gnu::noinline]] const Material& shade_textured(const Material& m, const Interaction& it,
                                                     std::optional<Material>& local) const;
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
        return float_blocks_ ? hit_block(tri4f_[block], ray, wray, t_max, best)
                             : hit_block(tri4_[block], ray, wray, t_max, best);
    }
    template <typename Block>
    static int hit_block(const Block& q, const Ray& ray, const WatertightRay& wray, double& t_max,
                         uint32_t& best) {
        double t;
        const int lane = intersect_watertight4(q, ray, wray, 0.0, t_max, t);
        if (lane < 0) return -1;
        t_max = t;
        best = q.prim[lane];
        return lane;
    }
    // Whether a packet's rays may be traced together: directions in one octant (the same
    // near and far box planes for all) and close in direction (components within half the
    // first ray's largest component of its own), origins within 1% of the scene's extent.
    // Camera rays through neighbouring pixels are; random rays almost never (one octant
    // alone: probability 8^-7 for eight). Only speed depends on it, never a result. Four
    // rays a vector, three axes, without a branch per ray: one at a time, the test cost ~25
    // instructions a camera ray.
    static bool coherent(const RayPacket& rays, double origin_radius) {
        auto first = [](const V4d& v) { return v[0] - V4d{}; };  // ray 0's component, broadcast
        auto magnitude = [](const V4d& v) { return v < 0.0 ? -v : v; };
        const double spread = 0.5 * std::max({std::abs(rays.d[0][0][0]), std::abs(rays.d[1][0][0]),
                                              std::abs(rays.d[2][0][0])});
        V4l ok = V4l{} - 1;
        for (int a = 0; a < 3; ++a) {
            const V4d d0 = first(rays.d[a][0]), o0 = first(rays.o[a][0]);
            for (int q = 0; q < RayPacket::kQuads; ++q) {
                const V4d& d = rays.d[a][q];
                // Same sign bit (as std::signbit: -0 differs from +0); NaN fails the bounds.
                const V4l same_sign = (reinterpret_cast<V4l>(d) ^ reinterpret_cast<V4l>(d0)) >= 0;
                ok &= same_sign & (magnitude(d - d0) <= spread) & (magnitude(rays.o[a][q] - o0) <= origin_radius);
            }
        }
        return lane_mask(ok) == 0xFu;
    }
    bool coherent(const RayPacket& rays) const { return coherent(rays, coherent_origin_radius_); }
    // Whether rays[0 .. m) may be one packet, and if not, why. Pads rays[m ..] with rays[0]
    // (lanes masked out) and transposes them into `packet` once they share an octant.
    enum class Coherence { kCoherent, kOctants, kIncoherent };
    [[gnu::always_inline]] Coherence packet_coherence(Ray (&rays)[kPacketRays], int m, RayPacket& packet) const {
        // Random rays mostly leave at the octant of their second ray, before the gathering.
        if (m > 1 && !same_octant(rays[0].d, rays[1].d)) return Coherence::kOctants;
        for (int r = m; r < kPacketRays; ++r) rays[r] = rays[0];
        packet = RayPacket(rays);
        return coherent(packet) ? Coherence::kCoherent : Coherence::kIncoherent;
    }
    // Whether rays ray_at(index[0 .. m)) may be one packet, as PacketOrder asks.
    template <typename RayAt>
    auto coherent_at(RayAt& ray_at) const {
        return [this, &ray_at](const size_t* index, int m) {
            Ray rays[kPacketRays];
            for (int r = 0; r < m; ++r) rays[r] = ray_at(index[r]);
            RayPacket packet;
            return packet_coherence(rays, m, packet) == Coherence::kCoherent;
        };
    }
    // Whether two directions lie in one octant (the same sign bits): random rays mostly fail
    // it at their second ray, before a packet's rays are gathered for coherent().
    static bool same_octant(const Vec3& a, const Vec3& b) {
        const V4d a4 = {a.x, a.y, a.z, a.z}, b4 = {b.x, b.y, b.z, b.z};
        return lane_mask(reinterpret_cast<V4l>(a4) ^ reinterpret_cast<V4l>(b4)) == 0;
    }
    void prefetch_block(uint32_t block) const {
        if (float_blocks_) {
            prefetch_lines(&tri4f_[block]);
        } else {
            prefetch_lines(&tri4_[block]);
        }
    }
    // hit_block and prefetch_block for the blocks of mesh_bvh_.
    int hit_mesh_block(uint32_t block, const Ray& ray, const WatertightRay& wray, double& t_max,
                       uint32_t& best) const {
        return float_blocks_ ? hit_block(mesh_tri4f_[block], ray, wray, t_max, best)
                             : hit_block(mesh_tri4_[block], ray, wray, t_max, best);
    }
    void prefetch_mesh_block(uint32_t block) const {
        if (float_blocks_) {
            prefetch_lines(&mesh_tri4f_[block]);
        } else {
            prefetch_lines(&mesh_tri4_[block]);
        }
    }
    template <typename Block>
    static void prefetch_lines(const Block* block) {
        const char* p = reinterpret_cast<const char*>(block);
        for (size_t line = 0; line < sizeof(Block); line += 64) __builtin_prefetch(p + line);
    }
    // The closest hit of a ray so far: its primitive, and the block and lane when it came
    // from a block (its data is then in cache, the triangle array would be a miss on
    // large meshes).
    struct ClosestHit {
        uint32_t prim = 0;
        int32_t block = -1;
        int lane = 0;
    };
    // hit_primitive / hit_block for closest-hit queries, recording where the hit came from.
    // Exact ties go to the lower primitive id, as in the loops that test primitives in id
    // order (the direct path, intersect_batch's packs, brute force): a primitive of lower
    // id than the best so far is accepted at t_max itself (the test's bound is the next
    // double up), so the tree's visiting order never decides which of two primitives at
    // one distance (coplanar faces, a box standing on a floor) is reported. Triangles'
    // ids follow every sphere's and quad's, so a block (strict bound) loses a tie to them
    // whichever is met first; ties between triangles of blocks go to the tree's order.
    bool closest_primitive(uint32_t prim, const Ray& ray, const WatertightRay& wray, double& t_max,
                           ClosestHit& best) const {
        double bound = prim < best.prim ? next_up(t_max) : t_max;
        if (!hit_primitive(prim, ray, wray, bound, best.prim)) return false;
        t_max = bound;
        best.block = -1;
        return true;
    }
    bool closest_block(uint32_t block, const Ray& ray, const WatertightRay& wray, double& t_max,
                       ClosestHit& best) const {
        const int lane = hit_block(block, ray, wray, t_max, best.prim);
        if (lane < 0) return false;
        best.block = static_cast<int32_t>(block);
        best.lane = lane;
        return true;
    }
    void fill_interaction(const Ray& ray, double t, uint32_t prim, Interaction& it) const;
    // fill_interaction for the lanes of `lanes` (bits) of a pack of rays whose hits are all
    // spheres' (prim: the sphere's id, t: the distance), lane-wise and bit for bit; lane l's
    // interaction is *it[l].
    void fill_sphere_pack(const RayPack& r, VPd t, VPl prim, unsigned lanes, Interaction* const* it) const;
    // The interaction of a closest hit at distance t.
    void fill_hit(const Ray& ray, double t, const ClosestHit& best, Interaction& it) const {
        if (best.block >= 0) {
            it.t = t;
            it.prim = best.prim;
            fill_triangle(ray, t, float_blocks_ ? tri4f_[best.block].triangle(best.lane)
                                                : tri4_[best.block].triangle(best.lane), it);
            if (!normals_.empty()) shade_smooth(it);
        } else {
            fill_interaction(ray, t, best.prim, it);
        }
    }
    static void fill_triangle(const Ray& ray, double t, const Triangle& tri, Interaction& it);
    // The shading normal of a triangle hit (it.prim, it.p) where the triangle has vertex
    // normals; leaves a flat triangle's hit as fill_triangle made it.
    void shade_smooth(Interaction& it) const {
        const Triangle& tri = triangles_[it.prim - tri_base_];
        if (tri.normals == Triangle::kFlat) return;
        double w[3];
        tri.barycentrics(it.p, w);
        it.ns = normals_[tri.normals].at(w, it.n);
        it.smooth = true;
    }

    Camera camera_;
    std::vector<Material> materials_;
    std::vector<Sphere> spheres_;
    std::vector<Quad> quads_;
    std::vector<Triangle> triangles_;
    std::vector<TriangleNormals> normals_;  // of the smooth triangles (Triangle::normals)
    SceneTextures textures_;
    SceneSettings settings_;
    WideBVH bvh_;
    // Scenes of at most kDirectTestLimit spheres and quads skip the tree (see the constructor).
    static constexpr size_t kDirectTestLimit = 2;
    bool direct_ = false;
    // Batched queries (intersect_batch, occluded_batch) test a pack of rays at once against
    // every sphere and quad where there are at most kBatchTestLimit of them
    // (batch_direct_), and then any triangles through a tree of their own (mesh_bvh_, with
    // its blocks in mesh_tri4_ / mesh_tri4f_), built where there are at most
    // kMeshTreeLimit (a second tree costs memory: about 100 bytes a triangle); batch_direct_
    // is false where either limit is passed, and the queries then go through the tree of
    // all primitives, the batch's rays interleaved.
    // 32: callgrind, cornell_box plus n small boxes, 32x32, 16 spp, `mis`: with 36 quads
    // the packs and the tree cost the same (131 M vs 133 M instructions), with 48 the packs
    // 17% more, with 18 (cornell_box) 28% less.
    static constexpr size_t kBatchTestLimit = 32;
    static constexpr size_t kMeshTreeLimit = 1u << 18;
    bool batch_direct_ = false;
    // The batched queries' quads, in id order, as runs of consecutive quads: a boxed run (a
    // Box's six faces, say) is tested only where a lane of the pack may meet its padded
    // bounds, the others always (choose_quad_runs). Skipping a run changes no result: its
    // quads could not have hit those lanes, and the rest keep their order.
    struct QuadRun {
        uint32_t first = 0, count = 0;
        bool boxed = false;
        AABB bounds;  // padded like mesh_bounds_ (boxed runs only)
    };
    std::vector<QuadRun> quad_runs_;
    void choose_quad_runs(const AABB& world);
    // Whether a pack's slab test is ever needed (a boxed run, or mesh_bvh_'s bounds).
    bool pack_slabs_ = false;
    WideBVH mesh_bvh_;
    AABB mesh_bounds_;  // of mesh_bvh_'s triangles, padded (culls its descents a pack at a time)
    std::vector<Triangle4> mesh_tri4_;
    std::vector<Triangle4f> mesh_tri4f_;
    // The part of a batched query after the direct tests: the triangles of mesh_bvh_ for
    // the rays rays[index[0 .. count)), interleaved (WideBVH::traverse_interleaved), each
    // below its closest hit so far: t_max and best at index[k] that ray's distance and
    // primitive, in and out, found set where the mesh holds a closer hit. Shadow rays:
    // occlusions<true>.
    void closest_mesh_hits(size_t count, const size_t* index, const Ray* const* rays, double* t_max,
                           uint32_t* best, bool* found) const;
    // Bytes of mesh_bvh_ and its blocks (as tree_bytes for the main tree: whether its
    // traversals prefetch pushed entries).
    size_t mesh_tree_bytes() const {
        return mesh_bvh_.node_count() * sizeof(WideNode) + mesh_tri4f_.size() * sizeof(Triangle4f) +
               mesh_tri4_.size() * sizeof(Triangle4);
    }
    // Whether something of the main tree (kMesh false: as occluded()) or of mesh_bvh_ (true)
    // lies on each ray rays[i], t in (0, t_max[i]), for i = index[0 .. count) (index null:
    // 0 .. count), the rays interleaved: occluded[i] set where it does.
    template <bool kMesh>
    void occlusions(size_t count, const size_t* index, const Ray* const* rays, const double* t_max,
                    bool* occluded) const;
    // The BVH's block leaves (watertight test only), in block order: in float when every
    // triangle vertex is exactly a float (float_blocks_), else in double.
    std::vector<Triangle4> tri4_;
    std::vector<Triangle4f> tri4f_;
    bool float_blocks_ = false;
    std::vector<DeltaLight> deltas_;
    std::unique_ptr<EnvironmentMap> environment_;  // null: none, or an unlit map
    bool has_background_ = false;
    LightSampler lights_;
    uint32_t quad_base_ = 0, tri_base_ = 0;
    double coherent_origin_radius_ = 0.0;  // 1% of the diagonal of the scene's bounds
};

template <typename RayAt, typename Done>
size_t Scene::intersect_stream(size_t n, RayAt&& ray_at, Done&& done, bool preliminary, bool packets) const {
    constexpr int kLanes = kWidth;
    // Per lane: the ray and what intersect() keeps in locals.
    struct Context {
        Ray ray;
        WatertightRay wray;
        ClosestHit best;
    };
    auto lane_begin = [&](Context& c, const Ray& ray) -> const Ray& {
        c = Context{ray, triangles_.empty() ? WatertightRay() : WatertightRay(ray.d), ClosestHit{}};
        return c.ray;
    };
    auto lane_finish = [&](const Context& c, size_t i, bool hit, double t) {
        Interaction it;
        if (hit && preliminary) {
            it.t = t;
            it.prim = c.best.prim;
        } else if (hit) {
            fill_hit(c.ray, t, c.best, it);
        }
        done(i, hit, it);
    };
    // The tests of one lane, for either traversal.
    struct LaneTests {
        const Scene& scene;
        Context* ctx;
        bool test(int s, uint32_t prim, double& t_max) {
            return scene.closest_primitive(prim, ctx[s].ray, ctx[s].wray, t_max, ctx[s].best);
        }
        bool test_block(int s, uint32_t block, double& t_max) {
            return scene.closest_block(block, ctx[s].ray, ctx[s].wray, t_max, ctx[s].best);
        }
        void prefetch_block(uint32_t block) { scene.prefetch_block(block); }
    };

    // Runs of kPacketRays consecutive rays that are coherent go through the BVH as packets;
    // the rest are traced one ray per lane, interleaved.
    Context packet_ctx[kPacketRays];
    LaneTests packet{*this, packet_ctx};
    // The rays traced one per lane, by index: written in place, left uninitialised until
    // then (push_back was left out of line, a call per ray). Without packets, all of them
    // in order (no index).
    const std::unique_ptr<size_t[]> scattered(packets ? new size_t[n] : nullptr);
    size_t n_scattered = packets ? 0 : n;
    size_t in_packets = 0;
    if (packets) {
        const PacketOrder order = packet_order(n, ray_at);
        // Traces the rays ray_at(order[k .. k + m)) as one packet if they are coherent (and
        // returns kCoherent); otherwise traces nothing and says why.
        auto trace_packet = [&](size_t k, int m) [[gnu::always_inline]] {
            Ray rays[kPacketRays];
            for (int r = 0; r < m; ++r) rays[r] = ray_at(order[k + r]);
            RayPacket packet_rays;
            const Coherence why = packet_coherence(rays, m, packet_rays);
            if (why != Coherence::kCoherent) return why;
            // The per-ray constants four rays at a time (PacketSlabs, WatertightRays4).
            const PacketSlabs slabs(packet_rays);
            double t_max[kPacketRays];
            bool hit[kPacketRays] = {};
            for (int q = 0; q < RayPacket::kQuads; ++q) {
                const Ray* four = rays + 4 * q;
                const WatertightRays4 wrays =
                    triangles_.empty() ? WatertightRays4()
                                       : WatertightRays4(packet_rays.d[0][q], packet_rays.d[1][q], packet_rays.d[2][q]);
                for (int i = 0; i < 4; ++i) {
                    Context& c = packet_ctx[4 * q + i];
                    c.ray = four[i];
                    c.wray = wrays.lane(i);
                    c.best = ClosestHit{};
                    t_max[4 * q + i] = kInf;
                }
            }
            bvh_.traverse_packet(slabs, (1u << m) - 1u, t_max, hit, packet);
            for (int r = 0; r < m; ++r) lane_finish(packet_ctx[r], order[k + r], hit[r], t_max[r]);
            in_packets += static_cast<size_t>(m);
            return Coherence::kCoherent;
        };
        order.for_each_packet([&](size_t k, int m) {
            const Coherence whole = trace_packet(k, m);
            if (whole == Coherence::kCoherent) return;
            // Sixteen rays in one octant but not coherent as a whole (camera rays across the
            // end of an image row, say) may be as two halves of eight, each a packet of its
            // own. Random rays, which mostly fail at the octants, are not tried again.
            constexpr int kHalf = kPacketRays / 2;
            const bool halves = kPacketRays > 8 && m > kHalf && whole == Coherence::kIncoherent;
            for (int h = 0; h < m; h += kHalf) {
                const int mh = std::min(kHalf, m - h);
                if (halves && trace_packet(k + h, mh) == Coherence::kCoherent) continue;
                for (int r = 0; r < mh; ++r) scattered[n_scattered++] = order[k + h + r];
            }
        });
    }
    if (n_scattered == 0) return in_packets;

    struct InterleavedQuery : LaneTests {
        decltype(lane_begin)& begin_fn;
        decltype(lane_finish)& finish_fn;
        RayAt& ray_at;
        const size_t* index;

        size_t at(size_t k) const { return index != nullptr ? index[k] : k; }
        const Ray& begin(int s, size_t k) { return begin_fn(this->ctx[s], ray_at(at(k))); }
        double t_start(size_t) const { return kInf; }
        void finish(int s, size_t k, bool hit, double t) { finish_fn(this->ctx[s], at(k), hit, t); }
    };
    Context interleaved_ctx[kLanes];
    InterleavedQuery query{{*this, interleaved_ctx}, lane_begin, lane_finish, ray_at, scattered.get()};
    if (tree_bytes() <= kCachedTreeBytes) {
        bvh_.traverse_interleaved<kLanes, true>(n_scattered, query);
    } else {
        bvh_.traverse_interleaved<kLanes, false>(n_scattered, query);
    }
    return in_packets;
}

}  // namespace rt
