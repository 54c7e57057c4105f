"""Case ``fireflies``: on ``small_light``, samples above 100x the image mean, per strategy."""
from __future__ import annotations

import time

import numpy as np

import reference_tracer as rt
from mitsuba_scenes import get_scene

from ..constants import LUMINANCE_WEIGHTS

from .record import StressRecord, make_record

__all__ = ["fireflies", "firefly_counts", "small_light_scene"]


def small_light_scene(*, width: int = 64) -> rt.Scene:
    """The suite's ``small_light`` scene."""
    return get_scene("small_light", width=width, height=width)


def firefly_counts(scene: rt.Scene, *, strategies=rt.STRATEGIES, renders: int = 128, factor: float = 100.0,
                   seed: int = 0) -> dict:
    """Per strategy, the samples of ``renders`` 1-spp renders above ``factor`` times the mean
    of ``mis``'s (``threshold``, ``samples``, ``counts``, ``means``, ``max``), pixels that
    see an emitter directly and their neighbours left out (the light itself)."""
    direct_scene = rt.Scene(camera=scene.camera, shapes=scene.shapes, max_depth=1, background=scene.background)
    direct = rt.render(direct_scene, spp=64, strategy="cosine", seed=seed, threads=2).mean.max(axis=-1) > 0
    grown = direct.copy()
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            grown |= np.roll(np.roll(direct, dy, axis=0), dx, axis=1)
    keep = ~grown
    weights = np.asarray(LUMINANCE_WEIGHTS)
    values, nonfinite = {}, 0
    for si, strategy in enumerate(strategies):
        v = []
        for k in range(renders):
            r = rt.render(scene, spp=1, strategy=strategy, seed=seed * 100_000 + 1000 * si + k, threads=2)
            nonfinite += r.nonfinite_samples
            v.append((r.mean.astype(np.float64) @ weights)[keep])
        values[strategy] = np.concatenate(v)
    ref = values["mis"].mean() if "mis" in values else np.mean([x.mean() for x in values.values()])
    threshold = factor * ref
    return {"threshold": float(threshold), "factor": factor, "excluded_pixels": int(grown.sum()),
            "samples": {s: int(v.size) for s, v in values.items()},
            "counts": {s: int((v > threshold).sum()) for s, v in values.items()},
            "means": {s: float(v.mean()) for s, v in values.items()},
            "max": {s: float(v.max()) for s, v in values.items()}, "nonfinite_samples": nonfinite}


def fireflies(*, width: int = 64, renders: int = 128, factor: float = 100.0, seed: int = 0) -> StressRecord:
    """Fireflies on ``small_light`` (:func:`firefly_counts`): passes when ``uniform`` has at least
    100 times as many as ``mis`` (``uniform >= 100 * max(mis, 1)``)."""
    t0 = time.perf_counter()
    fc = firefly_counts(small_light_scene(width=width), renders=renders, factor=factor, seed=seed)
    c = fc["counts"]
    passed = c["uniform"] >= 100 * max(c["mis"], 1) and fc["nonfinite_samples"] == 0
    n = next(iter(fc["samples"].values()))
    figure = (f"samples > {factor:g}x mean ({fc['threshold']:.2f}) of {n:,}: "
              + ", ".join(f"{s} {c[s]}" for s in fc["counts"]))
    return make_record("fireflies", figure, passed, fc, t0)
