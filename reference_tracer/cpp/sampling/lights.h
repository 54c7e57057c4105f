// Light sampling: pick an emitter (area and delta lights by power, the environment - the
// constant background or an environment map - with a fixed share), then a point on it, and
// return the direction with its solid-angle density.
//
// Emitters are chosen by their power (area * luminance for area lights, in the same units
// 4 luminance(I) for a point light, the share of its cone's for a spot, R^2 luminance(E)
// for a directional light over the scene's bounding sphere of radius R); the environment,
// where there is one, takes half (all where it is the only light). Mitsuba picks uniformly
// among its emitters: the two differ in variance, never in expectation.
// Delta lights (PointLight, SpotLight, DirectionalLight, ProjectorLight: Mitsuba's point, spot,
// directional and projector) sit at one point or come from one direction: a sample of one is flagged
// `delta`, its pdf is the selection's probability alone, its radiance what arrives at the
// reference point (intensity / dist^2 times a spot's falloff; the irradiance of a
// directional light), and no other direction has any density of them (pdf_all and
// pdf_emitter ignore them): only light sampling can see them, and their samples take no
// MIS weight (as Mitsuba's ds.delta).
//
// Quads and triangles are sampled uniformly by area: pdf = dist^2 / (|cos_light| area).
// On a smooth triangle (vertex normals) cos_light and the side test take the shading normal
// at the sampled point, as Mitsuba's mesh emitters do (Mesh::sample_position interpolates
// the vertex normals; the area emitter's sample_direction and pdf_direction use it): the
// density then differs from the true one of area sampling by |cos_geometric / cos_shading|,
// which is Mitsuba's estimator and the one matched here on purpose.
// Spheres seen from outside are sampled uniformly inside the cone they subtend (every
// sample visible, no wasted back side); from inside (or the surface, e.g. a furnace),
// uniformly by area. Emission is one-sided: a sampled point seen from its back emits
// nothing, so such samples fail and their density is 0 - the same rule as Mitsuba's area
// emitter, which keeps the mixture estimator's pdf equal to the procedure's density.
#pragma once

#include <algorithm>
#include <memory>
#include <vector>

#include "../mutants.h"
#include "../shapes/quad.h"
#include "../shapes/sphere.h"
#include "../shapes/triangle.h"
#include "../texture.h"
#include "environment.h"
#include "warp.h"

namespace rt {

struct LightSample {
    Vec3 wi;            // unit direction from the reference point
    double dist = kInf; // distance to the sampled point (inf for the background)
    double pdf = 0.0;   // solid-angle density of this emitter's procedure times its selection
    Vec3 radiance;      // emitted radiance toward the reference point (delta: what arrives there)
    bool background = false;  // the environment's or a directional light's: the shadow ray is unbounded
    bool delta = false;       // a delta light's: no other technique can sample it (no MIS weight)
    bool valid = false;
};

// LightSamples of lanes of reference points (simd.h: F a pack of doubles) in
// structure-of-arrays form: the pack samplers write them as vectors, and the wavefront
// integrator finishes the next-event estimates of a pack of diffuse vertices from them
// without unpacking (PERFORMANCE.md, Ideas tried). A lane holds LightSample()'s values
// until a sample is set.
template <typename F>
struct LightSampleLanes {
    F wi[3], dist, pdf, radiance[3];
    unsigned valid = 0, background = 0, delta = 0;  // bit l: lane l's flag

    // Zeros (dist infinite), set from a register: with default member initialisers GCC
    // zeroed the arrays with `rep stos` on AVX2 targets, a microcoded start-up a pack.
    LightSampleLanes() {
        const F zero = {};
        for (int a = 0; a < 3; ++a) wi[a] = radiance[a] = zero;
        dist = broadcast<F>(kInf);
        pdf = zero;
    }

