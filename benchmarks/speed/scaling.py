"""The scaling benchmark: paths/s vs resolution and threads, cost per ray vs triangle count.

Paths/s of a suite scene vs resolution and vs thread count (1 and 2), and cost per ray
(and paths/s of a lit mesh scene) vs triangle count, with the cost fitted as
``a + b ln n`` (:func:`fit_log_growth`): a BVH gives logarithmic growth.

Examples
--------
>>> out = scaling_benchmark(resolutions=(8, 16), spp=1, thread_counts=(1,), triangles=(200, 2000),
...                         rays=1000, mesh_spp=1, variant=None, repeats=1)  # doctest: +SKIP
>>> sorted(out["fits"])  # doctest: +SKIP
['ours_ns_per_ray']
"""
from __future__ import annotations

import functools
import math

import numpy as np

import reference_tracer as rt
from mitsuba_scenes import get_scene, list_scenes
from reference_tracer.probe import core_scene
from reference_tracer.validation import positive_int

from ..constants import STRATEGIES
from ..metrics import convergence_slope

from .common import (check_jit_variant, environment, load_mitsuba, median, mitsuba_render_fn, spread, timed,
                     use_variant)
from .rays import intersect_mitsuba, intersect_ours, mesh_scene, random_rays

__all__ = ["scaling_benchmark", "fit_log_growth"]


def scaling_benchmark(*, scene: str = "cornell_box", resolutions=(32, 64, 128), spp: int = 16,
                      thread_counts=(1, 2), triangles=(1_000, 10_000, 100_000, 1_000_000), rays: int = 1 << 18,
                      mesh_spp: int = 4, strategy: str = "mis", variant: str | None = "llvm_ad_rgb",
                      threads: int = 2, repeats: int = 3, seed: int = 0, log=None) -> dict:
    """Paths/s vs resolution and threads, and cost per ray vs triangle count.

    Parameters
    ----------
    scene : str, keyword-only
        Suite scene for the resolution and thread sweeps.
    resolutions : sequence of int, keyword-only
        Square image sizes (at ``threads``).
    spp : int, keyword-only
        Samples per pixel of the resolution and thread sweeps.
    thread_counts : sequence of int, keyword-only
        Thread counts (at the largest resolution).
    triangles : sequence of int, keyword-only
        Torus sizes for the mesh sweep: random-ray cost (``rays`` rays) and paths/s of a
        lit render of it (``mesh_spp``, 64x64, max_depth 8).
    strategy : str, keyword-only
        Our strategy.
    variant : str or None, keyword-only
        Mitsuba JIT variant for the same sweeps (None: ours only).
    threads, repeats, seed : int, keyword-only

    Returns
    -------
    dict
        ``resolution`` / ``threads`` / ``mesh`` rows (medians over ``repeats``) and
        ``fits``: :func:`fit_log_growth` of ours' (and Mitsuba's) ns per ray on
        triangle count.
    """
    if scene not in list_scenes():
        raise ValueError(f"unknown scene {scene!r}; the suite has: {', '.join(list_scenes())}")
    resolutions = sorted({positive_int("resolution", r) for r in resolutions})
    thread_counts = sorted({positive_int("thread count", t) for t in thread_counts})
    sizes = sorted({positive_int("triangles", t, minimum=32) for t in triangles})
    if len(sizes) < 2:
        raise ValueError("the mesh sweep needs at least two triangle counts")
    spp, mesh_spp, rays = positive_int("spp", spp), positive_int("mesh_spp", mesh_spp), positive_int("rays", rays)
    threads, repeats = positive_int("threads", threads), positive_int("repeats", repeats)
    if strategy not in STRATEGIES:
        raise ValueError(f"strategy must be one of {STRATEGIES}, got {strategy!r}")
    use_mi, skipped = check_jit_variant(variant, "scaling", log)
    mi_variant = variant if use_mi else None
    out = {"config": {"scene": scene, "resolutions": resolutions, "spp": spp, "thread_counts": thread_counts,
                      "triangles": sizes, "rays": rays, "mesh_spp": mesh_spp, "strategy": strategy,
                      "variant": mi_variant, "threads": threads, "repeats": repeats},
           "environment": environment(), "skipped_variants": skipped,
           "resolution": [], "threads": [], "mesh": [], "fits": {}}
    measure = functools.partial(_paths_per_second, strategy=strategy, seed=seed, repeats=repeats,
                                variant=mi_variant)
    base = get_scene(scene)
    out["resolution"] = _resolution_rows(base, resolutions, spp=spp, threads=threads, measure=measure, log=log)
    out["threads"] = _thread_rows(base, thread_counts, resolution=resolutions[-1], spp=spp, measure=measure,
                                  log=log)
    out["mesh"] = _mesh_rows(sizes, rays=rays, mesh_spp=mesh_spp, threads=threads, repeats=repeats, seed=seed,
                             variant=mi_variant, measure=measure, log=log)
    tri = [r["triangles"] for r in out["mesh"]]
    out["fits"]["ours_ns_per_ray"] = fit_log_growth(tri, [r["ours_ns_per_ray"] for r in out["mesh"]])
    if use_mi:
        out["fits"]["mitsuba_ns_per_ray"] = fit_log_growth(tri, [r["mitsuba_ns_per_ray"] for r in out["mesh"]])
    out["environment_after"] = environment()
    return out


