// Pixel reconstruction filters as Mitsuba defines them (rfilters/*.cpp): box (each sample
// counts once in its own pixel: the plain mean), tent of radius r, and the Gaussian of
// standard deviation s truncated at 4 s and shifted to reach zero there. A sample at image
// position (px, py) adds w(x + 0.5 - px) w(y + 0.5 - py) times its radiance to every pixel
// (x, y) within the radius, and that weight to the pixel's weight sum; a pixel is the sum
// of its weighted radiance over the sum of its weights. Splats beyond the image are dropped
// (Mitsuba's sample_border=false): the samples are still drawn inside their own pixel.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include "math.h"

namespace rt {

enum class FilterKind : int { Box = 0, Tent = 1, Gaussian = 2 };

struct PixelFilter {
    FilterKind kind = FilterKind::Box;
    double radius = 0.5;   // tent: its radius; Gaussian: 4 standard deviations
    double stddev = 0.5;   // Gaussian only

    static PixelFilter box() { return {}; }
    static PixelFilter tent(double r) { return {FilterKind::Tent, r, 0.0}; }
    static PixelFilter gaussian(double s) { return {FilterKind::Gaussian, 4.0 * s, s}; }

    double eval(double x) const {
        x = std::abs(x);
        switch (kind) {
            case FilterKind::Box: return x < 0.5 ? 1.0 : 0.0;
            case FilterKind::Tent: return std::max(0.0, 1.0 - x / radius);
            case FilterKind::Gaussian: {
                const double a = -0.5 / (stddev * stddev);
                return std::max(0.0, std::exp(a * x * x) - std::exp(a * radius * radius));
            }
        }
        return 0.0;
    }
};

// A worker's image of weighted radiance and weights, (H, W, 4): R, G, B and the weight sum.
class SplatImage {
public:
    SplatImage(int width, int height, PixelFilter filter)
        : W_(width), H_(height), filter_(filter), acc_(size_t(width) * height * 4, 0.0) {}

    void add(double px, double py, const Vec3& L) {
        const double r = filter_.radius;
        const int x0 = std::max(0, int(std::ceil(px - 0.5 - r))), x1 = std::min(W_ - 1, int(std::floor(px - 0.5 + r)));
        const int y0 = std::max(0, int(std::ceil(py - 0.5 - r))), y1 = std::min(H_ - 1, int(std::floor(py - 0.5 + r)));
        for (int y = y0; y <= y1; ++y) {
            const double wy = filter_.eval(y + 0.5 - py);
            if (wy <= 0.0) continue;
            for (int x = x0; x <= x1; ++x) {
                const double w = wy * filter_.eval(x + 0.5 - px);
                if (w <= 0.0) continue;
                double* a = &acc_[(size_t(y) * W_ + x) * 4];
                a[0] += w * L.x;
                a[1] += w * L.y;
                a[2] += w * L.z;
                a[3] += w;
            }
        }
    }

    void add_to(std::vector<double>& total) const {
        for (size_t i = 0; i < acc_.size(); ++i) total[i] += acc_[i];
    }

private:
    int W_, H_;
    PixelFilter filter_;
    std::vector<double> acc_;
};

}  // namespace rt