    LightSample lane(int l) const {
        LightSample ls;
        ls.wi = Vec3(wi[0][l], wi[1][l], wi[2][l]);
        ls.dist = dist[l];
        ls.pdf = pdf[l];
        ls.radiance = Vec3(radiance[0][l], radiance[1][l], radiance[2][l]);
        ls.background = (background >> l) & 1u;
        ls.delta = (delta >> l) & 1u;
        ls.valid = (valid >> l) & 1u;
        return ls;
    }
    void set_lane(int l, const LightSample& ls) {
        for (int a = 0; a < 3; ++a) {
            wi[a][l] = ls.wi[a];
            radiance[a][l] = ls.radiance[a];
        }
        dist[l] = ls.dist;
        pdf[l] = ls.pdf;
        const unsigned bit = 1u << l;
        valid = ls.valid ? valid | bit : valid & ~bit;
        background = ls.background ? background | bit : background & ~bit;
        delta = ls.delta ? delta | bit : delta & ~bit;
    }
};
using LightSamplePack = LightSampleLanes<VPd>;

// An area light's sample on lanes of type F (double: one sample), before it is stored:
// what LightSampler::area_sample computes.
template <typename F>
struct AreaSample {
    F wi[3], dist, pdf;
    unsigned valid;  // bit l: lane l's sample is valid
};

// The parameters of a sphere light on lanes of type F (one sphere per lane).
template <typename F>
struct SphereLanes {
    F center[3], radius, normal_sign;
};

// Area lights first; the delta lights after them (is_delta).
enum class EmitterKind : uint8_t { Sphere, Quad, Triangle, Point, Spot, Directional, Projector };

struct Emitter {
    EmitterKind kind;
    uint32_t prim;   // scene primitive id (area lights)
    uint32_t index;  // index into the scene's array of that kind (delta lights: of DeltaLight)
    Vec3 radiance;
};

inline bool is_delta(EmitterKind k) { return k >= EmitterKind::Point; }

// A light without extent (Mitsuba's point, spot, directional and projector emitters).
struct DeltaLight {
    EmitterKind kind = EmitterKind::Point;  // Point, Spot, Directional or Projector
    Vec3 position;   // point, spot, projector
    // spot: the axis it shines along; directional: the direction its light travels;
    // projector: its optical axis (the world image of its local +z); unit
    Vec3 direction;
    // point, spot: radiant intensity (W/sr); directional: irradiance; projector: the
    // irradiance on its image plane at z = 1 times its scale (times the texture's value)
    Vec3 intensity;
    // spot: Mitsuba's falloff (src/emitters/spot.cpp): 1 within beam_width of the axis,
    // falling linearly in the angle to 0 at cutoff_angle, 0 beyond.
    double cutoff = 0.0, beam = 0.0;          // radians, beam <= cutoff
    double cos_cutoff = -1.0, cos_beam = -1.0;
    // A textured spot's projected texture, or a projector's irradiance texture (null: a
    // constant). Shared: the scene's vector of lights copies the record, not the texels.
    std::shared_ptr<const Texture> texture;
    double texture_mean = 1.0;  // the texture's mean (luminance), for power() alone
    // World to the light's frame (rotation, row-major): Mitsuba's to_world^-1, which is
    // what both emitters map directions or points through before their uv.
    double to_local[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    // spot: tan(cutoff), Mitsuba's m_uv_factor; projector: tan(fov_x / 2).
    double uv_factor = 1.0;
    double aspect = 1.0;  // projector: its texture's width / height (Mitsuba's resolution())

    Vec3 local(const Vec3& w) const {
        return Vec3(to_local[0] * w.x + to_local[1] * w.y + to_local[2] * w.z,
                    to_local[3] * w.x + to_local[4] * w.y + to_local[5] * w.z,
                    to_local[6] * w.x + to_local[7] * w.y + to_local[8] * w.z);
    }

    double falloff(double cos_theta) const {
        if (!(cos_theta > cos_cutoff)) return 0.0;
        if (cos_theta >= cos_beam) return 1.0;
        return (cutoff - std::acos(std::min(cos_theta, 1.0))) / (cutoff - beam);
    }

    // Power / pi, in the units of the area lights' selection weight (area * luminance):
    // 4 pi I / pi for a point; 2 pi I (1 - (sin c - sin b) / (c - b)) / pi, the falloff's
    // integral over the sphere, for a spot (2 (1 - cos c) when b = c), times a textured
    // spot's texture mean (the texture's variation across the cone is not integrated: a
    // selection weight needs only to be positive where the light is); R^2 E for a
    // directional light over the disk of radius R (the scene's bounding sphere). A
    // projector sends pi scale E / cos^3 over its frustum, dw = cos^3 dA on the plane
    // z = 1: its power is pi scale mean(E) times the image plane's area 4 tan^2(fov_x / 2) / aspect.
    double power(double scene_radius) const {
        const double lum = luminance(intensity);
        switch (kind) {
            case EmitterKind::Point: return 4.0 * lum;
            case EmitterKind::Spot: {
                const double cone = cutoff > beam ? 1.0 - (std::sin(cutoff) - std::sin(beam)) / (cutoff - beam)
                                                  : 1.0 - std::cos(cutoff);
                const double p = 2.0 * lum * cone;
                return texture ? p * texture_mean : p;
            }
            case EmitterKind::Directional: return scene_radius * scene_radius * lum;
            case EmitterKind::Projector:
                return lum * texture_mean * 4.0 * uv_factor * uv_factor / aspect;
            default: return 0.0;
        }
    }
};

class LightSampler {
public:
    LightSampler() = default;
    // `emitters`: the area lights; `deltas`: the delta lights (appended to the emitters, in
    // their order); `environment`: an environment map (lit), replacing the constant
    // `background` (which must then be black); `scene_radius`: of the scene's bounding
    // sphere (a directional light's power).
    LightSampler(std::vector<Emitter> emitters, const std::vector<Sphere>* spheres,
                 const std::vector<Quad>* quads, const std::vector<Triangle>* triangles,
                 const Vec3& background, size_t prim_count,
                 const std::vector<TriangleNormals>* normals = nullptr,
                 const EnvironmentMap* environment = nullptr, const std::vector<DeltaLight>* deltas = nullptr,
                 double scene_radius = 1.0)
        : emitters_(std::move(emitters)), spheres_(spheres), quads_(quads), triangles_(triangles),
          normals_(normals), deltas_(deltas), environment_(environment), background_(background) {
        std::vector<double> power;
        for (const Emitter& e : emitters_) power.push_back(area(e) * luminance(e.radiance));
        if (deltas_ != nullptr) {
            for (uint32_t i = 0; i < deltas_->size(); ++i) {
                const DeltaLight& d = (*deltas_)[i];
                emitters_.push_back({d.kind, ~uint32_t(0), i, d.intensity});
                power.push_back(d.power(scene_radius));
            }
        }
        select_ = DiscreteDistribution(power);
        const bool has_bg = max_component(background_) > 0.0 || environment_ != nullptr;
        p_background_ = has_bg ? (select_.empty() ? 1.0 : 0.5) : 0.0;
        if (select_.empty()) emitters_.clear();
        prim_to_emitter_.assign(prim_count, -1);
        for (size_t i = 0; i < emitters_.size(); ++i)
            if (!is_delta(emitters_[i].kind)) prim_to_emitter_[emitters_[i].prim] = int32_t(i);
        only_spheres_ = !emitters_.empty() && p_background_ == 0.0 &&
                           std::all_of(emitters_.begin(), emitters_.end(),
                                       [](const Emitter& e) { return e.kind == EmitterKind::Sphere; });
        if (only_spheres_)
            for (size_t i = 0; i < emitters_.size(); ++i) {
                const Sphere& s = (*spheres_)[emitters_[i].index];
                const double fields[kSphereFields] = {s.center.x,
                                                      s.center.y,
                                                      s.center.z,
                                                      s.radius,
                                                      s.normal_sign,
                                                      select_.pmf(i) * (1.0 - p_background_),
                                                      s.area(),
                                                      emitters_[i].radiance.x,
                                                      emitters_[i].radiance.y,
                                                      emitters_[i].radiance.z};
                for (int f = 0; f < kSphereFields; ++f) sphere_fields_[f].push_back(fields[f]);
            }
    }

