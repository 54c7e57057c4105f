"""How busy the lanes of a SIMD path tracer would be: path lengths and packet utilisation.

A packet-at-a-time integrator (Mitsuba's ``llvm`` variants run 8 or 16 paths per
instruction) loops until the longest path of its packet ends, so its cost per path is
the expected *maximum* length over a packet, where a path-at-a-time loop pays the
*mean*. :func:`segment_survival` estimates, with our tracer, how many paths reach each
segment (ray counts of renders capped at ``max_depth`` = 1, 2, ...: consecutive
differences estimate the paths that trace a k-th segment; each capped render draws a
different number of random numbers per path, so later samples of a pixel differ and the
differences are estimates, made non-increasing). :func:`packet_utilisation` turns that into the mean
length, the expected packet maximum and their ratio, the fraction of lane-iterations
doing work, for packets of independent paths. Paths of one pixel are correlated (a
packet of 8 consecutive samples of a pixel), so real packets vary less and the
utilisation is somewhat higher than this estimate.

Examples
--------
>>> out = packet_utilisation([1.0, 0.5, 0.25], 2)
>>> out["mean_segments"], out["expected_max"], out["utilisation"]
(1.75, 2.1875, 0.8)
"""
from __future__ import annotations

import dataclasses

import numpy as np

__all__ = ["segment_survival", "packet_utilisation"]


def segment_survival(scene, *, spp: int = 16, seed: int = 0, threads: int = 1) -> np.ndarray:
    """Fraction of paths that trace at least k segments, for k = 1 .. ``scene.max_depth``.

    Parameters
    ----------
    scene : reference_tracer.Scene
        Rendered as is (size, ``rr_depth``), with ``max_depth`` capped at 1, 2, ...; keep
        it small: this renders it ``max_depth`` times.
    spp, seed, threads : int, keyword-only
        Samples per pixel and seed of every capped render; threads.

    Returns
    -------
    numpy.ndarray
        ``S[k - 1]`` ~ paths with >= k segments / all paths (``S[0]`` = 1 exactly; the
        estimate is made non-increasing by a running minimum). Rendered with the ``cosine``
        strategy, which traces one ray per segment and no shadow rays; ``mis``
        continues its paths the same way (material sampling), so the figure is its too.
    """
    import reference_tracer as rt

    if scene.max_depth < 1:
        raise ValueError(f"segment_survival needs a finite max_depth >= 1, got {scene.max_depth}")
    paths = scene.camera.width * scene.camera.height * spp
    rays = [0.0]
    for k in range(1, scene.max_depth + 1):
        capped = dataclasses.replace(scene, max_depth=k)
        rays.append(rt.render(capped, spp=spp, strategy="cosine", seed=seed, threads=threads).rays / paths)
    return np.minimum.accumulate(np.clip(np.diff(np.asarray(rays)), 0.0, 1.0))


def packet_utilisation(survival, width: int) -> dict:
    """Mean path length, expected longest path of a ``width``-lane packet, and their ratio.

    Parameters
    ----------
    survival : sequence of float
        ``S[k - 1]``, the fraction of paths with >= k segments (:func:`segment_survival`).
    width : int
        Lanes per packet (8 for AVX2, 16 for AVX-512).

    Returns
    -------
    dict
        ``mean_segments`` (sum of S), ``expected_max`` (sum of 1 - (1 - S)^width: the
        packet's loop count when its paths are independent) and ``utilisation`` (their
        ratio: the share of lane-iterations that do work; 1 for a compacting wavefront).
    """
    s = np.clip(np.asarray(survival, dtype=float), 0.0, 1.0)
    if width < 1:
        raise ValueError(f"width must be >= 1, got {width}")
    mean = float(s.sum())
    emax = float(np.sum(1.0 - (1.0 - s) ** width))
    return {"mean_segments": mean, "expected_max": emax, "utilisation": mean / emax if emax > 0 else float("nan")}
