// Textures of reflectances (Mitsuba `checkerboard` and `bitmap`, src/textures/*.cpp), looked
// up at a hit's texture coordinates (Scene::texture_uv) after the texture's to_uv map, and
// Mitsuba's `mesh_attribute` (a mesh's per-vertex or per-face values, looked up by the hit's
// triangle and barycentrics instead: Texture::attribute). The
// Python layer (reference_tracer/image_files.py, bitmap.py) decodes image files into the linear texel
// values Mitsuba stores (8-bit sRGB texels decoded one by one, EXR as it is) and validates
// every parameter; this is the lookup alone.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "math.h"

namespace rt {

enum class TextureKind : int { Checkerboard = 0, Bitmap = 1, MeshAttribute = 2 };
enum class TextureWrap : int { Repeat = 0, Mirror = 1, Clamp = 2 };

struct Texture {
    TextureKind kind = TextureKind::Checkerboard;
    // to_uv: u' = m[0] u + m[1] v + m[2], v' = m[3] u + m[4] v + m[5].
    double to_uv[6] = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0};
    Vec3 color0, color1;  // checkerboard
    // Bitmap: height rows (row 0 the image's top, at v = 0) of width texels of `channels`
    // (1 or 3) linear values; at least 2 x 2 (the Python layer pads smaller images).
    int width = 0, height = 0, channels = 0;
    bool nearest = false;  // filter_type nearest; else bilinear
    TextureWrap wrap = TextureWrap::Repeat;
    std::vector<float> texels;
    // MeshAttribute: bound to one mesh, the scene's triangles [first_triangle, first_triangle +
    // width); texels hold, per triangle, its three corners' values in the core's corner order
    // (vertex attributes) or its one value (face attributes), `channels` (1 or 3) each, the
    // texture's scale already applied.
    uint32_t first_triangle = 0;
    bool per_vertex = false;

    Vec3 eval(double u, double v) const {
        const double x = to_uv[0] * u + to_uv[1] * v + to_uv[2];
        const double y = to_uv[3] * u + to_uv[4] * v + to_uv[5];
        if (kind == TextureKind::Checkerboard) {
            // color0 where both fractional parts are above one half or neither is.
            const bool ux = x - std::floor(x) > 0.5, uy = y - std::floor(y) > 0.5;
            return ux == uy ? color0 : color1;
        }
        return lookup(x, y);
    }

    // A mesh attribute at triangle `tri` (the scene's index) with corner weights w (Mitsuba's
    // eval_attribute: the corners' values weighted by the barycentrics, or the face's value).
    // A triangle of another mesh (which the Python layer never binds) reads 0.
    Vec3 attribute(uint32_t tri, const double w[3]) const {
        if (tri < first_triangle || tri - first_triangle >= uint32_t(width)) return Vec3(0.0);
        const size_t i = tri - first_triangle, c = size_t(channels);
        if (!per_vertex) return value(texels.data() + i * c);
        const float* t = texels.data() + i * 3 * c;
        return value(t + 2 * c) * w[2] + (value(t + c) * w[1] + value(t) * w[0]);
    }

private:
    Vec3 value(const float* t) const {
        return channels == 1 ? Vec3(double(t[0])) : Vec3(double(t[0]), double(t[1]), double(t[2]));
    }
    // An integer texel coordinate mapped into [0, res) as Dr.Jit's tex_wrap does it.
    int64_t wrap_index(int64_t p, int64_t res) const {
        if (wrap == TextureWrap::Clamp) return p < 0 ? 0 : (p >= res ? res - 1 : p);
        const int64_t shifted = p < 0 ? p + 1 : p;
        const int64_t div = shifted / res;  // truncates toward zero
        int64_t mod = p - div * res;
        if (mod < 0) mod += res;
        if (wrap == TextureWrap::Mirror && !(((div & 1) == 0) != (p < 0))) mod = res - 1 - mod;
        return mod;
    }
    Vec3 texel(int64_t ix, int64_t iy) const {
        const float* t = texels.data() + (size_t(wrap_index(iy, height)) * size_t(width) +
                                          size_t(wrap_index(ix, width))) * size_t(channels);
        return channels == 1 ? Vec3(double(t[0])) : Vec3(double(t[0]), double(t[1]), double(t[2]));
    }
    // A coordinate in texels brought near the image where it is too large for the integer
    // texel index, without changing the lookup: by whole periods of the pattern (two images
    // for mirror), or for clamp to just beyond the edge (the edge texel either way).
    double tame(double p, int64_t res) const {
        constexpr double kLimit = 1e15;
        if (std::abs(p) < kLimit) return p;
        if (wrap == TextureWrap::Clamp) return p < 0.0 ? -2.0 : double(res) + 2.0;
        return std::fmod(p, 2.0 * double(res));
    }
    Vec3 lookup(double x, double y) const {
        if (!std::isfinite(x) || !std::isfinite(y)) return Vec3(0.0);
        const double px = x * width, py = y * height;
        if (nearest) return texel(int64_t(std::floor(tame(px, width))), int64_t(std::floor(tame(py, height))));
        // Bilinear: texel centres at half-integers (Mitsuba's fmadd(uv, res, -0.5)).
        const double fx = tame(px, width) - 0.5, fy = tame(py, height) - 0.5;
        const double x0 = std::floor(fx), y0 = std::floor(fy);
        const double wx1 = fx - x0, wy1 = fy - y0, wx0 = 1.0 - wx1, wy0 = 1.0 - wy1;
        const int64_t ix = int64_t(x0), iy = int64_t(y0);
        // The four corners in Dr.Jit's order, each weight wx * wy, summed as it sums them.
        Vec3 out = texel(ix, iy) * (wx0 * wy0);
        out = texel(ix + 1, iy) * (wx1 * wy0) + out;
        out = texel(ix, iy + 1) * (wx0 * wy1) + out;
        out = texel(ix + 1, iy + 1) * (wx1 * wy1) + out;
        return out;
    }
};

// How a shape's hits get their texture coordinates (Mitsuba's parameterisations), one
// record per primitive where the scene has textures (Scene::texture_uv).
// Sphere: the unit direction in the sphere's own frame is local = m (p - center) (m: the
// transform's rotation, transposed, over the radius); u = phi / 2 pi (phi in [0, 2 pi)),
// v = theta / pi, Mitsuba's spherical angles of local.
struct SphereUV {
    double m[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
};
// Quad: uv = a + s b + t c at p = Q + s u + t v (the core's u and v).
struct QuadUV {
    double a[2] = {0, 0}, b[2] = {1, 0}, c[2] = {0, 1};
};
// Triangle: the texture coordinates of its corners a, b, c, interpolated by the barycentrics.
struct TriangleUV {
    double uv[3][2] = {{0, 0}, {1, 0}, {0, 1}};
};

}  // namespace rt