    bool empty() const { return emitters_.empty() && p_background_ == 0.0; }
    size_t emitter_count() const { return emitters_.size(); }
    // Density of sample() in direction wi through the environment (the constant
    // background's uniform sphere, or the environment map's distribution).
    double background_pdf(const Vec3& wi) const {
        if (environment_ != nullptr) return p_background_ * environment_->pdf(wi);
        return p_background_ * kUniformSpherePdf;
    }
    int emitter_of_prim(uint32_t prim) const { return prim < prim_to_emitter_.size() ? prim_to_emitter_[prim] : -1; }

    // M: a self-test mutant (mutants.h); Mutant::None is the tracer.
    template <Mutant M = Mutant::None>
    LightSample sample(const Vec3& ref, double u0, double u1, double u2) const {
        LightSample ls;
        if (p_background_ > 0.0 && (emitters_.empty() || u0 < p_background_)) {
            if (environment_ != nullptr) return sample_environment(u1, u2);
            ls.wi = square_to_uniform_sphere(u1, u2);
            ls.pdf = p_background_ * kUniformSpherePdf;
            ls.radiance = background_;
            ls.background = true;
            ls.valid = true;
            return ls;
        }
        if (emitters_.empty()) return ls;
        double u = p_background_ > 0.0 ? (u0 - p_background_) / (1.0 - p_background_) : u0;
        u = std::min(u, std::nextafter(1.0, 0.0));
        const size_t i = select_.sample(u);
        const Emitter& e = emitters_[i];
        const double sel = select_.pmf(i) * (1.0 - p_background_);
        if (is_delta(e.kind)) return sample_delta((*deltas_)[e.index], ref, sel);
        const double r[3] = {ref.x, ref.y, ref.z};
        double d[3], n[3], pdf_dir = 0.0;
        switch (e.kind) {
            case EmitterKind::Quad: {
                const Quad& q = (*quads_)[e.index];
                double p[3];
                q.point(u1, u2, p);
                for (int a = 0; a < 3; ++a) {
                    d[a] = p[a] - r[a];
                    n[a] = q.normal[a];
                }
                break;
            }
            case EmitterKind::Triangle: triangle_point(e, ref, u1, u2, d, n); break;
            default: sample_sphere(e, r, u1, u2, d, n, pdf_dir); break;
        }
        const AreaSample<double> t = area_sample<M>(d, n, sel, pdf_dir, area(e));
        if (t.valid == 0) return ls;
        ls.wi = Vec3(t.wi[0], t.wi[1], t.wi[2]);
        ls.dist = t.dist;
        ls.pdf = t.pdf;
        ls.radiance = e.radiance;
        ls.valid = true;
        return ls;
    }

