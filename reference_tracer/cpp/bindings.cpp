// Python bindings (nanobind): the compiled scene, rendering with the GIL released, and
// ray queries used by tests and benchmarks. Input arrays are validated by the Python
// layer (reference_tracer/_compile.py); the checks here guard the C++ invariants only.
#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <optional>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <type_traits>
#include <utility>

#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/optional.h>

#include "render.h"
#include "sampling_probe.h"
#include "threads.h"

namespace nb = nanobind;
using namespace nb::literals;

namespace {
#ifdef RT_MUTANTS_MODULE
// A distinct C++ type for the self-test's module: nanobind registers bound classes by C++
// type, and _core's Scene must not be bound a second time (with `mutant`) by _mutants.
namespace mutants {
#endif

using Matrix = nb::ndarray<const double, nb::ndim<2>, nb::c_contig, nb::device::cpu>;
using Vector = nb::ndarray<const double, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
using IndexVector = nb::ndarray<const int32_t, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
using Image = nb::ndarray<const float, nb::ndim<3>, nb::c_contig, nb::device::cpu>;

rt::Vec3 vec3(const Vector& a) {
    if (a.shape(0) != 3) throw std::invalid_argument("expected a 3-vector");
    return {a(0), a(1), a(2)};
}
// Three consecutive entries of row i (C-contiguous: straight from the data pointer; the
// ndarray's operator() recomputes the offset from its strides per entry, ~40
// instructions a ray in the batch queries).
rt::Vec3 row3(const Matrix& m, size_t i, size_t col) {
    const double* p = m.data() + i * m.shape(1) + col;
    return {p[0], p[1], p[2]};
}

// Rays a thread of intersect() takes at a time, at least: each chunk is ordered into
// packets on its own (Scene::packet_order).
constexpr size_t kRayChunk = 8192;

// How intersect() splits rays ray_at(0 .. n-1) into chunks: the first is [0, offset + size),
// the others [offset + j size, offset + (j + 1) size). kRayChunk rays where the rays show
// no rows. Where they come in an image's rows (looked for among the first 64k), whole
// bands of tiles, at least two, with the chunks beginning at the first whole row: chunks of
// kRayChunk would leave rows of more than ~1600 rays untiled, and cut bands in two where
// the rows' width does not divide kRayChunk.
struct RayChunks {
    size_t size = kRayChunk, offset = 0;
};
template <typename RayAt>
RayChunks ray_chunks(const rt::Scene& scene, size_t n, const RayAt& ray_at) {
    const rt::PacketOrder::Rows rows = scene.image_rows(std::min<size_t>(n, 1 << 16), ray_at);
    if (rows.width == 0) return {};
    const size_t band = rt::PacketOrder::kTileRows * rows.width;
    return {band * std::max<size_t>(2, (kRayChunk + band - 1) / band), rows.first};
}

void require_columns(const Matrix& m, size_t cols, const char* name) {
    if (m.shape(1) != cols)
        throw std::invalid_argument(std::string(name) + ": expected " + std::to_string(cols) + " columns");
}

using FloatVector = nb::ndarray<const float, nb::ndim<1>, nb::c_contig, nb::device::cpu>;

// Columns of a row of the texture table (reference_tracer/_compile.py, TEXTURE_COLUMNS):
// kind, filter (bitmap: 0 bilinear, 1 nearest), wrap (0 repeat, 1 mirror, 2 clamp), to_uv
// (6), color0 (3), color1 (3), width, height, channels, offset of the texels in `texels`.
// A mesh attribute (kind 2) uses filter for per-vertex (1) or per-face (0), width for its
// mesh's triangle count and height for the first of them.
constexpr size_t kTextureColumns = 19;

// The textures of a table of kTextureColumns columns whose bitmaps' (and mesh attributes')
// values lie in `texels`; a mesh attribute must name a range of the scene's n_triangles
// (0 where the table's textures are not on shapes: a light's).
std::vector<rt::Texture> read_texture_table(const Matrix& table, const FloatVector& texels, const std::string& name,
                                            size_t n_triangles) {
    require_columns(table, kTextureColumns, name.c_str());
    std::vector<rt::Texture> out;
    const size_t n_texels = texels.shape(0);
    for (size_t i = 0; i < table.shape(0); ++i) {
        const double* row = table.data() + i * kTextureColumns;
        rt::Texture t;
        const int kind = int(row[0]), filter = int(row[1]), wrap = int(row[2]);
        if (kind < 0 || kind > 2 || filter < 0 || filter > 1 || wrap < 0 || wrap > 2)
            throw std::invalid_argument(name + ": unknown kind, filter or wrap mode");
        t.kind = rt::TextureKind(kind);
        t.nearest = filter == 1;
        t.wrap = rt::TextureWrap(wrap);
        for (int k = 0; k < 6; ++k) t.to_uv[k] = row[3 + k];
        t.color0 = {row[9], row[10], row[11]};
        t.color1 = {row[12], row[13], row[14]};
        if (t.kind == rt::TextureKind::Bitmap) {
            const double w = row[15], h = row[16], c = row[17], offset = row[18];
            if (!(w >= 2 && h >= 2 && w <= 1e9 && h <= 1e9) || (c != 1 && c != 3) || !(offset >= 0) ||
                w != std::floor(w) || h != std::floor(h) || offset != std::floor(offset))
                throw std::invalid_argument(name + ": a bitmap needs whole sizes >= 2, 1 or 3 channels");
            const double count = w * h * c;
            if (offset + count > double(n_texels))
                throw std::invalid_argument(name + ": a bitmap's texels lie beyond `texels`");
            t.width = int(w);
            t.height = int(h);
            t.channels = int(c);
            const float* first = texels.data() + size_t(offset);
            t.texels.assign(first, first + size_t(count));
        } else if (t.kind == rt::TextureKind::MeshAttribute) {
            const double count = row[15], first_tri = row[16], c = row[17], offset = row[18];
            if (!(count >= 1 && first_tri >= 0 && offset >= 0) || (c != 1 && c != 3) ||
                count != std::floor(count) || first_tri != std::floor(first_tri) || offset != std::floor(offset) ||
                first_tri + count > double(n_triangles))
                throw std::invalid_argument(name + ": a mesh attribute needs 1 or 3 channels and a range of the "
                                            "scene's triangles");
            const double n = count * c * (filter == 1 ? 3.0 : 1.0);
            if (offset + n > double(n_texels))
                throw std::invalid_argument(name + ": a mesh attribute's values lie beyond `texels`");
            t.per_vertex = filter == 1;
            t.nearest = false;
            t.width = int(count);
            t.first_triangle = uint32_t(first_tri);
            t.channels = int(c);
            const float* first = texels.data() + size_t(offset);
            t.texels.assign(first, first + size_t(n));
        }
        out.push_back(std::move(t));
    }
    return out;
}

// The scene's textures (the Python layer's dict: `table`, `texels`, `materials`, `spheres`,
// `quads`, `triangles`, optionally `opacities`), each material's texture set in
// mats[i].texture, a masked one's opacity texture in mats[i].opacity_texture.
rt::SceneTextures read_textures(const nb::dict& d, std::vector<rt::Material>& mats, size_t n_spheres,
                                size_t n_quads, size_t n_triangles) {
    auto get = [&](const char* key) {
        if (!d.contains(key)) throw std::invalid_argument(std::string("textures: missing '") + key + "'");
        return d[key];
    };
    const Matrix table = nb::cast<Matrix>(get("table"));
    const FloatVector texels = nb::cast<FloatVector>(get("texels"));
    const IndexVector materials = nb::cast<IndexVector>(get("materials"));
    const Matrix spheres = nb::cast<Matrix>(get("spheres")), quads = nb::cast<Matrix>(get("quads")),
                 triangles = nb::cast<Matrix>(get("triangles"));
    require_columns(spheres, 9, "textures.spheres");
    require_columns(quads, 6, "textures.quads");
    require_columns(triangles, 6, "textures.triangles");
    if (table.shape(0) == 0) throw std::invalid_argument("textures: an empty table (pass none instead)");
    if (materials.shape(0) != mats.size()) throw std::invalid_argument("textures.materials: one entry per material");
    if (spheres.shape(0) != n_spheres || quads.shape(0) != n_quads || triangles.shape(0) != n_triangles)
        throw std::invalid_argument("textures: one row of texture coordinates per sphere, quad and triangle");
    rt::SceneTextures out;
    out.textures = read_texture_table(table, texels, "textures.table", n_triangles);
    for (size_t i = 0; i < mats.size(); ++i) {
        const int32_t id = materials(i);
        if (id < -1 || id >= int32_t(out.textures.size()))
            throw std::invalid_argument("textures.materials: texture index out of range");
        mats[i].texture = id;
    }
    // `opacities` (optional): each masked material's opacity texture, or -1.
    if (d.contains("opacities")) {
        const IndexVector opacities = nb::cast<IndexVector>(d["opacities"]);
        if (opacities.shape(0) != mats.size()) throw std::invalid_argument("textures.opacities: one entry per material");
        for (size_t i = 0; i < mats.size(); ++i) {
            const int32_t id = opacities(i);
            if (id < -1 || id >= int32_t(out.textures.size()))
                throw std::invalid_argument("textures.opacities: texture index out of range");
            if (id >= 0 && !mats[i].masked())
                throw std::invalid_argument("textures.opacities: an opacity texture on a material without a mask");
            mats[i].opacity_texture = id;
        }
    }
    out.spheres.resize(n_spheres);
    for (size_t i = 0; i < n_spheres; ++i)
        for (int k = 0; k < 9; ++k) out.spheres[i].m[k] = spheres(i, size_t(k));
    out.quads.resize(n_quads);
    for (size_t i = 0; i < n_quads; ++i)
        for (int k = 0; k < 2; ++k) {
            out.quads[i].a[k] = quads(i, size_t(k));
            out.quads[i].b[k] = quads(i, size_t(2 + k));
            out.quads[i].c[k] = quads(i, size_t(4 + k));
        }
    out.triangles.resize(n_triangles);
    for (size_t i = 0; i < n_triangles; ++i) {
        const double* row = triangles.data() + 6 * i;
        for (int v = 0; v < 3; ++v)
            for (int k = 0; k < 2; ++k) out.triangles[i].uv[v][k] = row[2 * v + k];
    }
    return out;
}

uint32_t material_id(double value, size_t n_materials, const char* name) {
    if (!(value >= 0.0) || value >= double(n_materials) || value != double(uint32_t(value)))
        throw std::invalid_argument(std::string(name) + ": material index out of range");
    return uint32_t(value);
}

template <typename T, typename Alloc = std::allocator<T>>
nb::ndarray<nb::numpy, T> to_numpy(std::vector<T, Alloc>&& data, std::initializer_list<size_t> shape) {
    auto* heap = new std::vector<T, Alloc>(std::move(data));
    nb::capsule owner(heap, [](void* p) noexcept { delete static_cast<std::vector<T, Alloc>*>(p); });
    return nb::ndarray<nb::numpy, T>(heap->data(), shape, owner);
}

// An allocator whose vectors leave new elements uninitialised (default-, not
// value-initialised): for outputs that the code fills entry by entry anyway, a zero fill
// first is a second pass over the memory (a quarter of a full ray query's time on 1M camera
// rays: 48 bytes a ray of hit points and normals).
template <typename T>
struct UninitialisedAllocator : std::allocator<T> {
    template <typename U>
    struct rebind { using other = UninitialisedAllocator<U>; };
    UninitialisedAllocator() = default;
    template <typename U>
    UninitialisedAllocator(const UninitialisedAllocator<U>&) noexcept {}
    template <typename U>
    void construct(U* p) noexcept { ::new (static_cast<void*>(p)) U; }
    template <typename U, typename... Args>
    void construct(U* p, Args&&... args) { ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...); }
};

class PyScene {
public:
    PyScene(const Vector& lookfrom, const Vector& lookat, const Vector& vup, double vfov, int width, int height,
            const Matrix& materials, const Matrix& spheres, const Matrix& quads, const Matrix& triangles,
            const IndexVector& triangle_materials, const Vector& background, int max_depth, int rr_depth,
            int triangle_test, const std::optional<IndexVector>& smooth_triangles,
            const std::optional<Matrix>& triangle_normals, const std::optional<Matrix>& delta_lights,
            const std::optional<Image>& environment, double environment_scale,
            const std::optional<Matrix>& environment_to_world, int projection, double view_width,
            double view_height, double aperture_radius, double focus_distance, double near_clip,
            double far_clip, const std::optional<nb::dict>& textures,
            const std::optional<nb::dict>& light_textures) {
        if (width < 1 || height < 1) throw std::invalid_argument("image size must be positive");
        if (max_depth < 1) throw std::invalid_argument("max_depth must be >= 1 here (the Python layer maps -1)");
        if (triangle_test < 0 || triangle_test > 2) throw std::invalid_argument("unknown triangle test");
        require_columns(materials, 26, "materials");
        require_columns(spheres, 6, "spheres");
        require_columns(quads, 10, "quads");
        require_columns(triangles, 9, "triangles");
        if (triangle_materials.shape(0) != triangles.shape(0))
            throw std::invalid_argument("triangle_materials: one entry per triangle expected");

        std::vector<rt::Material> mats;
        for (size_t i = 0; i < materials.shape(0); ++i) {
            rt::Material m;
            const int type = int(materials(i, 0));
            if (type < 0 || type > 8) throw std::invalid_argument("materials: unknown material type");
            m.type = rt::MaterialType(type);
            m.albedo = row3(materials, i, 1);
            m.radiance = row3(materials, i, 4);
            m.param = materials(i, 7);
            m.two_sided = materials(i, 8) != 0.0;
            m.reflects = materials(i, 9) != 0.0;
            m.schlick = materials(i, 10) != 0.0;
            const int distribution = int(materials(i, 11));
            if (distribution < 0 || distribution > 1) throw std::invalid_argument("materials: unknown distribution");
            m.distribution = rt::Distribution(distribution);
            m.fresnel.enabled = materials(i, 12) != 0.0;
            m.fresnel.eta = row3(materials, i, 13);
            m.fresnel.k = row3(materials, i, 16);
            if (m.type == rt::MaterialType::Plastic || m.type == rt::MaterialType::RoughPlastic) {
                // Plastic: int_ior / ext_ior, specular_reflectance, nonlinear (the Python
                // layer validates them; these checks keep the core's own invariants).
                const double eta = materials(i, 19);
                if (!(eta > 0.0) || !std::isfinite(eta))
                    throw std::invalid_argument("materials: plastic eta must be > 0");
                if (m.type == rt::MaterialType::RoughPlastic && (eta == 1.0 || !(m.param > 0.0)))
                    throw std::invalid_argument("materials: rough plastic needs eta != 1 and alpha > 0");
                rt::make_plastic(m, row3(materials, i, 20), eta, materials(i, 23) != 0.0);
            }
            if (m.type == rt::MaterialType::RoughDielectric) {
                // int_ior / ext_ior, in the plastics' column
                m.eta = materials(i, 19);
                if (!(m.eta > 0.0) || !std::isfinite(m.eta) || m.eta == 1.0 || !(m.param > 0.0))
                    throw std::invalid_argument("materials: rough dielectric needs eta > 0, != 1 and alpha > 0");
            }
            // Mitsuba's mask around the material above: a flag, then the opacity (the
            // constant's, clipped to [0, 1] as eval_opacity does; a texture's replaces it
            // at each hit).
            if (materials(i, 24) != 0.0) {
                if (m.type == rt::MaterialType::DiffuseLight)
                    throw std::invalid_argument("materials: a mask around an emitter is not supported");
                const double opacity = materials(i, 25);
                if (std::isnan(opacity)) throw std::invalid_argument("materials: a mask's opacity is NaN");
                m.nested = m.type;
                m.type = rt::MaterialType::Masked;
                m.opacity = std::min(1.0, std::max(0.0, opacity));
            }
            mats.push_back(m);
        }
        const size_t nm = mats.size();
        std::vector<rt::Sphere> sph;
        for (size_t i = 0; i < spheres.shape(0); ++i)
            sph.push_back({row3(spheres, i, 0), spheres(i, 3), spheres(i, 5) != 0.0 ? -1.0 : 1.0,
                           material_id(spheres(i, 4), nm, "spheres")});
        std::vector<rt::Quad> qs;
        for (size_t i = 0; i < quads.shape(0); ++i)
            qs.emplace_back(row3(quads, i, 0), row3(quads, i, 3), row3(quads, i, 6), material_id(quads(i, 9), nm, "quads"));
        std::vector<rt::Triangle> tris;
        tris.reserve(triangles.shape(0));
        for (size_t i = 0; i < triangles.shape(0); ++i)
            tris.push_back({row3(triangles, i, 0), row3(triangles, i, 3), row3(triangles, i, 6),
                            material_id(double(triangle_materials(i)), nm, "triangle_materials")});

        // Smooth shading: row k of triangle_normals holds the vertex normals (at a, b, c) of
        // triangle smooth_triangles[k]; the other triangles are flat.
        std::vector<rt::TriangleNormals> normals;
        if (smooth_triangles.has_value() != triangle_normals.has_value())
            throw std::invalid_argument("smooth_triangles and triangle_normals come together");
        if (smooth_triangles) {
            const IndexVector& index = *smooth_triangles;
            const Matrix& rows = *triangle_normals;
            require_columns(rows, 9, "triangle_normals");
            if (index.shape(0) != rows.shape(0))
                throw std::invalid_argument("triangle_normals: one row per entry of smooth_triangles expected");
            normals.reserve(index.shape(0));
            for (size_t k = 0; k < index.shape(0); ++k) {
                const int64_t i = index(k);
                if (i < 0 || size_t(i) >= tris.size())
                    throw std::invalid_argument("smooth_triangles: triangle index out of range");
                if (tris[size_t(i)].normals != rt::Triangle::kFlat)
                    throw std::invalid_argument("smooth_triangles: a triangle is listed twice");
                rt::TriangleNormals tn;
                for (int v = 0; v < 3; ++v) {
                    const rt::Vec3 n = row3(rows, k, size_t(3 * v));
                    const double len = rt::length(n);
                    if (!(len > 0.0) || !std::isfinite(len))
                        throw std::invalid_argument("triangle_normals: every normal must be finite and non-zero");
                    tn.n[v] = n / len;
                }
                tris[size_t(i)].normals = static_cast<uint32_t>(k);
                normals.push_back(tn);
            }
        }

        // Delta lights, one row each (reference_tracer/_compile.py, DELTA_LIGHT_COLUMNS): kind
        // (0 point, 1 spot, 2 directional, 3 projector), position (3), direction (3: a spot's
        // axis, the direction a directional light's light travels, a projector's optical
        // axis; unit), intensity (3: a directional light's irradiance, a projector's
        // irradiance times its scale), a spot's cutoff and beam angles (radians,
        // 0 <= beam <= cutoff <= pi, cutoff > 0); then a textured spot's or a projector's
        // texture (an index into `light_textures`, -1: none) and its mean, the rotation from
        // world to the light's frame (9, row-major), the uv factor (a spot's tan(cutoff), a
        // projector's tan(fov_x / 2)) and a projector's aspect ratio.
        std::vector<rt::DeltaLight> deltas;
        std::vector<std::shared_ptr<const rt::Texture>> light_texture_list;
        if (light_textures) {
            const nb::dict& d = *light_textures;
            if (!d.contains("table") || !d.contains("texels"))
                throw std::invalid_argument("light_textures: expected 'table' and 'texels'");
            for (rt::Texture& t : read_texture_table(nb::cast<Matrix>(d["table"]), nb::cast<FloatVector>(d["texels"]),
                                                     "light_textures.table", 0))
                light_texture_list.push_back(std::make_shared<const rt::Texture>(std::move(t)));
        }
        if (delta_lights) {
            const Matrix& rows = *delta_lights;
            require_columns(rows, 25, "delta_lights");
            for (size_t i = 0; i < rows.shape(0); ++i) {
                rt::DeltaLight d;
                const int kind = int(rows(i, 0));
                if (kind < 0 || kind > 3 || double(kind) != rows(i, 0))
                    throw std::invalid_argument("delta_lights: unknown kind");
                constexpr rt::EmitterKind kinds[] = {rt::EmitterKind::Point, rt::EmitterKind::Spot,
                                                     rt::EmitterKind::Directional, rt::EmitterKind::Projector};
                d.kind = kinds[kind];
                d.position = row3(rows, i, 1);
                d.direction = row3(rows, i, 4);
                d.intensity = row3(rows, i, 7);
                if (!rt::is_finite(d.position) || !rt::is_finite(d.intensity) || !(std::min({d.intensity.x, d.intensity.y, d.intensity.z}) >= 0.0))
                    throw std::invalid_argument("delta_lights: position and intensity must be finite, intensity >= 0");
                if (kind != 0 && !(std::abs(rt::length(d.direction) - 1.0) < 1e-9))
                    throw std::invalid_argument("delta_lights: direction must be a unit vector");
                d.cutoff = rows(i, 10);
                d.beam = rows(i, 11);
                if (kind == 1) {
                    if (!(d.beam >= 0.0 && d.beam <= d.cutoff && d.cutoff > 0.0 && d.cutoff <= rt::kPi))
                        throw std::invalid_argument("delta_lights: a spot needs 0 <= beam <= cutoff <= pi, cutoff > 0");
                    d.cos_cutoff = std::cos(d.cutoff);
                    d.cos_beam = std::cos(d.beam);
                }
                const double tex = rows(i, 12);
                if (tex != -1.0) {
                    if (kind != 1 && kind != 3)
                        throw std::invalid_argument("delta_lights: only a spot or a projector has a texture");
                    if (!(tex >= 0.0 && tex < double(light_texture_list.size())) || tex != std::floor(tex))
                        throw std::invalid_argument("delta_lights: texture index out of range of light_textures");
                    d.texture = light_texture_list[size_t(tex)];
                }
                d.texture_mean = rows(i, 13);
                for (int k = 0; k < 9; ++k) d.to_local[k] = rows(i, size_t(14 + k));
                d.uv_factor = rows(i, 23);
                d.aspect = rows(i, 24);
                if (d.texture || kind == 3) {
                    bool finite = std::isfinite(d.uv_factor) && std::isfinite(d.aspect);
                    for (double x : d.to_local) finite = finite && std::isfinite(x);
                    if (!finite || !(d.texture_mean >= 0.0) || !std::isfinite(d.texture_mean))
                        throw std::invalid_argument("delta_lights: a texture's mean must be >= 0, the frame finite");
                    if (kind == 3 && !(d.uv_factor > 0.0 && d.aspect > 0.0))
                        throw std::invalid_argument("delta_lights: a projector needs tan(fov / 2) > 0 and an aspect > 0");
                }
                deltas.push_back(d);
            }
        }
        // An environment map: (H, W, 3) linear RGB (padded as Mitsuba pads it), its scale
        // and rotation (3 x 3, map to world).
        std::unique_ptr<rt::EnvironmentMap> env;
        if (environment.has_value() != environment_to_world.has_value())
            throw std::invalid_argument("environment and environment_to_world come together");
        if (environment) {
            const Image& img = *environment;
            const Matrix& m = *environment_to_world;
            if (img.shape(2) != 3 || img.shape(1) < 2 || img.shape(0) < 3)
                throw std::invalid_argument("environment: expected an (H >= 3, W >= 2, 3) image");
            if (m.shape(0) != 3 || m.shape(1) != 3) throw std::invalid_argument("environment_to_world: expected 3 x 3");
            if (!(environment_scale >= 0.0) || !std::isfinite(environment_scale))
                throw std::invalid_argument("environment_scale must be finite and >= 0");
            const size_t n = img.shape(0) * img.shape(1) * 3;
            std::vector<float> rgb(img.data(), img.data() + n);
            for (float x : rgb)
                if (!(x >= 0.0f) || !std::isfinite(x))
                    throw std::invalid_argument("environment: every value must be finite and >= 0");
            double r[3][3];
            for (int a = 0; a < 3; ++a)
                for (int b = 0; b < 3; ++b) r[a][b] = m(a, b);
            env = std::make_unique<rt::EnvironmentMap>(std::move(rgb), int(img.shape(1)), int(img.shape(0)),
                                                       environment_scale, r);
        }
        rt::SceneTextures scene_textures;
        if (textures) scene_textures = read_textures(*textures, mats, sph.size(), qs.size(), tris.size());

        rt::SceneSettings settings;
        settings.background = vec3(background);
        settings.max_depth = max_depth;
        settings.rr_depth = rr_depth;
        settings.triangle_test = rt::TriangleTest(triangle_test);
        // The camera's options (the Python layer validates them; these checks keep the
        // core's own invariants).
        if (projection < 0 || projection > 1) throw std::invalid_argument("unknown projection");
        if (!(aperture_radius >= 0.0) || !std::isfinite(aperture_radius))
            throw std::invalid_argument("aperture_radius must be finite and >= 0");
        if (aperture_radius > 0.0 && (projection != 0 || !(focus_distance > 0.0) || !std::isfinite(focus_distance)))
            throw std::invalid_argument("a thin lens needs a perspective projection and a focus_distance > 0");
        if (!(near_clip >= 0.0) || !std::isfinite(near_clip) || !(far_clip > near_clip))
            throw std::invalid_argument("clip planes need 0 <= near_clip < far_clip");
        rt::Camera camera(vec3(lookfrom), vec3(lookat), vec3(vup), vfov, width, height);
        if (projection == 1) {
            if (!(view_width > 0.0) || !(view_height > 0.0) || !std::isfinite(view_width) || !std::isfinite(view_height))
                throw std::invalid_argument("an orthographic view needs a finite width and height > 0");
            camera = rt::Camera::orthographic(vec3(lookfrom), vec3(lookat), vec3(vup), view_width, view_height,
                                              width, height);
        }
        camera.aperture_radius = aperture_radius;
        if (aperture_radius > 0.0) camera.focus_distance = focus_distance;
        camera.near_clip = near_clip;
        camera.far_clip = far_clip;

        const auto t0 = std::chrono::steady_clock::now();
        {
            nb::gil_scoped_release release;
            scene_ = std::make_unique<rt::Scene>(camera, std::move(mats), std::move(sph), std::move(qs),
                                                 std::move(tris), settings, std::move(normals), std::move(deltas),
                                                 std::move(env), std::move(scene_textures));
        }
        build_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }

#ifdef RT_MUTANTS_MODULE
    // `mutant`: a seeded bug of the self-test (mutants.h), for benchmarks/selftest only;
    // 0 renders with the tracer itself. Only this module (reference_tracer._mutants) has it.
    nb::dict render(int spp, int strategy, uint64_t seed, int threads, nb::object progress, bool moments,
                    int integrator, int mutant, int filter, double filter_param, int direct_emitter, int direct_bsdf) {
        if (mutant < 0 || mutant >= int(rt::Mutant::Count))
            throw std::invalid_argument("mutant id out of range [0, " + std::to_string(int(rt::Mutant::Count)) + ")");
        // The seeded bugs live in the scalar integrator (Integrator<M>) only.
        if (mutant != 0 && integrator != int(rt::IntegratorKind::Scalar))
            throw std::invalid_argument("seeded bugs run in the scalar integrator only: pass integrator=1");
#else
    nb::dict render(int spp, int strategy, uint64_t seed, int threads, nb::object progress, bool moments,
                    int integrator, int filter, double filter_param, int direct_emitter, int direct_bsdf) {
#endif
        if (spp < 1) throw std::invalid_argument("spp must be >= 1");
        if (strategy < 0 || strategy > 4) throw std::invalid_argument("unknown strategy");
        if (threads < 1) throw std::invalid_argument("threads must be >= 1");
        if (integrator < 0 || integrator > 1) throw std::invalid_argument("unknown integrator");
        rt::RenderJob job;
        job.integrator = rt::IntegratorKind(integrator);
        job.scene = scene_.get();
        job.strategy = rt::Strategy(strategy);
        job.spp = spp;
        job.seed = seed;
        job.threads = threads;
        job.moments = moments;
        // filter: 0 box, 1 tent (filter_param: radius), 2 Gaussian (filter_param: standard deviation)
        if (filter < 0 || filter > 2) throw std::invalid_argument("unknown filter");
        if (filter != 0 && !(filter_param > 0.0 && filter_param < 64.0))
            throw std::invalid_argument("filter radius / standard deviation must be in (0, 64)");
        job.filter = filter == 1 ? rt::PixelFilter::tent(filter_param)
                   : filter == 2 ? rt::PixelFilter::gaussian(filter_param) : rt::PixelFilter::box();
        // Mitsuba's `direct` with these sample counts; both 0: the path integrator.
        if (direct_emitter < 0 || direct_bsdf < 0 || direct_emitter > 4096 || direct_bsdf > 4096)
            throw std::invalid_argument("direct sample counts must be in [0, 4096]");
        job.direct = rt::DirectCounts{direct_emitter, direct_bsdf};

        bool interrupted = false, callback_failed = false;
        rt::RenderOutput out;
        {
            nb::gil_scoped_release release;
            auto poll = [&](uint64_t done, uint64_t total) {
                // Once cancelled, the workers are stopping and a Python error is set: touch
                // nothing of Python again until render() returns and raises it.
                if (interrupted || callback_failed) return false;
                nb::gil_scoped_acquire acquire;
                if (PyErr_CheckSignals() != 0) {  // Ctrl-C: the KeyboardInterrupt is now set
                    interrupted = true;
                    return false;
                }
                if (!progress.is_none()) {
                    try {
                        progress(done, total);
                    } catch (nb::python_error& e) {
                        e.restore();
                        callback_failed = true;
                        return false;
                    }
                }
                return true;
            };
#ifdef RT_MUTANTS_MODULE
            out = rt::render_mutant(job, rt::Mutant(mutant), poll);
#else
            out = rt::render(job, poll);
#endif
        }
        if (interrupted || callback_failed) throw nb::python_error();
        const auto& cam = scene_->camera();
        const size_t H = size_t(cam.height), W = size_t(cam.width);
        if (!progress.is_none()) progress(W * H, W * H);
        nb::dict result;
        result["sum"] = to_numpy(std::move(out.sum), {H, W, 3});
        result["sum_sq"] = to_numpy(std::move(out.sum_sq), {H, W, 3});
        if (filter != 0) result["filtered"] = to_numpy(std::move(out.filtered), {H, W, 4});
        if (moments) {
            rt::TailMoments& tm = out.tails;
            result["d1"] = to_numpy(std::move(tm.d1), {H, W, 3});
            result["d2"] = to_numpy(std::move(tm.d2), {H, W, 3});
            result["d3"] = to_numpy(std::move(tm.d3), {H, W, 3});
            result["d4"] = to_numpy(std::move(tm.d4), {H, W, 3});
            result["max"] = to_numpy(std::move(tm.max), {H, W, 3});
        }
        result["rays"] = out.rays;
        result["nonfinite"] = out.nonfinite;
        result["seconds"] = out.seconds;
        return result;
    }

    // Closest hits of N rays: t (inf on a miss), primitive id (-1), point and front normal
    // (geometric), the shading normal where the scene has smooth triangles, the texture
    // coordinates and the material's reflectance at the hit where it has textures;
    // with `preliminary` only t and the primitive (what Mitsuba's ray_intersect_preliminary
    // gives; the batch queries then skip the point and normal).
    // `wavefront`: through Scene::intersect_batch, as the wavefront integrator asks.
    nb::dict intersect(const Matrix& origins, const Matrix& directions, bool brute_force, int threads,
                       bool batch, bool wavefront, bool preliminary) const {
        require_columns(origins, 3, "origins");
        require_columns(directions, 3, "directions");
        if (origins.shape(0) != directions.shape(0)) throw std::invalid_argument("origins and directions differ in length");
        const size_t n = origins.shape(0);
        if (threads < 1) throw std::invalid_argument("threads must be >= 1");
        // Every entry is written once, by store() (zeros for a miss's point and normal).
        // Shading normals only where the scene has smooth triangles (elsewhere the normal).
        const bool shading = !preliminary && scene_->has_shading_normals();
        // Texture coordinates and each hit's reflectance (its texture's value) where the
        // scene has textures.
        const bool textured = !preliminary && scene_->has_textures();
        std::vector<double, UninitialisedAllocator<double>> t(n), p(preliminary ? 0 : 3 * n),
            nrm(preliminary ? 0 : 3 * n), sh(shading ? 3 * n : 0), uvs(textured ? 2 * n : 0),
            refl(textured ? 3 * n : 0);
        std::vector<int64_t, UninitialisedAllocator<int64_t>> prim(n);
        auto store = [&](size_t i, bool hit, const rt::Interaction& it) {
            t[i] = hit ? it.t : rt::kInf;
            prim[i] = hit ? int64_t(it.prim) : -1;
            if (preliminary) return;
            for (int c = 0; c < 3; ++c) {
                p[3 * i + c] = hit ? it.p[c] : 0.0;
                nrm[3 * i + c] = hit ? it.n[c] : 0.0;
            }
            if (shading)
                for (int c = 0; c < 3; ++c) sh[3 * i + c] = hit ? it.ns[c] : 0.0;
            if (textured) {
                double u = 0.0, v = 0.0;
                rt::Vec3 rho(0.0);
                if (hit) {
                    scene_->texture_uv(it, u, v);
                    rho = scene_->reflectance(scene_->material(it.material), it);
                }
                uvs[2 * i] = u;
                uvs[2 * i + 1] = v;
                for (int c = 0; c < 3; ++c) refl[3 * i + c] = rho[c];
            }
        };
        // Rows of the C-contiguous (N, 3) arrays (checked above), read directly.
        const double* o_rows = origins.data();
        const double* d_rows = directions.data();
        auto ray_at = [o_rows, d_rows](size_t i) {
            const double* o = o_rows + 3 * i;
            const double* d = d_rows + 3 * i;
            return rt::Ray{{o[0], o[1], o[2]}, {d[0], d[1], d[2]}};
        };
        std::vector<size_t> packet_rays(static_cast<size_t>(threads), 0);
        auto work = [&](size_t begin, size_t end, size_t worker) {
            if (wavefront) {
                std::vector<rt::Ray> rays;
                for (size_t i = begin; i < end; ++i) rays.push_back(ray_at(i));
                std::unique_ptr<bool[]> hit(new bool[rays.size()]);
                std::vector<rt::Interaction> its(rays.size());
                std::vector<const rt::Ray*> ray_ptrs;
                std::vector<rt::Interaction*> it_ptrs;
                for (size_t k = 0; k < rays.size(); ++k) {
                    ray_ptrs.push_back(&rays[k]);
                    it_ptrs.push_back(&its[k]);
                }
                scene_->intersect_batch(rays.size(), ray_ptrs.data(), hit.get(), it_ptrs.data());
                for (size_t k = 0; k < rays.size(); ++k) store(begin + k, hit[k], its[k]);
                return;
            }
            if (batch && !brute_force) {
                packet_rays[worker] += scene_->intersect_stream(
                    end - begin, [&](size_t k) { return ray_at(begin + k); },
                    [&](size_t k, bool hit, const rt::Interaction& it) { store(begin + k, hit, it); }, preliminary);
                return;
            }
            for (size_t i = begin; i < end; ++i) {
                const rt::Ray ray = ray_at(i);
                rt::Interaction it;
                const bool hit = brute_force ? scene_->intersect_brute_force(ray, it) : scene_->intersect(ray, it);
                store(i, hit, it);
            }
        };
        // Chunks of rays (ray_chunks) handed out through an atomic counter, as the renderer
        // hands out tiles: with one fixed half per thread, camera rays left one thread idle
        // while the other finished the half of the image where the mesh is (cpu/wall 1.7-1.8
        // on two threads). Each chunk gathers its own packets (Scene::packet_order); a ray's
        // hit does not depend on its packet.
        const RayChunks chunks = batch && !brute_force && !wavefront ? ray_chunks(*scene_, n, ray_at) : RayChunks{};
        std::atomic<size_t> next_chunk{0};
        auto worker_loop = [&](size_t worker) {
            for (;;) {
                const size_t j = next_chunk.fetch_add(1, std::memory_order_relaxed);
                const size_t begin = j == 0 ? 0 : chunks.offset + j * chunks.size;
                if (begin >= n) return;
                work(begin, std::min(n, chunks.offset + (j + 1) * chunks.size), worker);
            }
        };
        const auto t0 = std::chrono::steady_clock::now();
        {
            nb::gil_scoped_release release;
            std::vector<std::thread> pool;
            // No more threads than chunks (at most n / size + 2 of them): the others would find no work.
            const int workers = static_cast<int>(std::min<size_t>(size_t(threads), n / chunks.size + 2));
            rt::start_threads(pool, workers, [&](int k) { worker_loop(static_cast<size_t>(k)); });
            for (std::thread& th : pool) th.join();
        }
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        nb::dict r;
        r["t"] = to_numpy(std::move(t), {n});
        r["prim"] = to_numpy(std::move(prim), {n});
        if (!preliminary) {
            r["point"] = to_numpy(std::move(p), {n, 3});
            r["normal"] = to_numpy(std::move(nrm), {n, 3});
            if (shading) r["shading_normal"] = to_numpy(std::move(sh), {n, 3});
            if (textured) {
                r["uv"] = to_numpy(std::move(uvs), {n, 2});
                r["reflectance"] = to_numpy(std::move(refl), {n, 3});
            }
        }
        r["seconds"] = seconds;
        size_t in_packets = 0;
        for (size_t c : packet_rays) in_packets += c;
        r["packet_rays"] = in_packets;
        r["chunk"] = chunks.size;  // rays a thread took at a time (the first: chunk_offset more)
        r["chunk_offset"] = chunks.offset;
        return r;
    }

    // The order in which intersect() gathers these rays into packets, taken as one batch
    // (intersect() hands its threads chunks of rays, ray_chunks, each ordered on its own):
    // the caller's index of each ray in gathering order, the packets' sizes, and the rows
    // found (packet_order.h; width 0: none, the rays' own order).
    nb::dict packet_order(const Matrix& origins, const Matrix& directions) const {
        require_columns(origins, 3, "origins");
        require_columns(directions, 3, "directions");
        const size_t n = origins.shape(0);
        if (directions.shape(0) != n) throw std::invalid_argument("origins and directions differ in length");
        const rt::PacketOrder order =
            scene_->packet_order(n, [&](size_t i) { return rt::Ray{row3(origins, i, 0), row3(directions, i, 0)}; });
        std::vector<int64_t> index(n), sizes;
        for (size_t k = 0; k < n; ++k) index[k] = static_cast<int64_t>(order[k]);
        order.for_each_packet([&](size_t, int m) { sizes.push_back(m); });
        const size_t packets = sizes.size();
        nb::dict r;
        r["order"] = to_numpy(std::move(index), {n});
        r["sizes"] = to_numpy(std::move(sizes), {packets});
        r["row_width"] = order.rows().width;
        r["first_row"] = order.rows().first;
        return r;
    }

    // Whether anything lies on each of N rays with t in (0, t_max): per ray
    // (Scene::occluded), or as the wavefront integrator asks (Scene::occluded_batch).
    nb::ndarray<nb::numpy, uint8_t> occluded(const Matrix& origins, const Matrix& directions, const Vector& t_max,
                                             bool wavefront) const {
        require_columns(origins, 3, "origins");
        require_columns(directions, 3, "directions");
        const size_t n = origins.shape(0);
        if (directions.shape(0) != n || t_max.shape(0) != n)
            throw std::invalid_argument("origins, directions and t_max differ in length");
        std::vector<rt::Ray> rays;
        std::vector<double> tm(n);
        for (size_t i = 0; i < n; ++i) {
            rays.push_back({row3(origins, i, 0), row3(directions, i, 0)});
            tm[i] = t_max(i);
        }
        std::unique_ptr<bool[]> occ(new bool[n]);
        if (wavefront) {
            std::vector<const rt::Ray*> ray_ptrs;
            for (const rt::Ray& r : rays) ray_ptrs.push_back(&r);
            scene_->occluded_batch(n, ray_ptrs.data(), tm.data(), occ.get());
        } else {
            for (size_t i = 0; i < n; ++i) occ[i] = scene_->occluded(rays[i], tm[i]);
        }
        std::vector<uint8_t> out(occ.get(), occ.get() + n);
        return to_numpy(std::move(out), {n});
    }

    // The closest hits of N rays (origins, directions, t_max) on each sphere and each quad
    // of the scene alone (t_min 0), through the shape's test on lanes of `width` rays (one
    // of rt::kLaneWidths: 1 is Sphere::hit / Quad::hit on one ray, more their packs, absent
    // lanes of the last pack repeating its first ray): dict `hit` (N, S + Q) uint8, `t`
    // (N, S + Q; t_max where there is no hit), the spheres' columns first, and for the
    // spheres' columns `point` and `normal` (N, S, 3), Sphere::surface_lanes at o + t d. A
    // testing seam: every width must give width 1's results.
    nb::dict shape_hits(const Matrix& origins, const Matrix& directions, const Vector& t_max, int width) const {
        require_columns(origins, 3, "origins");
        require_columns(directions, 3, "directions");
        const size_t n = origins.shape(0);
        if (directions.shape(0) != n || t_max.shape(0) != n)
            throw std::invalid_argument("origins, directions and t_max differ in length");
        const size_t spheres = scene_->sphere_count(), cols = spheres + scene_->quad_count();
        std::vector<double> t(n * cols), point(n * spheres * 3), normal(n * spheres * 3);
        std::vector<uint8_t> hit(n * cols);
        auto run = [&](auto lanes) {
            using F = decltype(lanes);
            for (size_t c = 0; c < cols; ++c) {
                if (c < spheres)
                    shape_hits_in_packs<F>(scene_->sphere(c), origins, directions, t_max, c, cols, t, hit, &point,
                                           &normal);
                else
                    shape_hits_in_packs<F>(scene_->quad(c - spheres), origins, directions, t_max, c, cols, t, hit);
            }
        };
        if (width == 1) run(double{});
        else if (width == 4) run(rt::Vd<4>{});
        else if (width == 8) run(rt::Vd<8>{});
        else throw std::invalid_argument("width must be one of LANE_WIDTHS (1, 4, 8)");
        nb::dict r;
        r["t"] = to_numpy(std::move(t), {n, cols});
        r["hit"] = to_numpy(std::move(hit), {n, cols});
        r["point"] = to_numpy(std::move(point), {n, spheres, 3});
        r["normal"] = to_numpy(std::move(normal), {n, spheres, 3});
        return r;
    }

    // The nearest watertight hit of N rays among the scene's triangles, tested one after
    // another with a shrinking t_max (`width` 1: intersect_watertight) or four at a time
    // (`width` 4: intersect_watertight4 on blocks of four consecutive triangles, the last
    // block padded with its first): dict `t` (inf on a miss) and `index` (the triangle's,
    // -1 on a miss). A testing seam: both widths must give the same hits, ties included.
    nb::dict triangle_hits(const Matrix& origins, const Matrix& directions, int width) const {
        require_columns(origins, 3, "origins");
        require_columns(directions, 3, "directions");
        const size_t n = origins.shape(0), count = scene_->triangle_count();
        if (directions.shape(0) != n) throw std::invalid_argument("origins and directions differ in length");
        if (width != 1 && width != 4) throw std::invalid_argument("width must be 1 or 4 (triangles of a block)");
        std::vector<rt::Triangle4> blocks;
        for (size_t first = 0; width == 4 && first < count; first += 4) {
            rt::Triangle4 block;
            for (int lane = 0; lane < 4; ++lane) {
                const size_t i = first + size_t(lane) < count ? first + size_t(lane) : first;
                block.set(lane, scene_->triangle(i), static_cast<uint32_t>(i));
            }
            blocks.push_back(block);
        }
        std::vector<double> t(n, rt::kInf);
        std::vector<int64_t> index(n, -1);
        for (size_t i = 0; i < n; ++i) {
            const rt::Ray ray{row3(origins, i, 0), row3(directions, i, 0)};
            const rt::WatertightRay w(ray.d);
            double best = rt::kInf, hit_t;
            if (width == 1) {
                for (size_t k = 0; k < count; ++k) {
                    if (rt::intersect_watertight(scene_->triangle(k), ray, w, 0.0, best, hit_t)) {
                        best = hit_t;
                        index[i] = int64_t(k);
                    }
                }
            } else {
                for (const rt::Triangle4& block : blocks) {
                    const int lane = rt::intersect_watertight4(block, ray, w, 0.0, best, hit_t);
                    if (lane >= 0) {
                        best = hit_t;
                        index[i] = int64_t(block.prim[lane]);
                    }
                }
            }
            t[i] = best;
        }
        nb::dict r;
        r["t"] = to_numpy(std::move(t), {n});
        r["index"] = to_numpy(std::move(index), {n});
        return r;
    }

    // Shape::hit on lanes of type F over the rows of origins and directions: column c of
    // t and hit; for a sphere, column c of point and normal (Sphere::surface_lanes).
    template <typename F, typename Shape>
    static void shape_hits_in_packs(const Shape& shape, const Matrix& origins, const Matrix& directions,
                                    const Vector& t_max, size_t c, size_t cols, std::vector<double>& t,
                                    std::vector<uint8_t>& hit, std::vector<double>* point = nullptr,
                                    std::vector<double>* normal = nullptr) {
        constexpr int kWidth = rt::kLanesOf<F>;
        const size_t n = origins.shape(0);
        for (size_t base = 0; base < n; base += kWidth) {
            const int m = static_cast<int>(std::min<size_t>(kWidth, n - base));
            F o[3], d[3], tm;
            for (int l = 0; l < kWidth; ++l) {
                const size_t i = base + size_t(l < m ? l : 0);
                for (int a = 0; a < 3; ++a) {
                    rt::set_lane(o[a], l, origins(i, a));
                    rt::set_lane(d[a], l, directions(i, a));
                }
                rt::set_lane(tm, l, t_max(i));
            }
            const unsigned met = rt::lane_mask(shape.hit(o, d, F{}, tm));
            for (int l = 0; l < m; ++l) {
                hit[(base + size_t(l)) * cols + c] = (met >> l) & 1u;
                t[(base + size_t(l)) * cols + c] = rt::lane_of(tm, l);
            }
            if constexpr (std::is_same_v<Shape, rt::Sphere>) {
                F at[3], center[3], p[3], nv[3];
                for (int a = 0; a < 3; ++a) {
                    at[a] = o[a] + tm * d[a];
                    center[a] = rt::broadcast<F>(shape.center[a]);
                }
                rt::Sphere::surface_lanes(at, center, rt::broadcast<F>(shape.radius), rt::broadcast<F>(shape.normal_sign),
                                          p, nv);
                const size_t spheres = point->size() / (3 * origins.shape(0));
                for (int l = 0; l < m; ++l)
                    for (int a = 0; a < 3; ++a) {
                        (*point)[((base + size_t(l)) * spheres + c) * 3 + size_t(a)] = rt::lane_of(p[a], l);
                        (*normal)[((base + size_t(l)) * spheres + c) * 3 + size_t(a)] = rt::lane_of(nv[a], l);
                    }
            }
        }
    }

    // LightSampler::sample_pack on packs of lanes F over the rows of refs and u.
    template <typename F>
    void sample_lights_in_packs(const Matrix& refs, const Matrix& u, std::vector<rt::LightSample>& out) const {
        constexpr int kWidth = rt::kLanesOf<F>;
        const int n = static_cast<int>(out.size());
        for (int base = 0; base < n; base += kWidth) {
            const int m = std::min(kWidth, n - base);
            F ref[3], ui[3];
            for (int l = 0; l < kWidth; ++l) {
                const size_t i = size_t(base + (l < m ? l : 0));
                for (int a = 0; a < 3; ++a) {
                    ref[a][l] = refs(i, a);
                    ui[a][l] = u(i, a);
                }
            }
            rt::LightSampleLanes<F> pack;
            scene_->lights().sample_pack(ref, ui, (1u << m) - 1u, pack);
            for (int l = 0; l < m; ++l) out[size_t(base + l)] = pack.lane(l);
        }
    }

    // Light sampling from N reference points with uniform numbers u (N, 3), `width` points
    // at a time: 1 runs LightSampler::sample() point by point (the scalar integrator's);
    // a width of rt::kLaneWidths above 1 runs LightSampler::sample_pack on packs of that
    // many lanes (the wavefront integrator's at kPackWidth), absent lanes of the last pack
    // repeating its first point. A testing seam: every width must give width 1's samples.
    nb::dict sample_lights(const Matrix& refs, const Matrix& u, int width) const {
        require_columns(refs, 3, "refs");
        require_columns(u, 3, "u");
        if (refs.shape(0) != u.shape(0)) throw std::invalid_argument("refs and u differ in length");
        const size_t n = refs.shape(0);
        std::vector<double> wi(3 * n, 0.0), pdf(n, 0.0), dist(n, 0.0), pdf_all(n, 0.0), radiance(3 * n, 0.0);
        std::vector<uint8_t> valid(n, 0), delta(n, 0);
        std::vector<rt::LightSample> samples(n);
        if (width == 1) {
            for (size_t i = 0; i < n; ++i) samples[i] = scene_->lights().sample(row3(refs, i, 0), u(i, 0), u(i, 1), u(i, 2));
        } else if (width == 4) {
            sample_lights_in_packs<rt::Vd<4>>(refs, u, samples);
        } else if (width == 8) {
            sample_lights_in_packs<rt::Vd<8>>(refs, u, samples);
        } else {
            throw std::invalid_argument("width must be one of LANE_WIDTHS (1, 4, 8)");
        }
        for (size_t i = 0; i < n; ++i) {
            const rt::Vec3 ref = row3(refs, i, 0);
            const rt::LightSample& ls = samples[i];
            valid[i] = ls.valid;
            delta[i] = ls.delta;
            if (!ls.valid) continue;
            for (int c = 0; c < 3; ++c) {
                wi[3 * i + c] = ls.wi[c];
                radiance[3 * i + c] = ls.radiance[c];
            }
            pdf[i] = ls.pdf;
            dist[i] = ls.dist;
            pdf_all[i] = scene_->lights().pdf_all(ref, ls.wi);
        }
        nb::dict r;
        r["wi"] = to_numpy(std::move(wi), {n, 3});
        r["pdf"] = to_numpy(std::move(pdf), {n});
        r["pdf_all"] = to_numpy(std::move(pdf_all), {n});
        r["dist"] = to_numpy(std::move(dist), {n});
        r["valid"] = to_numpy(std::move(valid), {n});
        r["delta"] = to_numpy(std::move(delta), {n});
        r["radiance"] = to_numpy(std::move(radiance), {n, 3});
        return r;
    }

    // The radiance that rays escaping in N directions carry (the background, or the
    // environment map's value).
    nb::ndarray<nb::numpy, double> background(const Matrix& dirs) const {
        require_columns(dirs, 3, "dirs");
        const size_t n = dirs.shape(0);
        std::vector<double> out(3 * n);
        for (size_t i = 0; i < n; ++i) {
            const rt::Vec3 L = scene_->background(rt::normalize(row3(dirs, i, 0)));
            for (int c = 0; c < 3; ++c) out[3 * i + c] = L[c];
        }
        return to_numpy(std::move(out), {n, 3});
    }

    // Density of light sampling (all emitters and the background) for N directions.
    nb::ndarray<nb::numpy, double> light_pdf(const Matrix& refs, const Matrix& dirs) const {
        require_columns(refs, 3, "refs");
        require_columns(dirs, 3, "dirs");
        if (refs.shape(0) != dirs.shape(0)) throw std::invalid_argument("refs and dirs differ in length");
        const size_t n = refs.shape(0);
        std::vector<double> pdf(n);
        for (size_t i = 0; i < n; ++i) pdf[i] = scene_->lights().pdf_all(row3(refs, i, 0), rt::normalize(row3(dirs, i, 0)));
        return to_numpy(std::move(pdf), {n});
    }

    size_t primitive_count() const { return scene_->primitive_count(); }
    size_t emitter_count() const { return scene_->lights().emitter_count(); }
    bool has_delta_lights() const { return scene_->has_delta_lights(); }
    size_t bvh_nodes() const { return scene_->bvh().node_count(); }
    int bvh_depth() const { return scene_->bvh().depth(); }
    size_t bvh_blocks() const { return scene_->bvh().blocks().size(); }
    bool bvh_float_blocks() const { return scene_->float_blocks(); }
    size_t bvh_bytes() const { return scene_->tree_bytes(); }
    double build_seconds() const { return build_seconds_; }

private:
    std::unique_ptr<rt::Scene> scene_;
    double build_seconds_ = 0.0;
};

#ifdef RT_MUTANTS_MODULE
}  // namespace mutants
using namespace mutants;
#endif
}  // namespace

