// How fast can furnace's bounce run, by precision? A stand-alone kernel of the suite's
// `furnace` (the camera inside an emitting, diffuse unit sphere: Le 0.5, albedo 0.8; `mis`;
// roulette from depth 5; max depth 8) with every lane's state in structure-of-arrays
// packs and no more than this one scene needs: no material dispatch, no queue, no pixel
// bookkeeping, a finished path restarted in place. Its paths per second bound what a
// wavefront integrator of that layout could reach on this CPU, for packs of doubles and of
// floats; the tracer's own figure is `rtbench speed furnace --threads 1` (PERFORMANCE.md,
// Where the time goes). Not part of the tracer, and not bit for bit its numbers.
//
//   g++ -O3 -march=native -ffp-contract=off -fno-math-errno -std=c++17 scripts/furnace_bound.cpp -o /tmp/furnace_bound
//   /tmp/furnace_bound [seconds per configuration, default 2]
//
// Each line: segments and paths a second on one thread, and the mean radiance against the
// exact 0.5 (1 - 0.8^8) / 0.2 (single precision drifts low: its per-lane sums and its
// shadow epsilon). The "per-lane" lines keep each lane's state in a structure of its own,
// copied into a pack and back around every bounce.
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>

namespace {

constexpr double kPi = 3.14159265358979323846;

template <typename T, int W>
struct Lanes {
    typedef T F __attribute__((vector_size(sizeof(T) * W)));
    typedef decltype(F{} < F{}) M;
    typedef int32_t I __attribute__((vector_size(4 * W)));
    typedef uint64_t U __attribute__((vector_size(8 * W)));
};

template <typename T, int W>
class Furnace {
    using F = typename Lanes<T, W>::F;
    using M = typename Lanes<T, W>::M;
    using I = typename Lanes<T, W>::I;
    using U = typename Lanes<T, W>::U;
    static constexpr int kPacks = 4;  // a thread's paths in flight: kPacks * W
    static constexpr T kLe = 0.5, kAlbedo = 0.8, kArea = T(4 * kPi);
    static constexpr T kOffset = sizeof(T) == 8 ? 1e-9 : 1e-4;        // ray origins off the surface
    static constexpr T kShadowEnd = sizeof(T) == 8 ? 1 - 1e-7 : 1 - 1e-4;  // shadow rays end short of the light

    struct Pack {
        F o[3], d[3], beta[3], L[3], sum[3];
        F depth, prev_pdf, prev_ref[3], prev_delta;
        U rng;  // last: fields() covers the rest
    };

public:
    Furnace() {
        for (int k = 0; k < kPacks; ++k) {
            for (int l = 0; l < W; ++l) packs_[k].rng[l] = 0x853c49e6748fea9bull * uint64_t(k * W + l + 1);
            for (int a = 0; a < 3; ++a) packs_[k].sum[a] = F{};
            restart(packs_[k], ~M{});
        }
    }

    void bounces(int n) {
        for (int i = 0; i < n; ++i)
            for (Pack& p : packs_) bounce(p);
    }