    // Whether the scene's only light is one quad (no background): the case sample_pack
    // serves with the quad's point in every lane (every Cornell box of the suite).
    bool single_quad() const {
        return emitters_.size() == 1 && emitters_[0].kind == EmitterKind::Quad && p_background_ == 0.0;
    }
    // Whether the scene's lights are spheres (no background): the case sample_pack serves
    // with each lane's sphere (`furnace`, `glossy_plates`).
    bool only_spheres() const { return only_spheres_; }
    // Whether the scene's light sampling runs a pack at a time (sample_pack's pack bodies).
    bool packed_sampling() const { return single_quad() || only_spheres(); }

    // sample() for lanes of reference points (simd.h: F a pack of doubles, V4d or V8d), the
    // lanes of `lanes` (bits; the others' values are not used and their results are any),
    // into `out`, as constructed (the caller's storage: a returned pack was built and
    // copied again where the caller keeps several).
    // Where packed_sampling() holds, the lanes run the bodies sample() runs (Quad::point,
    // sphere_point, area_sample) on the pack, so that every lane is sample()'s result bit for
    // bit (lane-wise square root and division are IEEE like the scalar ones; a failed sample
    // is returned as LightSample(), as sample() returns it); else sample() lane by lane.
    // Always inline: out of line, the pack went back through memory (+0.5% instructions
    // on cornell_box).
    template <typename F>
    [[gnu::always_inline]] inline void sample_pack(const F (&ref)[3], const F (&u)[3], unsigned lanes,
                                                   LightSampleLanes<F>& out) const {
        if (single_quad()) {
            const Emitter& e = emitters_[0];
            const Quad& q = (*quads_)[e.index];
            F p[3], d[3], n[3], radiance[3];
            q.point(u[1], u[2], p);
            for (int a = 0; a < 3; ++a) {
                d[a] = p[a] - ref[a];
                n[a] = broadcast<F>(q.normal[a]);
            }
            const F sel = broadcast<F>(select_.pmf(0) * (1.0 - p_background_));
            broadcast_radiance(e, radiance);
            store(area_sample(d, n, sel, F{}, broadcast<F>(q.area())), radiance, all_lanes<F>(), out);
        } else if (only_spheres()) {
            sample_spheres(ref, u, lanes, out);
        } else {
            for (; lanes != 0; lanes &= lanes - 1) {
                const int l = __builtin_ctz(lanes);
                out.set_lane(l, sample(Vec3(ref[0][l], ref[1][l], ref[2][l]), u[0][l], u[1][l], u[2][l]));
            }
        }
    }

    // Density of sample() for the emitter `prim` in direction wi from ref, where the ray
    // (ref, wi) meets that emitter at `p` with front (shading) normal `n` (used for MIS
    // weights of emitters hit by BSDF sampling).
    double pdf_emitter(const Vec3& ref, const Vec3& wi, uint32_t prim, const Vec3& p, const Vec3& n) const {
        const int i = emitter_of_prim(prim);
        if (i < 0) return 0.0;
        return select_.pmf(i) * (1.0 - p_background_) * direction_pdf(emitters_[i], ref, wi, p, n);
    }

    // Total density of sample() in direction wi from ref: every emitter the line meets
    // (occluded or not) plus the background share. The `mixture` strategy needs this,
    // the density of the whole procedure.
    double pdf_all(const Vec3& ref, const Vec3& wi) const {
        double pdf = background_pdf(wi);
        const Ray r{ref, wi};
        for (size_t i = 0; i < emitters_.size(); ++i) {
            const Emitter& e = emitters_[i];
            double t;
            bool hit = false;
            Vec3 p, n;
            switch (e.kind) {
                case EmitterKind::Sphere: {
                    const Sphere& s = (*spheres_)[e.index];
                    hit = s.intersect(r, 0.0, kInf, t);
                    if (hit) s.surface(r.at(t), p, n);
                    break;
                }
                case EmitterKind::Quad: {
                    const Quad& q = (*quads_)[e.index];
                    hit = q.intersect(r, 0.0, kInf, t);
                    if (hit) { p = r.at(t); n = q.normal; }
                    break;
                }
                case EmitterKind::Triangle: {
                    const Triangle& tr = (*triangles_)[e.index];
                    hit = intersect_watertight(tr, r, WatertightRay(wi), 0.0, kInf, t);
                    if (hit) {
                        p = r.at(t);
                        n = tr.normal();
                        if (tr.normals != Triangle::kFlat) {
                            double w[3];
                            tr.barycentrics(p, w);
                            n = (*normals_)[tr.normals].at(w, n);
                        }
                    }
                    break;
                }
                default: break;  // a delta light: no direction has a density
            }
            if (hit) pdf += select_.pmf(i) * (1.0 - p_background_) * direction_pdf(e, ref, wi, p, n);
        }
        return pdf;
    }

private:
    template <typename F> static constexpr unsigned all_lanes() { return (1u << kLanesOf<F>) - 1u; }
    template <typename F> static void broadcast_radiance(const Emitter& e, F (&radiance)[3]) {
        for (int a = 0; a < 3; ++a) radiance[a] = broadcast<F>(e.radiance[a]);
    }

