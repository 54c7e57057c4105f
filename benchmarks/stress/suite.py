"""Case ``suite_nonfinite``: every suite scene under every strategy (and every triangle
test for meshes) renders zero NaN/Inf samples."""
from __future__ import annotations

import time

import reference_tracer as rt
from mitsuba_scenes import get_scene, list_scenes

from .record import StressRecord, make_record

__all__ = ["suite_nonfinite"]


def suite_nonfinite(*, width: int = 16, spp: int = 4, seed: int = 0) -> StressRecord:
    """Every suite scene under every strategy (and Cramer's tests for meshes): NaN/Inf samples."""
    t0 = time.perf_counter()
    counts, renders = {}, 0
    for name in list_scenes():
        scene = get_scene(name, width=width, height=width)
        has_tris = any(isinstance(s, (rt.Mesh, rt.Triangle)) for s in scene.shapes)
        for strategy in rt.STRATEGIES:
            for test in (rt.TRIANGLE_TESTS if has_tris else ("watertight",)):
                r = rt.render(scene, spp=spp, strategy=strategy, seed=seed, threads=2, triangle_test=test)
                counts[f"{name}/{strategy}/{test}"] = r.nonfinite_samples
                renders += 1
    total = sum(counts.values())
    figure = f"{total} NaN/Inf samples in {renders} renders of {len(list_scenes())} suite scenes"
    return make_record("suite_nonfinite", figure, total == 0, {"nonfinite": counts, "renders": renders}, t0)
