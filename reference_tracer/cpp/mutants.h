// Seeded bugs ("mutants") for the harness's self-test (benchmarks/selftest, `rtbench
// selftest`): does the statistical gate catch the bugs that happen in practice?
//
// Each mutant is one small, realistic mistake written into the tracer's sources at the
// place where it would be made (a missing cosine in the Lambertian BSDF, a missing
// Jacobian in the light sampler, ...). The hot functions take the mutant as a compile-time
// template parameter defaulting to Mutant::None, and every seeded line is an `if
// constexpr` (or a constant chosen by M): the tracer's instantiation contains no mutant
// code and no check at all, so its renders cost the same and stay bit-identical.
//
// The tracer's module (reference_tracer._core) instantiates Mutant::None only. The same
// sources plus mutants.cpp build a second module, reference_tracer._mutants, whose
// Scene.render takes `mutant=<id>` and picks the instantiation once per render
// (render_mutant, dispatch_mutant); only benchmarks/selftest imports it, and
// `reference_tracer.render` has no way to reach it.
//
// The catalogue (what each breaks, which scene and strategy expose it, and why) is
// benchmarks/selftest/catalogue.py; the names below must match it in order.
#pragma once

#include <type_traits>
#include <utility>

namespace rt {

// X(enumerator, "name"): one line per mutant, in catalogue order (ids 1, 2, ...).
#define RT_MUTANTS(X)                                                                                  \
    X(MissingCosine, "missing_cosine")          /* Lambertian f*cos returned without the cosine */   \
    X(PdfOffByPi, "pdf_off_by_pi")              /* Lambertian density cos instead of cos/pi */        \
    X(EmitterWeightOne, "emitter_weight_one")   /* emitter hits weighted 1 beside NEE under mis */    \
    X(LightPdfNoJacobian, "light_pdf_no_jacobian") /* area density used as a solid-angle density */   \
    X(RouletteNoReweight, "roulette_no_reweight")  /* Russian roulette survivors not divided by q */ \
    X(GlassNoEtaScale, "glass_no_eta_scale")    /* refraction without the 1/eta^2 radiance scale */   \
    X(GgxMaskingAlpha, "ggx_masking_alpha")     /* Smith G1 with alpha where alpha^2 belongs */       \
    X(TwoSidedLight, "two_sided_light")         /* emitters hit from the back emit too */             \
    X(MaxDepthOffByOne, "max_depth_off_by_one") /* one path segment more than max_depth allows */     \
    X(ShadowEpsilonLeak, "shadow_epsilon_leak") /* shadow rays stop 1% short of the light */          \
    X(HalfPixelJitter, "half_pixel_jitter")     /* pixel samples in [x - 1/2, x + 1/2) */             \
    X(CorrelatedPixelStreams, "correlated_pixel_streams") /* every pixel draws the same stream */

enum class Mutant : int {
    None = 0,
#define RT_MUTANT_ENUM(id, name) id,
    RT_MUTANTS(RT_MUTANT_ENUM)
#undef RT_MUTANT_ENUM
    Count
};

// Names by id (index 0 is "none").
inline constexpr const char* kMutantNames[] = {
    "none",
#define RT_MUTANT_NAME(id, name) name,
    RT_MUTANTS(RT_MUTANT_NAME)
#undef RT_MUTANT_NAME
};
static_assert(sizeof(kMutantNames) / sizeof(kMutantNames[0]) == size_t(Mutant::Count));

template <Mutant M>
using MutantTag = std::integral_constant<Mutant, M>;

// f(MutantTag<m>{}) for the run-time value m (0 <= m < Count, checked by the caller): the
// one place where a run-time mutant id becomes a compile-time one.
template <int I = 0, typename F>
decltype(auto) dispatch_mutant(Mutant m, F&& f) {
    if constexpr (I + 1 < int(Mutant::Count)) {
        if (int(m) != I) return dispatch_mutant<I + 1>(m, std::forward<F>(f));
    }
    return f(MutantTag<Mutant(I)>{});
}

}  // namespace rt
