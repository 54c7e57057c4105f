"""The registry of hard cases (:data:`CASES`: quick and full settings), :func:`run_cases`, and
the case ``suite_nonfinite``: every suite scene under every strategy renders no NaN/Inf sample."""
from __future__ import annotations

import reference_tracer as rt
from mitsuba_scenes import get_scene, list_scenes

from .degenerate import degenerate_input
from .fireflies import fireflies
from .furnace import white_furnace
from .glass import glass
from .grazing import grazing_rays
from .lights import light_sampling
from .record import stress_case
from .scale import scale_invariance
from .watertight import watertight_mesh

__all__ = ["CASES", "run_cases", "suite_nonfinite"]


@stress_case
def suite_nonfinite(*, width: int = 16, spp: int = 4, seed: int = 0):
    """Every suite scene under every strategy (and every triangle test for meshes): NaN/Inf samples."""
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
    return figure, total == 0, {"nonfinite": counts, "renders": renders}


#: case -> (function, quick keyword arguments, full keyword arguments)
CASES = {
    "watertight_mesh": (watertight_mesh, dict(rays=100_000, subdivisions=(1, 2, 3, 4)),
                        dict(rays=4_000_000, subdivisions=(1, 2, 3, 4, 5, 6))),
    "grazing_rays": (grazing_rays, dict(shapes=25, rays_per_shape=80), dict(shapes=100, rays_per_shape=100)),
    "degenerate_input": (degenerate_input, dict(coincident=100_000), dict(coincident=100_000, repeats=5)),
    "scale_invariance": (scale_invariance, dict(width=32, spp=64),
                         dict(width=48, spp=256, strategies=("mis", "cosine", "mixture"), furnace_spp=32)),
    "light_sampling": (light_sampling, dict(samples=100_000), dict(samples=1_000_000, width=32, spp=256)),
    "glass": (glass, dict(width=32, spp=32), dict(width=64, spp=64, compare_spp=512, compare_width=32)),
    "white_furnace": (white_furnace, dict(width=24, spp=64), dict(width=48, spp=256)),
    "fireflies": (fireflies, dict(width=64, renders=128), dict(width=64, renders=512)),
    "suite_nonfinite": (suite_nonfinite, dict(width=16, spp=4), dict(width=32, spp=16)),
}


def run_cases(names=None, *, quick: bool = False, on_record=None) -> list:
    """The :class:`~.record.StressRecord` of each named case (all by default), run with its quick
    or full settings; ``on_record`` is called with each as it completes. Unknown names are
    refused before any case runs:

    >>> run_cases(["no_such_case"])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: unknown stress case(s) ['no_such_case']; known: watertight_mesh, grazing_rays, ...
    """
    names = list(CASES) if names is None else list(names)
    unknown = [n for n in names if n not in CASES]
    if unknown:
        raise ValueError(f"unknown stress case(s) {unknown}; known: {', '.join(CASES)}")
    records = []
    for name in names:
        fn, quick_kw, full_kw = CASES[name]
        records.append(fn(**(quick_kw if quick else full_kw)))
        if on_record is not None:
            on_record(records[-1])
    return records
