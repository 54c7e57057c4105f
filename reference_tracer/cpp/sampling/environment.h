// Mitsuba's `envmap` emitter (src/emitters/envmap.cpp): radiance arriving from infinitely
// far away, read from an equirectangular (latitude-longitude) RGB image.
//
// Directions. In the map's own frame a direction d has
//   u = atan2(d.x, -d.z) / (2 pi)  (wrapped into [0, 1): u = 0 looks along -z, u = 1/4
//                                    along +x),
//   v = acos(d.y) / pi              (v = 0 is +y, the image's top row; v = 1 is -y),
// and d = (sin phi sin theta, cos theta, -cos phi sin theta) for phi = 2 pi u, theta = pi v.
// `to_world` (a rotation) turns map directions into world directions; the value seen
// along a world direction is that of R^T d.
//
// Value (eval), exactly Mitsuba's lookup in its RGB variants: bilinear interpolation, with
// the texel centres of the W columns at u = (i + 1/2) / W (periodic in u: between the last
// column and the first) and the H rows at v = k / (H - 1) (the first row at the pole +y,
// the last at -y, clamped beyond), times `scale`. Mitsuba pads an image narrower than 2
// columns or shorter than 3 rows by repeating its last column / row first: the caller
// passes the padded image (reference_tracer/envmap.py).
//
// Sampling (sample, pdf): piecewise constant in solid angle over the cells of that same
// grid: cell (j, k) spans u in [(j + 1/2) / W, (j + 3/2) / W] (the last one wraps past
// u = 1) and theta in [k pi / (H - 1), (k + 1) pi / (H - 1)], a solid angle
// Omega_k = (2 pi / W) (cos theta_k - cos theta_(k+1)). Its weight w_jk is the mean
// luminance of its four corner texels: the bilinear value is positive inside a cell
// exactly where one corner is, so the density is positive wherever the radiance is. A
// cell is chosen with probability w_jk Omega_k / Z (Z = sum of w Omega over all cells: a
// row first by its total, then the column within it) and a direction uniformly in it
// (phi uniform, cos theta uniform), so the solid-angle density is
//   pdf(d) = w_jk / Z  for d in cell (j, k),
// bounded everywhere, also at the poles (no 1 / sin theta). Mitsuba samples the bilinear
// interpolation of luminance times sin theta instead (its Hierarchical2D warp): the two
// differ in variance, not in expectation.
#pragma once

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "../math.h"
#include "warp.h"

namespace rt {

class EnvironmentMap {
public:
    // rgb: width * height * 3 values, rows from the top (v = 0) down, columns in u order;
    // width >= 2, height >= 3, every value finite and >= 0. to_world: a rotation, by rows.
    EnvironmentMap(std::vector<float> rgb, int width, int height, double scale, const double (&to_world)[3][3])
        : rgb_(std::move(rgb)), width_(width), height_(height), scale_(scale) {
        if (width < 2 || height < 3 || rgb_.size() != size_t(width) * size_t(height) * 3)
            throw std::invalid_argument("environment map: expected at least 2 x 3 RGB texels");
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c) to_world_[r][c] = to_world[r][c];
        const size_t W = size_t(width), rows = size_t(height) - 1;
        // The rows' cosines at their texel centres (theta_k = k pi / (H - 1)).
        cos_theta_.resize(size_t(height));
        for (size_t k = 0; k < size_t(height); ++k) cos_theta_[k] = std::cos(double(k) * kPi / double(height - 1));
        cos_theta_.front() = 1.0;
        cos_theta_.back() = -1.0;
        std::vector<double> lum(W * size_t(height));
        for (size_t i = 0; i < lum.size(); ++i)
            lum[i] = luminance(Vec3(rgb_[3 * i], rgb_[3 * i + 1], rgb_[3 * i + 2]));
        cell_.assign(W * rows, 0.0);
        col_cdf_.assign((W + 1) * rows, 0.0);
        row_cdf_.assign(rows + 1, 0.0);
        for (size_t k = 0; k < rows; ++k) {
            double* cdf = &col_cdf_[k * (W + 1)];
            for (size_t j = 0; j < W; ++j) {
                const size_t j1 = (j + 1) % W;
                const double w = 0.25 * (lum[k * W + j] + lum[k * W + j1] + lum[(k + 1) * W + j] + lum[(k + 1) * W + j1]);
                cell_[k * W + j] = w;
                cdf[j + 1] = cdf[j] + w;
            }
            const double omega = (2.0 * kPi / double(W)) * (cos_theta_[k] - cos_theta_[k + 1]);
            row_cdf_[k + 1] = row_cdf_[k] + cdf[W] * omega;
        }
        total_ = row_cdf_[rows];
        const double inv = total_ > 0.0 ? 1.0 / total_ : 0.0;
        for (double& w : cell_) w *= inv;  // now the density of each cell
    }

    // Whether any texel is lit: an all-black map is no light.
    bool lit() const { return total_ > 0.0 && std::isfinite(total_); }
    int width() const { return width_; }
    int height() const { return height_; }

    // Radiance arriving along the world direction d (from far away in direction d).
    Vec3 eval(const Vec3& d) const {
        double u, v;
        to_uv(d, u, v);
        return eval_uv(u, v);
    }

    // Solid-angle density of sample() for the world direction d (unit).
    double pdf(const Vec3& d) const {
        double u, v;
        to_uv(d, u, v);
        return cell_[cell_of(u, v)];
    }