    // The rest of sample() on lanes of type F once a point p on an area light is drawn at
    // d = p - ref with the light's normal n there: lane l has an emitter selected with
    // probability sel, of the given area, and the solid-angle density pdf_dir of cone
    // sampling (0 where the point was sampled by area). One body for sample() (F double)
    // and the packs.
    template <Mutant M = Mutant::None, typename F>
    [[gnu::always_inline]] static AreaSample<F> area_sample(const F (&d)[3], const F (&n)[3], F sel, F pdf_dir,
                                                             F area) {
        AreaSample<F> t;
        const F dist2 = mul_add(d[2], d[2], mul_add(d[1], d[1], d[0] * d[0]));  // dot_fused(d, d)
        t.dist = sqrt_of(dist2);
        const F inv = 1.0 / t.dist;  // Vec3 / double multiplies by the reciprocal
        for (int a = 0; a < 3; ++a) t.wi[a] = d[a] * inv;
        const F cos_l = -mul_add(n[2], t.wi[2], mul_add(n[1], t.wi[1], n[0] * t.wi[0]));  // -dot_fused(n, wi)
        // Area sampling -> solid angle. A pack divides only where one of its lanes sampled
        // by area (cone sampling, the spheres' common case, has its density already).
        const auto by_area = pdf_dir == 0.0;
        if constexpr (M == Mutant::LightPdfNoJacobian) {
            t.pdf = sel * (by_area ? 1.0 / area : pdf_dir);  // seeded bug: the area density, no dist^2 / cos
        } else {
            t.pdf = sel * (lane_mask(by_area) != 0 ? (by_area ? dist2 / (cos_l * area) : pdf_dir) : pdf_dir);
        }
        // Not valid: the point is ref itself, seen from its back (one-sided emission) or
        // exactly grazing, or the density is not a positive finite number.
        t.valid = lane_mask((dist2 > 0.0) & (cos_l > 0.0) & (t.pdf > 0.0) & (t.pdf < kInf));
        return t;
    }

    // Stores an area sample t of the given radiance into the lanes of `lanes` of out (the
    // others are left as they are); a failed sample is stored as LightSample().
    template <typename F>
    static void store(const AreaSample<F>& t, const F (&radiance)[3], unsigned lanes, LightSampleLanes<F>& out) {
        const unsigned valid = t.valid & lanes;
        const auto set = lanes_of_bits<F>(lanes), good = lanes_of_bits<F>(valid);
        for (int a = 0; a < 3; ++a) {
            out.wi[a] = good ? t.wi[a] : (set ? F{} : out.wi[a]);
            out.radiance[a] = good ? radiance[a] : (set ? F{} : out.radiance[a]);
        }
        out.dist = good ? t.dist : (set ? broadcast<F>(kInf) : out.dist);
        out.pdf = good ? t.pdf : (set ? F{} : out.pdf);
        out.valid = (out.valid & ~lanes) | valid;
        out.background &= ~lanes;
        out.delta &= ~lanes;
    }

