"""Case ``fireflies``: on ``small_light``, samples above 100x the image mean, per strategy."""
from __future__ import annotations

import numpy as np
from scipy import ndimage

import reference_tracer as rt
from mitsuba_scenes import get_scene

from ..constants import LUMINANCE_WEIGHTS

from .record import stress_case

__all__ = ["fireflies", "firefly_counts"]


def firefly_counts(scene: rt.Scene, *, strategies=rt.STRATEGIES, renders: int = 128, factor: float = 100.0,
                   seed: int = 0) -> dict:
    """Per strategy, the samples of ``renders`` 1-spp renders above ``factor`` times the mean
    of ``mis``'s (``threshold``, ``samples``, ``counts``, ``means``, ``max``), pixels that
    see an emitter directly and their neighbours left out (the light itself). ``ValueError``
    where ``strategies`` leaves out ``mis`` (the threshold's measure) or ``renders`` < 1."""
    strategies = tuple(strategies)
    if "mis" not in strategies:
        raise ValueError(f"firefly_counts needs 'mis' among the strategies (the threshold is {factor:g}x its "
                         f"mean), got {', '.join(strategies) or 'none'}")
    if renders < 1:
        raise ValueError(f"renders must be at least 1, got {renders}")
    direct_scene = rt.Scene(camera=scene.camera, shapes=scene.shapes, max_depth=1, background=scene.background)
    direct = rt.render(direct_scene, spp=64, strategy="cosine", seed=seed, threads=2).mean.max(axis=-1) > 0
    grown = ndimage.maximum_filter(direct, size=3, mode="wrap")   # and the 8 neighbours, across the borders
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
    threshold = factor * values["mis"].mean()
    return {"threshold": float(threshold), "factor": factor, "excluded_pixels": int(grown.sum()),
            "samples": {s: int(v.size) for s, v in values.items()},
            "counts": {s: int((v > threshold).sum()) for s, v in values.items()},
            "means": {s: float(v.mean()) for s, v in values.items()},
            "max": {s: float(v.max()) for s, v in values.items()}, "nonfinite_samples": nonfinite}


@stress_case
def fireflies(*, width: int = 64, renders: int = 128, factor: float = 100.0, seed: int = 0):
    """Fireflies on ``small_light`` (:func:`firefly_counts`): passes when ``uniform`` has at least
    100 times as many as ``mis`` (``uniform >= 100 * max(mis, 1)``)."""
    fc = firefly_counts(get_scene("small_light", width=width, height=width), renders=renders, factor=factor, seed=seed)
    c = fc["counts"]
    passed = c["uniform"] >= 100 * max(c["mis"], 1) and fc["nonfinite_samples"] == 0
    n = next(iter(fc["samples"].values()))
    figure = (f"samples > {factor:g}x mean ({fc['threshold']:.2f}) of {n:,}: "
              + ", ".join(f"{s} {c[s]}" for s in fc["counts"]))
    return figure, passed, fc