    // The same bounces with each lane's state in a structure of its own (as the tracer keeps
    // its lanes), copied into a pack before each bounce and back after it, field by field:
    // the least an array-of-structures layout adds.
    void bounces_per_lane(int n) {
        if (!per_lane_) {
            for (int k = 0; k < kPacks; ++k) to_lanes(packs_[k], k);
            per_lane_ = true;
        }
        for (int i = 0; i < n; ++i)
            for (int k = 0; k < kPacks; ++k) {
                Pack p;
                F* f = fields(p);
                for (int j = 0; j < kFields; ++j)
                    for (int l = 0; l < W; ++l) f[j][l] = lanes_[k * W + l].field[j];
                for (int l = 0; l < W; ++l) p.rng[l] = lanes_[k * W + l].rng;
                bounce(p);
                to_lanes(p, k);
            }
    }
    uint64_t segments() const { return segments_; }
    uint64_t paths() const { return paths_; }
    double mean() const {
        double sum = 0;
        for (int k = 0; k < kPacks; ++k)
            for (int l = 0; l < W; ++l) sum += per_lane_ ? lanes_[k * W + l].field[kSumField] : packs_[k].sum[0][l];
        return sum / double(paths_);
    }

private:
    static F splat(T x) { return x - F{}; }
    static F sqrt_of(F x) {
        F r;
        for (int i = 0; i < W; ++i) r[i] = std::sqrt(x[i]);  // one vsqrtp[sd] per register
        return r;
    }
    static F dot(const F (&a)[3], const F (&b)[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

    // PCG RXS M XS, 64-bit state a lane, as the tracer's generator; 53 or 24 bits a draw.
    F next(U& s) const {
        const U old = s;
        s = s * 6364136223846793005ull + 1442695040888963407ull;
        const U word = ((old >> ((old >> 59u) + 5u)) ^ old) * 12605985483714917081ull;
        const U out = (word >> 43u) ^ word;
        if constexpr (sizeof(T) == 8)
            return __builtin_convertvector(out >> 11, F) * T(0x1.0p-53);
        else
            return __builtin_convertvector(__builtin_convertvector(out >> 40, I), F) * T(0x1.0p-24);
    }

    // sin and cos of x in [-pi, pi]: quarter turns and polynomials of the tracer's degree
    // (double) or of single precision's.
    static void sincos(F x, F& s, F& c) {
        const I quarter = __builtin_convertvector(x * T(2 / kPi) + T(2.5), I) - 2;
        const F r = x - __builtin_convertvector(quarter, F) * T(kPi / 2);
        const F z = r * r;
        F ps, pc;
        if constexpr (sizeof(T) == 8) {
            ps = z * T(-1.0 / 39916800) + T(1.0 / 362880);
            ps = z * ps + T(-1.0 / 5040);
            ps = z * ps + T(1.0 / 120);
            ps = z * ps + T(-1.0 / 6);
            pc = z * T(1.0 / 479001600) + T(-1.0 / 3628800);
            pc = z * pc + T(1.0 / 40320);
            pc = z * pc + T(-1.0 / 720);
            pc = z * pc + T(1.0 / 24);
        } else {
            ps = z * T(-1.0 / 5040) + T(1.0 / 120);
            ps = z * ps + T(-1.0 / 6);
            pc = z * T(1.0 / 40320) + T(-1.0 / 720);
            pc = z * pc + T(1.0 / 24);
        }
        ps = z * ps + T(1);
        pc = z * (z * pc + T(-0.5)) + T(1);
        const F sr = r * ps;
        const I k = quarter & 3;
        const M odd = __builtin_convertvector((k & 1) != 0, M);
        const F a = odd ? pc : sr, b = odd ? sr : pc;
        s = __builtin_convertvector((k & 2) != 0, M) ? -a : a;
        c = __builtin_convertvector(((k + 1) & 2) != 0, M) ? -b : b;
    }

    // The unit sphere at the origin, as the tracer's cancellation-free test: lanes with a hit
    // in (0, t_max), t_max lowered to it.
    static M sphere(const F (&o)[3], const F (&d)[3], F& t_max) {
        const F to_c[3] = {-o[0], -o[1], -o[2]};
        const F a = dot(d, d), inv_a = T(1) / a, h = dot(d, to_c), ha = h * inv_a;
        const F f[3] = {to_c[0] - ha * d[0], to_c[1] - ha * d[1], to_c[2] - ha * d[2]};
        const F disc = T(1) - dot(f, f);
        const F c = dot(to_c, to_c) - T(1);
        const F root = sqrt_of(a * disc);
        const F q = h + (h < T(0) ? -root : root);
        const F t0 = c / q, t1 = q * inv_a;
        const M swap = t0 > t1;
        const F lo = swap ? t1 : t0, hi = swap ? t0 : t1;
        const M met = disc >= T(0);
        const M hit0 = met & (lo > T(0)) & (lo < t_max);
        const M hit1 = met & (hit0 == 0) & (hi > T(0)) & (hi < t_max);
        t_max = hit0 ? lo : (hit1 ? hi : t_max);
        return hit0 | hit1;
    }

    // New camera paths in `lanes`: a pinhole at the centre, 60 degrees, a jittered film point.
    void restart(Pack& p, M lanes) const {
        const F x = (next(p.rng) * T(2) - T(1)) * T(0.57735), y = (next(p.rng) * T(2) - T(1)) * T(0.57735);
        const F inv = T(1) / sqrt_of(x * x + y * y + T(1));
        const F d[3] = {x * inv, y * inv, inv};
        for (int a = 0; a < 3; ++a) {
            p.o[a] = lanes ? F{} : p.o[a];
            p.d[a] = lanes ? d[a] : p.d[a];
            p.beta[a] = lanes ? splat(1) : p.beta[a];
            p.L[a] = lanes ? F{} : p.L[a];
        }
        p.depth = lanes ? F{} : p.depth;
        p.prev_delta = lanes ? splat(1) : p.prev_delta;
    }

    void bounce(Pack& p) {
        // The closest hit, its exact point and inward normal.
        F t = splat(INFINITY), hp[3], n[3];
        sphere(p.o, p.d, t);
        for (int a = 0; a < 3; ++a) hp[a] = p.o[a] + t * p.d[a];
        const F inv_len = T(1) / sqrt_of(dot(hp, hp));
        for (int a = 0; a < 3; ++a) {
            hp[a] = hp[a] * inv_len;
            n[a] = -hp[a];
        }
        // Emission, MIS-weighted against light sampling after a BSDF sample.
        F to_hit[3];
        for (int a = 0; a < 3; ++a) to_hit[a] = hp[a] - p.prev_ref[a];
        const F pdf_e = dot(to_hit, to_hit) / (-dot(n, p.d) * kArea);
        const F pb2 = p.prev_pdf * p.prev_pdf;
        const F w_e = p.prev_delta != T(0) ? splat(1) : pb2 / (pb2 + pdf_e * pdf_e);
        for (int a = 0; a < 3; ++a) p.L[a] += p.beta[a] * kLe * w_e;
        const M last = p.depth + T(1) >= T(8);
        // A light sample by area, from inside the sphere.
        F ref[3];
        for (int a = 0; a < 3; ++a) ref[a] = hp[a] + n[a] * kOffset;
        const F z = T(1) - T(2) * next(p.rng);
        const F r = sqrt_of(T(1) - z * z);
        F s, c;
        sincos((next(p.rng) - T(0.5)) * T(2 * kPi), s, c);
        const F on_light[3] = {r * c, r * s, z};
        F wi[3];
        for (int a = 0; a < 3; ++a) wi[a] = on_light[a] - ref[a];
        const F dist2 = dot(wi, wi), dist = sqrt_of(dist2), inv_dist = T(1) / dist;
        for (int a = 0; a < 3; ++a) wi[a] = wi[a] * inv_dist;
        const F cos_l = dot(on_light, wi), cos_i = dot(wi, n);
        const F pdf_l = dist2 / (cos_l * kArea);
        const F pl2 = pdf_l * pdf_l, pdf_b = cos_i * T(1 / kPi);
        const F w_l = pl2 / (pl2 + pdf_b * pdf_b);
        const F scale = ((T(kAlbedo / kPi) * cos_i) * kLe) * (w_l / pdf_l);
        // Its shadow ray.
        F t_shadow = dist * kShadowEnd;
        const M add = (cos_l > T(0)) & (cos_i > T(0)) & (sphere(ref, wi, t_shadow) == 0) & (last == 0);
        for (int a = 0; a < 3; ++a) p.L[a] += add ? p.beta[a] * scale : F{};
        // The cosine-weighted continuation (concentric map), in the normal's frame.
        const F ca = T(2) * next(p.rng) - T(1), cb = T(2) * next(p.rng) - T(1);
        const M first = ca * ca > cb * cb;
        F ss, cc;
        sincos(T(kPi / 4) * ((first ? cb : ca) / (first ? ca : cb)), ss, cc);
        const F lx = first ? ca * cc : cb * ss, ly = first ? ca * ss : cb * cc;
        const F lz2 = T(1) - lx * lx - ly * ly;
        const F lz = sqrt_of(lz2 > T(0) ? lz2 : F{});
        const F sign = n[2] < T(0) ? splat(-1) : splat(1);
        const F fa = T(-1) / (sign + n[2]), fb = n[0] * n[1] * fa;
        const F fs[3] = {T(1) + sign * n[0] * n[0] * fa, sign * fb, -sign * n[0]};
        const F ft[3] = {fb, sign + n[1] * n[1] * fa, -n[1]};
        for (int a = 0; a < 3; ++a) {
            p.d[a] = fs[a] * lx + ft[a] * ly + n[a] * lz;
            p.o[a] = p.prev_ref[a] = ref[a];
            p.beta[a] *= kAlbedo;
        }
        p.prev_pdf = lz * T(1 / kPi);
        p.prev_delta = F{};
        // Russian roulette from depth 5 (the throughput is grey).
        const F q = p.beta[0] < T(0.95) ? p.beta[0] : splat(0.95);
        const M roulette = p.depth + T(1) >= T(5);
        const M dies = roulette & (next(p.rng) >= q);
        const F inv_q = T(1) / q;
        for (int a = 0; a < 3; ++a) p.beta[a] = roulette ? p.beta[a] * inv_q : p.beta[a];
        p.depth += T(1);
        const M done = last | dies;
        for (int a = 0; a < 3; ++a) p.sum[a] += done ? p.L[a] : F{};
        segments_ += W;
        for (int l = 0; l < W; ++l) paths_ += done[l] != 0;
        restart(p, done);
    }

    // A pack's floating-point fields as an array of F (all of Pack but the generator), and
    // the place of sum[0] among them.
    static constexpr int kFields = int((sizeof(Pack) - sizeof(U)) / sizeof(F));
    static constexpr int kSumField = int(offsetof(Pack, sum) / sizeof(F));
    static F* fields(Pack& p) { return reinterpret_cast<F*>(&p); }
    static const F* fields(const Pack& p) { return reinterpret_cast<const F*>(&p); }
    struct Lane {
        T field[kFields];
        uint64_t rng;
    };
    void to_lanes(const Pack& p, int k) {
        const F* f = fields(p);
        for (int j = 0; j < kFields; ++j)
            for (int l = 0; l < W; ++l) lanes_[k * W + l].field[j] = f[j][l];
        for (int l = 0; l < W; ++l) lanes_[k * W + l].rng = p.rng[l];
    }

    Pack packs_[kPacks];
    Lane lanes_[kPacks * W];
    bool per_lane_ = false;
    uint64_t segments_ = 0, paths_ = 0;
};

template <typename T, int W>
void measure(const char* name, double seconds, bool per_lane = false) {
    auto* furnace_ptr = new Furnace<T, W>();
    Furnace<T, W>& furnace = *furnace_ptr;
    const auto start = std::chrono::steady_clock::now();
    double took = 0;
    while (took < seconds) {
        if (per_lane)
            furnace.bounces_per_lane(1000);
        else
            furnace.bounces(1000);
        took = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    }
    std::printf("%-18s %6.1f Msegments/s %6.2f Mpaths/s  mean %.4f (exact %.4f)\n", name,
                furnace.segments() / took / 1e6, furnace.paths() / took / 1e6, furnace.mean(),
                0.5 * (1 - std::pow(0.8, 8)) / 0.2);
    delete furnace_ptr;
}

}  // namespace

int main(int argc, char** argv) {
    const double seconds = argc > 1 ? std::atof(argv[1]) : 2.0;
    // Packs of one and of two registers' width (wider ones the compiler splits badly).
    measure<double, 4>("doubles, 4 lanes", seconds);
#ifdef __AVX512F__
    measure<double, 8>("doubles, 8 lanes", seconds);
#endif
    measure<float, 8>("floats, 8 lanes", seconds);
#ifdef __AVX512F__
    measure<float, 16>("floats, 16 lanes", seconds);
    measure<double, 8>("per-lane doubles, 8", seconds, true);
    measure<float, 16>("per-lane floats, 16", seconds, true);
#else
    measure<double, 4>("per-lane doubles, 4", seconds, true);
    measure<float, 8>("per-lane floats, 8", seconds, true);
#endif
}
