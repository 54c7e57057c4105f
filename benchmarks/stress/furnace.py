"""Case ``white_furnace``: white furnaces are exact per sample for ``cosine`` and in
expectation for every other strategy."""
from __future__ import annotations

import numpy as np

import reference_tracer as rt
from mitsuba_scenes import get_scene
from mitsuba_scenes.scenes.furnace import ALBEDO, RADIANCE, expected_radiance

from .probes import creased_furnace_scene, probe_scene
from .record import stress_case
from .ztests import constant_ztest

__all__ = ["white_furnace"]


@stress_case
def white_furnace(*, width: int = 24, spp: int = 64, seed: int = 0):
    """White furnaces: energy is neither gained nor lost, for every strategy.

    Per scene and strategy, ``exact`` (every pixel equal to the closed form: every sample
    weighs exactly 1), ``expect`` (:func:`constant_ztest`) or ``global`` (its global test
    only, for heavy-tailed weights): an albedo-1 sphere in a background of 1
    (``cosine`` exact), :func:`creased_furnace_scene` (``cosine`` exact; ``light`` misses
    interreflection and is left out) and the suite's ``furnace`` (inside a sphere every
    strategy but ``uniform`` is exact; ``light`` at Le (1 + rho)).
    """
    sphere = probe_scene([rt.Sphere((0, 0, 0), 1.0, rt.Lambertian(1.0))], width=width, lookfrom=(0, 0, -4.0),
                         vfov=35.0, background=1.0)
    plan = [("sphere", sphere, {"cosine": ("exact", 1.0), "uniform": ("expect", 1.0),
             "light": ("expect", 1.0), "mixture": ("expect", 1.0), "mis": ("expect", 1.0)}),
            ("creased", creased_furnace_scene(width=width), {"cosine": ("exact", 1.0), "mis": ("expect", 1.0),
             "uniform": ("global", 1.0), "mixture": ("global", 1.0)})]
    scene = get_scene("furnace", width=width, height=width)
    exact = expected_radiance(max_depth=scene.max_depth)
    direct = expected_radiance(max_depth=min(2, scene.max_depth))   # Le (1 + rho)
    assert abs(direct - RADIANCE * (1 + ALBEDO)) < 1e-12 or scene.max_depth < 2
    plan.append(("suite furnace", scene, {"cosine": ("exact", exact), "light": ("exact", direct),
                 "mixture": ("exact", exact), "mis": ("exact", exact), "uniform": ("global", exact)}))
    out, nonfinite, passed = {}, 0, True
    for name, scene, tests in plan:
        for i, (strategy, (mode, value)) in enumerate(tests.items()):
            r = rt.render(scene, spp=spp, strategy=strategy, seed=seed + 7 * i, threads=2)
            nonfinite += r.nonfinite_samples
            entry = {"mode": mode, "exact": value, "mean": float(r.mean.mean()), "min": float(r.mean.min()),
                     "max": float(r.mean.max())}
            if mode == "exact":
                # float32 image of a double sum of identical samples: equal to 1e-6 relative
                rel = np.abs(r.mean.astype(np.float64) / value - 1.0)
                entry["pixels_off"] = int((rel > 1e-6).sum())
                entry["max_rel_error"] = float(rel.max())
                entry["passed"] = entry["pixels_off"] == 0
            else:
                zt = constant_ztest(r, value, local=(mode == "expect"))
                entry.update(z_global=zt["z_global"][0], z_limit=zt["z_global_limit"], outliers=zt["outliers"],
                             outlier_limit=zt["outlier_limit"] if mode == "expect" else None, passed=zt["passed"])
            out[f"{name}/{strategy}"] = entry
            passed &= entry["passed"]
    passed &= nonfinite == 0
    exact_off = sum(v["pixels_off"] for v in out.values() if v["mode"] == "exact")
    n_exact = sum(v["mode"] == "exact" for v in out.values())
    zs = {k: v["z_global"] for k, v in out.items() if "z_global" in v}
    worst = max(zs, key=lambda k: abs(zs[k]))
    figure = (f"per-sample-exact renders ({n_exact}) pixels off: {exact_off}; in expectation ({len(zs)}): "
              f"max |Z| {abs(zs[worst]):.2f} ({worst}; limit {out[worst]['z_limit']:.2f}); sphere means "
              + ", ".join(f"{s} {out['sphere/' + s]['mean']:.4f}" for s in rt.STRATEGIES))
    return figure, passed, {"renders": out, "nonfinite_samples": nonfinite}