def _paths_per_second(sc, *, spp, threads, strategy, seed, repeats, variant) -> dict:
    """Median paths/s (wall and CPU) of ours and, unless ``variant`` is None, Mitsuba on ``sc``.

    Both get a warm-up render first; then ``repeats`` interleaved rounds.
    """
    core_scene(sc)
    rt.render(sc, spp=1, strategy=strategy, seed=1, threads=threads)   # warm-up
    mscene = None
    if variant is not None:
        mscene, _ = load_mitsuba(variant, sc, threads)
        mi, _ = use_variant(variant)
        mitsuba_render_fn(mi, mscene, spp, 7)()   # warm-up (JIT)
    ours, ours_cpu, mits, mits_cpu = [], [], [], []
    paths = sc.camera.width * sc.camera.height * spp
    for r in range(repeats):
        res, _, cpu = timed(lambda: rt.render(sc, spp=spp, strategy=strategy, seed=seed + r, threads=threads))
        ours.append(paths / res.seconds)
        ours_cpu.append(paths / cpu if cpu > 0 else float("nan"))
        if variant is not None:
            mi, _ = use_variant(variant, threads)
            _, wall, cpu = timed(mitsuba_render_fn(mi, mscene, spp, 1000 + r))
            mits.append(paths / wall)
            mits_cpu.append(paths / cpu if cpu > 0 else float("nan"))
    row = {"ours_paths_per_second": median(ours), "ours_paths_per_cpu_second": median(ours_cpu),
           "ours_spread": spread(ours)}
    if variant is not None:
        row.update({"mitsuba_paths_per_second": median(mits), "mitsuba_paths_per_cpu_second": median(mits_cpu),
                    "ratio": median([a / b for a, b in zip(ours, mits)])})
    return row


def _progress(row) -> str:
    """``ours X Mpaths/s[, Mitsuba Y]`` of a sweep row, for the progress log."""
    text = f"ours {row['ours_paths_per_second'] / 1e6:.3f} Mpaths/s"
    if "mitsuba_paths_per_second" in row:
        text += f", Mitsuba {row['mitsuba_paths_per_second'] / 1e6:.3f}"
    return text


def _resolution_rows(base, resolutions, *, spp, threads, measure, log) -> list:
    """Paths/s of ``base`` at each square resolution."""
    rows = []
    for res in resolutions:
        row = {"resolution": res, "threads": threads, "spp": spp,
               **measure(base.with_camera_size(res, res), spp=spp, threads=threads)}
        rows.append(row)
        if log:
            log(f"resolution {res}: {_progress(row)}")
    return rows