    // A direction drawn with density pdf(): false (nothing drawn) only for an unlit map.
    bool sample(double u1, double u2, Vec3& d, double& pdf, Vec3& radiance) const {
        if (!lit()) return false;
        const size_t W = size_t(width_), rows = size_t(height_) - 1;
        double r1, r2;
        const size_t k = pick(row_cdf_.data(), rows, u1, r1);
        const size_t j = pick(&col_cdf_[k * (W + 1)], W, u2, r2);
        // Uniform in the cell: cos theta uniform between its rows, phi uniform between the
        // texel centres of columns j and j + 1.
        const double cos_t = cos_theta_[k] - r1 * (cos_theta_[k] - cos_theta_[k + 1]);
        const double sin_t = safe_sqrt((1.0 - cos_t) * (1.0 + cos_t));
        double u = (double(j) + 0.5 + r2) / double(W);
        if (u >= 1.0) u -= 1.0;
        double sin_p, cos_p;
        sincos_turn(u, sin_p, cos_p);
        d = normalize(to_world(Vec3(sin_p * sin_t, cos_t, -cos_p * sin_t)));
        pdf = cell_[k * W + j];
        radiance = eval_uv(u, std::acos(std::clamp(cos_t, -1.0, 1.0)) * kInvPi);
        return pdf > 0.0;
    }

private:
    Vec3 to_world(const Vec3& v) const {
        return {to_world_[0][0] * v.x + to_world_[0][1] * v.y + to_world_[0][2] * v.z,
                to_world_[1][0] * v.x + to_world_[1][1] * v.y + to_world_[1][2] * v.z,
                to_world_[2][0] * v.x + to_world_[2][1] * v.y + to_world_[2][2] * v.z};
    }
    Vec3 to_local(const Vec3& v) const {  // R^T v
        return {to_world_[0][0] * v.x + to_world_[1][0] * v.y + to_world_[2][0] * v.z,
                to_world_[0][1] * v.x + to_world_[1][1] * v.y + to_world_[2][1] * v.z,
                to_world_[0][2] * v.x + to_world_[1][2] * v.y + to_world_[2][2] * v.z};
    }

    // (u, v) of a world direction, u in [0, 1), v in [0, 1].
    void to_uv(const Vec3& world, double& u, double& v) const {
        const Vec3 d = to_local(world);
        u = std::atan2(d.x, -d.z) * (0.5 * kInvPi);
        u -= std::floor(u);
        if (u >= 1.0) u = 0.0;  // -tiny + 1 rounds to 1
        const double len = length(d);
        v = std::acos(std::clamp(d.y / len, -1.0, 1.0)) * kInvPi;
    }

    // The cell (index into cell_) holding (u, v).
    size_t cell_of(double u, double v) const {
        const int W = width_, rows = height_ - 1;
        int j = int(std::floor(u * W - 0.5));  // in [-1, W - 1]
        if (j < 0) j += W;
        const int k = std::min(int(v * rows), rows - 1);
        return size_t(k) * size_t(W) + size_t(std::min(j, W - 1));
    }

    // The bilinear lookup (Mitsuba's eval_spectrum in RGB variants), times scale.
    Vec3 eval_uv(double u, double v) const {
        const int W = width_, H = height_;
        u -= std::floor(u);
        v = std::clamp(v, 0.0, 1.0);
        const double x = u * W - 0.5;  // texel centres at integers
        const double x0 = std::floor(x), tx = x - x0;
        int i0 = int(x0);
        if (i0 < 0) i0 += W;
        if (i0 >= W) i0 -= W;
        const int i1 = i0 + 1 == W ? 0 : i0 + 1;
        const double y = v * (H - 1);
        const int k0 = std::min(int(y), H - 2);
        const double ty = y - k0;
        const auto at = [&](int i, int k, int c) { return double(rgb_[3 * (size_t(k) * size_t(W) + size_t(i)) + c]); };
        Vec3 out;
        for (int c = 0; c < 3; ++c) {
            const double top = (1.0 - tx) * at(i0, k0, c) + tx * at(i1, k0, c);
            const double bottom = (1.0 - tx) * at(i0, k0 + 1, c) + tx * at(i1, k0 + 1, c);
            out[c] = ((1.0 - ty) * top + ty * bottom) * scale_;
        }
        return out;
    }

    // The entry of the n entries of a cumulative table cdf[0 .. n] (cdf[0] = 0) that u
    // falls in, and u's place within it (in [0, 1)); never an entry of weight 0.
    static size_t pick(const double* cdf, size_t n, double u, double& rest) {
        const double total = cdf[n];
        const double t = std::min(u * total, std::nextafter(total, 0.0));
        size_t i = size_t(std::upper_bound(cdf + 1, cdf + n + 1, t) - (cdf + 1));
        if (i >= n) i = n - 1;
        const double w = cdf[i + 1] - cdf[i];
        rest = w > 0.0 ? std::clamp((t - cdf[i]) / w, 0.0, std::nextafter(1.0, 0.0)) : 0.0;
        return i;
    }

    std::vector<float> rgb_;
    int width_, height_;
    double scale_;
    double to_world_[3][3];
    std::vector<double> cos_theta_;  // cos theta of each row's texel centres
    std::vector<double> cell_;       // density (solid angle) of each cell, (H - 1) x W
    std::vector<double> col_cdf_;    // per row of cells: cumulative weights, W + 1 each
    std::vector<double> row_cdf_;    // cumulative w Omega of the rows of cells, H entries
    double total_ = 0.0;
};

}  // namespace rt