#ifdef RT_MUTANTS_MODULE
// reference_tracer._mutants: the same scene and render loop with the self-test's seeded
// bugs selectable (render's `mutant`); reached only through reference_tracer.testing (the self-test).
NB_MODULE(_mutants, m) {
    m.doc() = "The C++ core built with the self-test's seeded bugs (benchmarks/selftest); not the tracer.";
    // The seeded bugs by id (index 0: "none", the tracer).
    m.def("mutant_names", []() {
        nb::list names;
        for (const char* name : rt::kMutantNames) names.append(name);
        return names;
    });
#else
NB_MODULE(_core, m) {
    m.doc() = "C++ core of reference_tracer: scene, BVH, integrator and render loop.";
#endif
    // Rays per pack of the batched scene queries (simd.h): 8 in AVX-512 builds, else 4.
    m.attr("PACK_WIDTH") = rt::kPackWidth;
    m.attr("LANE_WIDTHS") = nb::make_tuple(rt::kLaneWidths[0], rt::kLaneWidths[1], rt::kLaneWidths[2]);
    m.attr("PACKET_RAYS") = rt::kPacketRays;  // rays per packet of coherent rays in intersect()
    m.attr("RAY_CHUNK") = kRayChunk;           // rays a thread of intersect() orders into packets at a time
    // Trees above this many bytes are traversed without prefetching pushed children.
    m.attr("CACHED_TREE_BYTES") = rt::Scene::kCachedTreeBytes;
    // The order in which the traversals visit the children a ray meets in a node of the
    // wide tree: `t_near` the eight children's entry distances, `met` which of them the ray
    // meets. Returns the slots met, nearest first, twice: as the interleaved traversal's
    // sorting network orders them and as the single-ray traversal's insertion sort does
    // (the two must agree, with child_order_key as the key).
    m.def("child_visit_order", [](const nb::list& t_near, const nb::list& met) {
        if (nb::len(t_near) != rt::kWidth || nb::len(met) != rt::kWidth)
            throw std::invalid_argument("child_visit_order: t_near and met need one entry per child (8)");
        rt::WideNode node{};
        rt::V8f tn{};
        rt::V8i lanes{};
        for (int c = 0; c < rt::kWidth; ++c) {
            tn[c] = nb::cast<float>(t_near[c]);
            if (!(tn[c] >= 0.0f))
                throw std::invalid_argument("child_visit_order: entry distances are >= 0 and not NaN");
            lanes[c] = nb::cast<bool>(met[c]) ? -1 : 0;
            node.child[c] = c;
        }
        int32_t ref[rt::kWidth], count[rt::kWidth];
        float t[rt::kWidth];
        const int k = rt::far_to_near_hits(node, lanes, tn, ref, count, t);
        nb::list network, insertion;
        for (int j = k - 1; j >= 0; --j) network.append(ref[j]);
        int idx[rt::kWidth];
        const int k2 = rt::sorted_hits(rt::lane_mask(lanes), tn, idx);
        for (int j = 0; j < k2; ++j) insertion.append(idx[j]);
        return nb::make_tuple(network, insertion);
    }, "t_near"_a, "met"_a);
    nb::class_<PyScene>(m, "Scene")
        .def(nb::init<const Vector&, const Vector&, const Vector&, double, int, int, const Matrix&, const Matrix&,
                      const Matrix&, const Matrix&, const IndexVector&, const Vector&, int, int, int,
                      const std::optional<IndexVector>&, const std::optional<Matrix>&, const std::optional<Matrix>&,
                      const std::optional<Image>&, double, const std::optional<Matrix>&, int, double, double, double,
                      double, double, double, const std::optional<nb::dict>&, const std::optional<nb::dict>&>(),
             "lookfrom"_a, "lookat"_a, "vup"_a, "vfov"_a, "width"_a, "height"_a, "materials"_a, "spheres"_a,
             "quads"_a, "triangles"_a, "triangle_materials"_a, "background"_a, "max_depth"_a, "rr_depth"_a,
             "triangle_test"_a = 0, "smooth_triangles"_a = nb::none(), "triangle_normals"_a = nb::none(),
             "delta_lights"_a = nb::none(), "environment"_a = nb::none(), "environment_scale"_a = 1.0,
             "environment_to_world"_a = nb::none(), "projection"_a = 0, "view_width"_a = 0.0,
             "view_height"_a = 0.0, "aperture_radius"_a = 0.0, "focus_distance"_a = 1.0, "near_clip"_a = 0.0,
             "far_clip"_a = rt::kInf, "textures"_a = nb::none(), "light_textures"_a = nb::none())
        .def("render", &PyScene::render, "spp"_a, "strategy"_a, "seed"_a, "threads"_a, "progress"_a = nb::none(),
             "moments"_a = false, "integrator"_a = 0
#ifdef RT_MUTANTS_MODULE
             , "mutant"_a = 0
#endif
             , "filter"_a = 0, "filter_param"_a = 0.0, "direct_emitter"_a = 0, "direct_bsdf"_a = 0)
        .def("intersect", &PyScene::intersect, "origins"_a, "directions"_a, "brute_force"_a = false, "threads"_a = 1,
             "batch"_a = true, "wavefront"_a = false,
             "preliminary"_a = false)
        .def("packet_order", &PyScene::packet_order, "origins"_a, "directions"_a)
        .def("occluded", &PyScene::occluded, "origins"_a, "directions"_a, "t_max"_a, "wavefront"_a = false)
        .def("sample_lights", &PyScene::sample_lights, "refs"_a, "u"_a, "width"_a = 1)
        .def("shape_hits", &PyScene::shape_hits, "origins"_a, "directions"_a, "t_max"_a, "width"_a = 1)
        .def("triangle_hits", &PyScene::triangle_hits, "origins"_a, "directions"_a, "width"_a = 1)
        .def("light_pdf", &PyScene::light_pdf, "refs"_a, "dirs"_a)
        .def("background", &PyScene::background, "dirs"_a)
        .def_prop_ro("primitive_count", &PyScene::primitive_count)
        .def_prop_ro("emitter_count", &PyScene::emitter_count)
        .def_prop_ro("has_delta_lights", &PyScene::has_delta_lights)
        .def_prop_ro("bvh_nodes", &PyScene::bvh_nodes)
        .def_prop_ro("bvh_depth", &PyScene::bvh_depth)
        .def_prop_ro("bvh_blocks", &PyScene::bvh_blocks)
        .def_prop_ro("bvh_float_blocks", &PyScene::bvh_float_blocks)
        .def_prop_ro("bvh_bytes", &PyScene::bvh_bytes)
        .def_prop_ro("build_seconds", &PyScene::build_seconds);
    rt::register_sampling_probe(m);  // batch sampling routines for the chi-square tests
}
