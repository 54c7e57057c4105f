"""Case ``watertight_mesh``: rays from inside closed meshes through their edges and vertices."""
from __future__ import annotations

import inspect

import numpy as np

import reference_tracer as rt

from .probes import count_escapes, edge_and_vertex_rays, icosphere, probe_scene
from .record import stress_case

__all__ = ["watertight_mesh"]


@stress_case
def watertight_mesh(*, rays: int = 100_000, subdivisions=(1, 2, 3, 4), seed: int = 0,
                    render_width: int = 32):
    """Rays from inside closed icospheres aimed exactly at shared edges and vertices.

    Counts the escapes of each triangle test of ``rt.TRIANGLE_TESTS``: the watertight test
    (Woop, Benthin and Wald 2013) must leak none and be ``rt.render``'s default; a black
    icosphere around the camera in a white background must render black.

    Parameters
    ----------
    rays : int
        Rays per triangle test, split evenly over the ``subdivisions`` levels (20 * 4^s faces).
    render_width : int
        Image size of the leak render (4 spp per level).
    """
    rng = np.random.default_rng(seed)
    per = max(1, rays // len(subdivisions))
    escapes = {t: 0 for t in rt.TRIANGLE_TESTS}
    by_level, nan, leak_pixels, nonfinite = {}, 0, 0, 0
    for level in subdivisions:
        V, F, E = icosphere(level)
        # An eighth from the exact centre, the rest from random points inside r = 0.6.
        origins = rng.normal(size=(per, 3))
        origins *= (0.6 * rng.random(per) ** (1 / 3) / np.linalg.norm(origins, axis=1))[:, None]
        origins[: per // 8] = 0.0
        dirs, kind = edge_and_vertex_rays(V, E, origins, rng)
        scene = probe_scene([rt.Mesh(V, F, rt.Lambertian(0.0))], background=1.0, lookfrom=(0.1, 0.05, -0.2),
                            lookat=(0.3, -0.2, 1.0), width=render_width)
        by_level[level] = {"faces": int(len(F))}
        for test in rt.TRIANGLE_TESTS:
            r = count_escapes(scene, origins, dirs, triangle_test=test)
            escapes[test] += r["escapes"]
            nan += r["nan"] + r["nonfinite_hits"]
            by_level[level][test] = {"escapes": r["escapes"],
                                     "edge": int(r["escaped"][kind < 2].sum()),
                                     "vertex": int(r["escaped"][kind == 2].sum())}
        img = rt.render(scene, spp=4, strategy="cosine", seed=seed, threads=1)
        leak_pixels += int((img.mean.max(axis=-1) > 0).sum())
        nonfinite += img.nonfinite_samples
    default = inspect.signature(rt.render).parameters["triangle_test"].default
    total = per * len(subdivisions)
    passed = escapes[default] == 0 and default == "watertight" and nan == 0 and leak_pixels == 0 \
        and nonfinite == 0
    figure = (f"escapes of {total:,} edge/vertex rays: " +
              ", ".join(f"{t} {escapes[t]:,}" for t in ("cramer32", "cramer", "watertight")) +
              f" (default {default}); leak pixels {leak_pixels}")
    details = {"rays_per_test": total, "escapes": escapes, "by_level": by_level, "default": default,
               "nan": nan, "leak_pixels": leak_pixels, "nonfinite_samples": nonfinite}
    return figure, passed, details