    // sample_pack where only_spheres() holds: per lane, the emitter is selected as sample()
    // does (a table walk, lane by lane; the one sphere in every lane where there is one),
    // then sphere_point and area_sample on the pack. Out of line: inlined, its two
    // bodies grew the wavefront integrator's loop past GCC's inlining budget, which then
    // left scatter_diffuse out of line in every scene (cornell_box -1.7%).
    template <typename F>
    [[gnu::noinline]] void sample_spheres(const F (&ref)[3], const F (&u)[3], unsigned lanes, LightSampleLanes<F>& out) const {
        SphereLanes<F> s;
        F sel, area, radiance[3];
        if (emitters_.size() == 1) {
            const Sphere& sphere = (*spheres_)[emitters_[0].index];
            for (int a = 0; a < 3; ++a) s.center[a] = broadcast<F>(sphere.center[a]);
            s.radius = broadcast<F>(sphere.radius);
            s.normal_sign = broadcast<F>(sphere.normal_sign);
            sel = broadcast<F>(select_.pmf(0) * (1.0 - p_background_));
            area = broadcast<F>(sphere.area());
            broadcast_radiance(emitters_[0], radiance);
        } else {
            // Each lane's emitter (every lane: the others' values are not used), then its
            // parameters read from the tables by emitter, a field at a time (glossy_plates
            // 1.012x, 1.035x in the AVX2 build, against each lane's sphere and emitter read in
            // turn; PERFORMANCE.md, Ideas tried).
            size_t index[kLanesOf<F>];
            const F below_one = broadcast<F>(std::nextafter(1.0, 0.0));
            select_.sample_lanes(below_one < u[0] ? below_one : u[0], index);  // std::min(u0, below_one)
            const auto field = [&](int f) {
                F lanes{};
                for (int l = 0; l < kLanesOf<F>; ++l) lanes[l] = sphere_fields_[f][index[l]];
                return lanes;
            };
            for (int a = 0; a < 3; ++a) {
                s.center[a] = field(kCenterX + a);
                radiance[a] = field(kRadianceR + a);
            }
            s.radius = field(kRadius);
            s.normal_sign = field(kNormalSign);
            sel = field(kSelection);
            area = field(kArea);
        }
        F d[3], n[3], pdf_dir;
        // Where every lane sampled by area (each vertex of `furnace`), the density's zero is
        // a constant: area_sample then divides in every lane without testing which (-2% on
        // `furnace` with the test).
        if (sphere_point(s, ref, u[1], u[2], lanes, d, n, pdf_dir) == lanes)
            store(area_sample(d, n, sel, F{}, area), radiance, lanes, out);
        else
            store(area_sample(d, n, sel, pdf_dir, area), radiance, lanes, out);
    }

    // A point on sphere s (lane by lane) for the reference point ref, as d = p - ref with
    // the sphere's normal n there, from the uniforms u1, u2. From inside or on the sphere,
    // uniform by area (pdf_dir 0); from outside, uniform in the subtended cone (pdf_dir its
    // solid-angle density), the point where the sampled direction first meets the sphere
    // found by its angle at the centre (pbrt-v4's and Mitsuba's formula: no division but
    // by sin^2 theta_max, and the azimuth's own sine and cosine for the point's; three
    // divisions and two square roots fewer than intersecting the sampled direction with
    // the sphere, PERFORMANCE.md, Ideas tried). A pack runs each of the two only where one of
    // `lanes` needs it. Returns the lanes sampled by area (bits). One body for sample()
    // (F double) and the packs.
    template <typename F>
    [[gnu::always_inline]] static unsigned sphere_point(const SphereLanes<F>& s, const F (&ref)[3], F u1, F u2,
                                                        unsigned lanes, F (&d)[3], F (&n)[3], F& pdf_dir) {
        F to_c[3];
        for (int a = 0; a < 3; ++a) to_c[a] = s.center[a] - ref[a];
        const F dc2 = to_c[0] * to_c[0] + to_c[1] * to_c[1] + to_c[2] * to_c[2];  // length_squared
        const F r2 = s.radius * s.radius;
        const auto inside = dc2 <= r2;
        const unsigned by_area = lane_mask(inside) & lanes;
        for (int a = 0; a < 3; ++a) d[a] = n[a] = F{};
        pdf_dir = F{};
        if (by_area != 0) {
            // p = centre + radius * dir, n = dir * normal_sign, dir uniform on the unit sphere.
            F dir[3];
            sphere_point_at_height(1.0 - 2.0 * u1, u2, dir);  // square_to_uniform_sphere
            for (int a = 0; a < 3; ++a) {
                d[a] = (s.center[a] + s.radius * dir[a]) - ref[a];
                n[a] = dir[a] * s.normal_sign;
            }
        }
        if (by_area == lanes) return by_area;
        // The cone's axis and frame (Frame(to_c / dc)).
        const F dc = sqrt_of(dc2);
        const F inv_dc = 1.0 / dc;  // Vec3 / double multiplies by the reciprocal
        F axis[3];
        for (int a = 0; a < 3; ++a) axis[a] = to_c[a] * inv_dc;
        F fs[3], ft[3];
        frame_tangents(axis, fs, ft);
        const F sin2_max = cone_sin2(r2, dc2);
        const F omc = cone_one_minus_cos(sin2_max);
        // The direction at angle theta from the axis, 1 - cos theta uniform in [0, omc]
        // (square_to_uniform_cone), and alpha, the angle at the centre between ref and the
        // point where it first meets the sphere: cos alpha = sin^2 theta / sin theta_max
        // + cos theta sqrt(1 - sin^2 theta / sin^2 theta_max).
        const F omc_theta = u1 * omc;
        const F cos_theta = 1.0 - omc_theta;
        const F q = omc_theta * (2.0 - omc_theta) / sin2_max;  // sin^2 theta / sin^2 theta_max
        const F cos_raw = mul_add(q, s.radius * inv_dc, cos_theta * safe_sqrt_of(1.0 - q));
        const F one = as_lanes(1.0, dc), minus_one = as_lanes(-1.0, dc);
        const F cos_a = cos_raw < -1.0 ? minus_one : (1.0 < cos_raw ? one : cos_raw);  // std::clamp
        const F sin_a = safe_sqrt_of(1.0 - cos_a * cos_a);
        F cy, cx;
        sincos_turn(u2, cy, cx);
        // Normal at the point, outward from the centre, on the side facing ref.
        const F v[3] = {sin_a * cx, sin_a * cy, -cos_a};
        for (int a = 0; a < 3; ++a) {
            const F outward = mul_add(axis[a], v[2], mul_add(ft[a], v[1], fs[a] * v[0]));  // Frame::to_world
            const F dp = (s.center[a] + s.radius * outward) - ref[a];
            d[a] = inside ? d[a] : dp;
            n[a] = inside ? n[a] : outward * s.normal_sign;
        }
        pdf_dir = inside ? pdf_dir : uniform_cone_pdf(omc);
        return by_area;
    }

