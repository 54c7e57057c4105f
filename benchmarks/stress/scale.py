"""Case ``scale_invariance``: the Cornell box at scale 1e-4, 1, 1e4 and translated 1e5
away renders the same within noise; a creased white furnace is exactly 1 at every scale."""
from __future__ import annotations

import reference_tracer as rt
from mitsuba_scenes import get_scene

from .probes import creased_furnace_scene, transform_scene
from .record import stress_case
from .ztests import image_ztest

__all__ = ["scale_invariance"]


#: the transformed variants of the scale-1 scene: (label, scale, offset)
SCALES = (("scale 1e-4", 1e-4, (0.0, 0.0, 0.0)), ("scale 1e4", 1e4, (0.0, 0.0, 0.0)),
          ("translated 1e5", 1.0, (1e5, -1e5, 1e5)))


@stress_case
def scale_invariance(*, width: int = 32, spp: int = 64, strategies=("mis",), furnace_width: int = 24,
                     furnace_spp: int = 8, seed: int = 0):
    """The same scene at scale 1e-4, 1 and 1e4, and translated 1e5 away, renders the same.

    The Cornell box at each scale against a scale-1 render of its own seed
    (:func:`image_ztest`; scale 1 itself is the null comparison), and
    :func:`creased_furnace_scene` at each scale exactly 1 with ``cosine``. Reported
    beside the verdict: the smallest size / distance from the origin (1e-6 .. 1e-11) at
    which the creased furnace stays exact.
    """
    base_scene = get_scene("cornell_box", width=width, height=width)
    comparisons, nonfinite = {}, 0
    passed = True
    for si, strategy in enumerate(strategies):
        s0 = seed * 1000 + 100 * si
        variants = [("scale 1 (null)", 1.0, (0.0, 0.0, 0.0))] + list(SCALES)
        for k, (label, scale, off) in enumerate(variants):
            # A fresh scale-1 reference per comparison keeps the comparisons independent.
            ref = rt.render(base_scene, spp=spp, strategy=strategy, seed=s0 + 2 * k + 1, threads=2)
            res = rt.render(transform_scene(base_scene, scale=scale, offset=off), spp=spp, strategy=strategy,
                            seed=s0 + 2 * k + 2, threads=2)
            nonfinite += ref.nonfinite_samples + res.nonfinite_samples
            zt = image_ztest(res.mean, res.variance, spp, ref.mean, ref.variance, spp)
            zt["mean_ratio"] = float(res.mean.mean() / ref.mean.mean())
            comparisons[f"{strategy}: {label}"] = zt
            passed &= zt["passed"]
    furnace = creased_furnace_scene(width=furnace_width)
    furnace_bad = {}
    for label, scale, off in [("scale 1", 1.0, (0.0, 0.0, 0.0))] + list(SCALES):
        res = rt.render(transform_scene(furnace, scale=scale, offset=off), spp=furnace_spp, strategy="cosine",
                        seed=seed, threads=2)
        nonfinite += res.nonfinite_samples
        furnace_bad[label] = {"pixels_not_1": int((res.mean != 1.0).sum()),
                              "min": float(res.mean.min()), "max": float(res.mean.max())}
        passed &= furnace_bad[label]["pixels_not_1"] == 0
    # reported, not part of the verdict: how small may a scene be beside its distance from the origin?
    limit = {}
    for ratio in (1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11):
        res = rt.render(transform_scene(furnace, scale=ratio * 1e5, offset=(1e5, 0.0, 0.0)), spp=4,
                        strategy="cosine", seed=seed, threads=2)
        limit[ratio] = int((res.mean != 1.0).sum())
    exact_down_to = min([r for r in limit if all(limit[q] == 0 for q in limit if q >= r)], default=None)
    passed &= nonfinite == 0
    worst = max(max(abs(z) for z in c["z_global"]) for c in comparisons.values())
    outl = max(c["outliers"] for c in comparisons.values())
    lim = min(c["outlier_limit"] for c in comparisons.values())
    figure = (f"Cornell box vs scale 1: max |Z_global| {worst:.2f} (limit "
              f"{next(iter(comparisons.values()))['z_global_limit']:.2f}), outlier pixels <= {outl} "
              f"(limit {lim}); creased furnace pixels != 1: "
              f"{sum(v['pixels_not_1'] for v in furnace_bad.values())} [not in verdict: exact down to "
              f"size/distance {exact_down_to:g}, pixels off at " +
              ", ".join(f"{r:g}: {n}" for r, n in limit.items()) + "]")
    details = {"comparisons": comparisons, "creased_furnace": furnace_bad, "nonfinite_samples": nonfinite,
               "size_over_distance_pixels_off": {str(r): n for r, n in limit.items()},
               "exact_down_to_size_over_distance": exact_down_to,
               "spp": spp, "width": width}
    return figure, passed, details