def _thread_rows(base, thread_counts, *, resolution, spp, measure, log) -> list:
    """Paths/s of ``base`` at ``resolution`` for each thread count, with the speed-up over 1 thread."""
    top = base.with_camera_size(resolution, resolution)
    rows = []
    for t in thread_counts:
        row = {"threads": t, "resolution": resolution, "spp": spp, **measure(top, spp=spp, threads=t)}
        rows.append(row)
        if log:
            log(f"{t} thread(s): {_progress(row)}")
    one = {r["threads"]: r for r in rows}
    if 1 in one:
        for r in rows:
            r["ours_speedup"] = r["ours_paths_per_second"] / one[1]["ours_paths_per_second"]
            if "mitsuba_paths_per_second" in r:
                r["mitsuba_speedup"] = r["mitsuba_paths_per_second"] / one[1]["mitsuba_paths_per_second"]
    return rows


def _mesh_rows(sizes, *, rays, mesh_spp, threads, repeats, seed, variant, measure, log) -> list:
    """Random-ray cost and lit-render paths/s of a torus of each size (Mitsuba's too unless None)."""
    rows = []
    for n_target in sizes:
        lit = mesh_scene(n_target, seed=seed, lit=True)
        ntri = int(len(lit.shapes[0].faces))
        core = core_scene(lit)
        o, d = random_rays(rays, seed=seed)
        ours = intersect_ours(core, o, d, threads=threads, repeats=repeats)
        row = {"triangles": ntri, "rays": len(o), "threads": threads,
               "build_seconds": float(core.build_seconds), "bvh_depth": int(core.bvh_depth),
               "ours_ns_per_ray": median(ours["seconds"]) / len(o) * 1e9}
        if variant is not None:
            mscene, load = load_mitsuba(variant, lit, threads, check_merge=False)
            mres = intersect_mitsuba(mscene, o, d, repeats=repeats)
            row.update({"mitsuba_ns_per_ray": median(mres["seconds"]) / len(o) * 1e9,
                        "mitsuba_load_seconds": load})
        row.update(measure(lit, spp=mesh_spp, threads=threads))
        rows.append(row)
        lit._core_cache.clear()
        if log:
            log(f"{ntri} triangles: ours {row['ours_ns_per_ray']:.0f} ns/ray, "
                f"{row['ours_paths_per_second'] / 1e6:.3f} Mpaths/s"
                + (f"; Mitsuba {row['mitsuba_ns_per_ray']:.0f} ns/ray" if variant is not None else ""))
    return rows


def fit_log_growth(n, cost) -> dict:
    """Fit ``cost = a + b ln n`` (least squares) and the log-log exponent of ``cost`` on ``n``.

    A BVH gives logarithmic growth: ``b`` > 0 with a good ``r2`` and a log-log exponent
    far below 1 (linear growth would give 1).

    Returns
    -------
    dict
        ``a``, ``b`` (cost per e-fold of ``n``), ``per_doubling`` (``b ln 2``), ``r2``,
        ``loglog_exponent``.

    Examples
    --------
    >>> f = fit_log_growth([1e3, 1e4, 1e5], [10 + 2 * np.log(x) for x in (1e3, 1e4, 1e5)])
    >>> round(f["b"], 6), round(f["r2"], 6)
    (2.0, 1.0)
    """
    n = np.asarray(n, dtype=np.float64)
    x = np.log(n)
    y = np.asarray(cost, dtype=np.float64)
    if x.shape != y.shape or x.size < 2 or not np.all(np.isfinite(x)) or not np.all(np.isfinite(y)):
        raise ValueError("fit_log_growth needs at least two finite (n, cost) pairs of equal length")
    b, a = np.polyfit(x, y, 1)
    pred = a + b * x
    ss = float(np.sum((y - y.mean()) ** 2))
    r2 = 1.0 - float(np.sum((y - pred) ** 2)) / ss if ss > 0 else 1.0
    expo = convergence_slope(n, y).slope if np.all(y > 0) and np.ptp(x) > 0 else float("nan")
    return {"a": float(a), "b": float(b), "per_doubling": float(b * math.log(2)), "r2": r2,
            "loglog_exponent": expo}