    // sin^2 of the half-angle of the cone that a sphere of squared radius r2 subtends at
    // squared distance dc2 from its centre (at most 1), and 1 - cos of that angle from it,
    // without cancellation.
    template <typename F>
    static F cone_sin2(F r2, F dc2) {
        const F ratio = r2 / dc2;
        return ratio < 1.0 ? ratio : as_lanes(1.0, ratio);  // std::min(1.0, ratio)
    }
    template <typename F>
    static F cone_one_minus_cos(F sin2) {
        const F cos_max = safe_sqrt_of(1.0 - sin2);
        return sin2 / (1.0 + cos_max);  // 1 - cos_max
    }

    double area(const Emitter& e) const {
        switch (e.kind) {
            case EmitterKind::Sphere: return (*spheres_)[e.index].area();
            case EmitterKind::Quad: return (*quads_)[e.index].area();
            case EmitterKind::Triangle: return (*triangles_)[e.index].area();
            default: break;
        }
        return 0.0;
    }

    // sample() for the environment map (its own pdf times the environment's share).
    [[gnu::noinline]] LightSample sample_environment(double u1, double u2) const {
        LightSample ls;
        double pdf;
        if (!environment_->sample(u1, u2, ls.wi, pdf, ls.radiance)) return ls;
        ls.pdf = p_background_ * pdf;
        ls.background = true;
        ls.valid = ls.pdf > 0.0 && std::isfinite(ls.pdf);
        return ls;
    }

    // sample() for a delta light, selected with probability sel: the direction toward it
    // (or against a directional light's travel), what arrives at ref, pdf = sel.
    [[gnu::noinline]] static LightSample sample_delta(const DeltaLight& d, const Vec3& ref, double sel) {
        LightSample ls;
        ls.delta = true;
        ls.pdf = sel;
        if (!(sel > 0.0)) return ls;
        if (d.kind == EmitterKind::Directional) {
            ls.wi = -d.direction;
            ls.radiance = d.intensity;
            ls.background = true;  // no point to stop at: the shadow ray is unbounded
            ls.valid = !is_black(ls.radiance);
            return ls;
        }
        const Vec3 to = d.position - ref;
        const double dist2 = dot(to, to);
        if (!(dist2 > 0.0) || !std::isfinite(dist2)) return ls;
        ls.dist = std::sqrt(dist2);
        ls.wi = to / ls.dist;
        if (d.kind == EmitterKind::Projector) return projector(d, ref, ls);
        double falloff = 1.0;
        if (d.kind == EmitterKind::Spot) falloff = d.falloff(-dot(ls.wi, d.direction));
        ls.radiance = d.intensity * (falloff / dist2);
        // Mitsuba's spot texture: looked up where the falloff is positive, at
        // uv = 0.5 + 0.5 (x, y) / (z tan(cutoff)) of the local direction from the light.
        if (d.texture && falloff > 0.0) {
            const Vec3 l = d.local(-ls.wi);
            ls.radiance = ls.radiance * d.texture->eval(0.5 + 0.5 * l.x / (l.z * d.uv_factor),
                                                        0.5 + 0.5 * l.y / (l.z * d.uv_factor));
        }
        ls.valid = !is_black(ls.radiance) && is_finite(ls.radiance);
        return ls;
    }

    // The rest of sample_delta for a projector (Mitsuba's src/emitters/projector.cpp,
    // sample_direction): ref in the light's frame maps through the inverse perspective
    // projection to uv = (0.5 - 0.5 x / (z t), 0.5 - 0.5 aspect y / (z t)), t = tan(fov_x / 2);
    // outside [0, 1]^2 or behind it (z <= 0) it is dark. What arrives is
    // pi scale E(uv) / (z^2 cos), cos between the optical axis and the direction from the
    // light: the inverse of a perspective camera's importance, so that a constant texture
    // projected onto a plane facing it lights it evenly.
    static LightSample& projector(const DeltaLight& d, const Vec3& ref, LightSample& ls) {
        const Vec3 l = d.local(ref - d.position);
        if (!(l.z > 0.0)) return ls;
        const double u = 0.5 - 0.5 * l.x / (l.z * d.uv_factor);
        const double v = 0.5 - 0.5 * d.aspect * l.y / (l.z * d.uv_factor);
        if (!(u >= 0.0 && u <= 1.0 && v >= 0.0 && v <= 1.0)) return ls;
        const double cos_axis = -dot(d.direction, ls.wi);
        if (!(cos_axis > 0.0)) return ls;
        const Vec3 e = d.texture ? d.intensity * d.texture->eval(u, v) : d.intensity;
        ls.radiance = e * (kPi / (l.z * l.z * cos_axis));
        ls.valid = !is_black(ls.radiance) && is_finite(ls.radiance);
        return ls;
    }

    // Solid-angle density of this emitter's point sampling for the direction wi that
    // meets it at p (normal n); zero when the point is seen from its back.
    double direction_pdf(const Emitter& e, const Vec3& ref, const Vec3& wi, const Vec3& p, const Vec3& n) const {
        const double cos_l = -dot(n, wi);
        if (!(cos_l > 0.0)) return 0.0;
        if (e.kind == EmitterKind::Sphere) {
            const Sphere& s = (*spheres_)[e.index];
            const double dc2 = length_squared(s.center - ref);
            if (dc2 > s.radius * s.radius) return uniform_cone_pdf(cone_one_minus_cos(cone_sin2(s.radius * s.radius, dc2)));
        }
        const double dist2 = length_squared(p - ref);
        const double pdf = dist2 / (cos_l * area(e));
        return std::isfinite(pdf) ? pdf : 0.0;
    }

    // A point on a triangle light, as d = p - ref with the normal n there (the shading
    // normal at the sampled point on a smooth triangle).
    void triangle_point(const Emitter& e, const Vec3& ref, double u1, double u2, double (&d)[3],
                        double (&n)[3]) const {
        const Triangle& t = (*triangles_)[e.index];
        Vec3 p, nn;
        if (t.normals == Triangle::kFlat) {
            p = t.point(u1, u2);
            nn = t.normal();
        } else {
            double w[3];
            p = t.point(u1, u2, w);
            nn = (*normals_)[t.normals].at(w, t.normal());
        }
        const Vec3 dp = p - ref;
        for (int a = 0; a < 3; ++a) {
            d[a] = dp[a];
            n[a] = nn[a];
        }
    }

    // sphere_point for sample(), out of line: quads and triangles (the common emitters)
    // then inline into sample() and the integrator.
    [[gnu::noinline]] void sample_sphere(const Emitter& e, const double (&ref)[3], double u1, double u2,
                                         double (&d)[3], double (&n)[3], double& pdf_dir) const {
        const Sphere& sphere = (*spheres_)[e.index];
        const SphereLanes<double> s{{sphere.center.x, sphere.center.y, sphere.center.z}, sphere.radius,
                                    sphere.normal_sign};
        sphere_point(s, ref, u1, u2, 1u, d, n, pdf_dir);
    }

    std::vector<Emitter> emitters_;
    const std::vector<Sphere>* spheres_ = nullptr;
    const std::vector<Quad>* quads_ = nullptr;
    const std::vector<Triangle>* triangles_ = nullptr;
    const std::vector<TriangleNormals>* normals_ = nullptr;  // of smooth triangles (Triangle::normals)
    const std::vector<DeltaLight>* deltas_ = nullptr;       // the scene's delta lights (Emitter::index)
    const EnvironmentMap* environment_ = nullptr;           // the environment map, if any
    Vec3 background_;
    DiscreteDistribution select_;
    // Where only_spheres(): each emitter's sphere as sample_spheres reads it, a table a
    // field, by emitter (the selection share is select_.pmf(i) (1 - p_background_)).
    enum SphereField {
        kCenterX, kCenterY, kCenterZ, kRadius, kNormalSign, kSelection, kArea, kRadianceR, kRadianceG, kRadianceB,
        kSphereFields
    };
    std::vector<double> sphere_fields_[kSphereFields];
    std::vector<int32_t> prim_to_emitter_;
    double p_background_ = 0.0;
    bool only_spheres_ = false;  // only_spheres(), decided once
};

}  // namespace rt
