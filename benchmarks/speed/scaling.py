"""The scaling benchmark (``rtbench speed --scaling``): paths/s of ours beside Mitsuba against image size, maximum
depth, threads and a lit torus's triangle count, with build or load times and the cost a random ray fitted as
``a + b ln n`` (:func:`fit_log_growth`), so a user sees where each one's cost grows."""
from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np

import reference_tracer as rt
from mitsuba_scenes import get_scene, list_scenes
from reference_tracer.probe import core_scene
from reference_tracer.validation import positive_int

from ..constants import STRATEGIES
from ..metrics import convergence_slope
from .common import check_jit_variant, environment, load_mitsuba, median, mitsuba_render_timed, spread, timed
from .rays import MIN_TRIANGLES, intersect_mitsuba, intersect_ours, mesh_scene, random_rays

__all__ = ["AXES", "scaling_benchmark", "fit_log_growth"]

#: the sweeps of a suite scene: result key, the row field it varies, its label.
AXES = (("resolution", "resolution", "image size (square)"), ("depth", "max_depth", "max depth"),
        ("threads", "threads", "threads"))


def scaling_benchmark(*, scene: str = "cornell_box", resolutions=(32, 64, 128, 256, 512), depths=(2, 5, 10, 20, 50),
                      spp: int = 16, thread_counts=(1, 2), triangles=(1_000, 10_000, 100_000, 1_000_000),
                      rays: int = 1 << 18, mesh_spp: int = 4, strategy: str = "mis",
                      variant: str | None = "llvm_ad_rgb", threads: int = 2, repeats: int = 3, seed: int = 0,
                      log=None) -> dict:
    """Paths/s against image size, max depth, threads and triangle count; ours and Mitsuba.

    Parameters
    ----------
    scene : str, keyword-only
        Suite scene of the image-size, depth and thread sweeps.
    resolutions, depths, thread_counts : sequence of int, keyword-only
        Square image sizes; maximum depths and thread counts, at the middle image size.
    spp, threads : int, keyword-only
        Samples per pixel of those sweeps; threads of all but the thread sweep.
    triangles : sequence of int, keyword-only
        At least two torus sizes: build times, random-ray cost (``rays`` rays) and paths/s of a lit 64x64 render of it
        (``mesh_spp``).
    strategy, variant : str, keyword-only
        Our strategy; Mitsuba's JIT variant (None: ours only).
    repeats, seed : int, keyword-only

    Returns
    -------
    dict
        ``config``, ``environment``, rows of ``resolution``, ``depth``, ``threads`` (``resolution``, ``max_depth``,
        ``threads``, ours' and Mitsuba's paths/s wall and CPU, ``ratio``; ``*_speedup`` over one thread) and ``mesh``
        (``triangles``, ``build_seconds``, ``mitsuba_load_seconds``, ``*_ns_per_ray``, paths/s), and ``fits``
        (:func:`fit_log_growth` of the ns a ray on triangle count).
    """
    if scene not in list_scenes():
        raise ValueError(f"unknown scene {scene!r}; the suite has: {', '.join(list_scenes())}")
    resolutions, depths, thread_counts, sizes = (
        sorted({positive_int(what, x, minimum=low) for x in xs}) for what, xs, low in (
            ("resolution", resolutions, 1), ("max depth", depths, 1), ("thread count", thread_counts, 1),
            ("triangles", triangles, MIN_TRIANGLES)))
    if len(sizes) < 2:
        raise ValueError("the mesh sweep needs at least two triangle counts")
    spp, mesh_spp, rays = positive_int("spp", spp), positive_int("mesh_spp", mesh_spp), positive_int("rays", rays)
    threads, repeats = positive_int("threads", threads), positive_int("repeats", repeats)
    if strategy not in STRATEGIES:
        raise ValueError(f"strategy must be one of {STRATEGIES}, got {strategy!r}")
    use_mi, skipped = check_jit_variant(variant, "scaling", log)
    variant, sides = (variant, ("ours", "mitsuba")) if use_mi else (None, ("ours",))
    out = {"config": {"scene": scene, "resolutions": resolutions, "depths": depths, "spp": spp,
                      "thread_counts": thread_counts, "triangles": sizes, "rays": rays, "mesh_spp": mesh_spp,
                      "strategy": strategy, "variant": variant, "threads": threads, "repeats": repeats},
           "environment": environment(), "skipped_variants": skipped, "fits": {}}
    base = get_scene(scene)
    middle = base.with_camera_size(resolutions[len(resolutions) // 2], resolutions[len(resolutions) // 2])
    sweeps = {"resolution": [(base.with_camera_size(r, r), threads) for r in resolutions],
              "depth": [(dataclasses.replace(middle, max_depth=d), threads) for d in depths],
              "threads": [(middle, t) for t in thread_counts]}
    for key, field, _ in AXES:
        out[key] = []
        for sc, t in sweeps[key]:
            row = {"resolution": sc.camera.width, "max_depth": sc.max_depth, "threads": t, "spp": spp,
                   **_measure(sc, spp=spp, threads=t, strategy=strategy, seed=seed, repeats=repeats, variant=variant)}
            out[key].append(row)
            if log:
                log(f"{field} {row[field]}: {_progress(row)}")
    one = [r for r in out["threads"] if r["threads"] == 1]
    for r, who in itertools.product(out["threads"] if one else [], sides):
        r[f"{who}_speedup"] = r[f"{who}_paths_per_second"] / one[0][f"{who}_paths_per_second"]
    out["mesh"] = [_mesh_row(n, rays=rays, mesh_spp=mesh_spp, threads=threads, strategy=strategy, repeats=repeats,
                             seed=seed, variant=variant, log=log) for n in sizes]
    for who in sides:
        out["fits"][f"{who}_ns_per_ray"] = fit_log_growth([r["triangles"] for r in out["mesh"]],
                                                          [r[f"{who}_ns_per_ray"] for r in out["mesh"]])
    out["environment_after"] = environment()
    return out


def _measure(sc, *, spp, threads, strategy, seed, repeats, variant) -> dict:
    """Median paths/s (wall and CPU) of ours and, unless ``variant`` is None, Mitsuba on ``sc``: a warm-up render each
    (our tree, Mitsuba's JIT), then ``repeats`` interleaved rounds."""
    renders = {"ours": lambda r: timed(lambda: rt.render(sc, spp=spp, strategy=strategy, seed=seed + r,
                                                         threads=threads))}
    if variant is not None:
        mscene, _ = load_mitsuba(variant, sc, threads)
        renders["mitsuba"] = lambda r: mitsuba_render_timed(variant, mscene, spp=spp, seed=1000 + r, threads=threads)
    paths, got = sc.camera.width * sc.camera.height * spp, {who: [] for who in renders}
    for r in [repeats, *range(repeats)]:   # the first: the warm-up
        for who, render in renders.items():
            res, wall, cpu = render(r)
            got[who] += [] if r == repeats else [(paths / (res.seconds if who == "ours" else wall),
                                                  paths / cpu if cpu > 0 else float("nan"))]
    row = {"ours_spread": spread([w for w, _ in got["ours"]])}
    for who, pairs in got.items():
        row.update({f"{who}_paths_per_second": median(w for w, _ in pairs),
                    f"{who}_paths_per_cpu_second": median(c for _, c in pairs)})
    if variant is not None:
        row["ratio"] = median(a[0] / b[0] for a, b in zip(got["ours"], got["mitsuba"]))
    return row


def _progress(row) -> str:
    """``ours X Mpaths/s[, Mitsuba Y]`` of a sweep row, for the progress log."""
    text = f"ours {row['ours_paths_per_second'] / 1e6:.3f} Mpaths/s"
    if "mitsuba_paths_per_second" in row:
        text += f", Mitsuba {row['mitsuba_paths_per_second'] / 1e6:.3f}"
    return text


def _mesh_row(n_target, *, rays, mesh_spp, threads, strategy, repeats, seed, variant, log) -> dict:
    """Build times, random-ray cost and lit-render paths/s of the torus of ``n_target`` triangles."""
    lit = mesh_scene(n_target, seed=seed, lit=True)
    core = core_scene(lit)
    o, d = random_rays(rays, seed=seed)
    row = {"triangles": int(len(lit.shapes[0].faces)), "rays": len(o), "threads": threads,
           "build_seconds": float(core.build_seconds), "bvh_depth": int(core.bvh_depth),
           "ours_ns_per_ray": median(intersect_ours(core, o, d, threads=threads)["seconds"]
                                     for _ in range(repeats)) / len(o) * 1e9}
    if variant is not None:
        mscene, load = load_mitsuba(variant, lit, threads, check_merge=False)
        row.update({"mitsuba_ns_per_ray": median(intersect_mitsuba(mscene, o, d)["seconds"] for _ in range(repeats))
                    / len(o) * 1e9, "mitsuba_load_seconds": load})
    row.update(_measure(lit, spp=mesh_spp, threads=threads, strategy=strategy, seed=seed, repeats=repeats,
                        variant=variant))
    lit._core_cache.clear()
    if log:
        log(f"{row['triangles']} triangles: ours build {row['build_seconds']:.3f} s, {row['ours_ns_per_ray']:.0f} "
            f"ns/ray; {_progress(row)}" + (f"; Mitsuba {row['mitsuba_ns_per_ray']:.0f} ns/ray" if variant else ""))
    return row


def fit_log_growth(n, cost) -> dict:
    """Fit ``cost = a + b ln n`` (least squares) and the log-log exponent of ``cost`` on ``n`` (a BVH: ``b`` > 0, a
    good ``r2``, an exponent far below linear growth's 1): ``a``, ``b``, ``per_doubling`` (``b ln 2``), ``r2``,
    ``loglog_exponent``.

    >>> f = fit_log_growth([1e3, 1e4, 1e5], [10 + 2 * np.log(x) for x in (1e3, 1e4, 1e5)])
    >>> round(f["b"], 6), round(f["r2"], 6)
    (2.0, 1.0)
    """
    n = np.asarray(n, dtype=np.float64)
    x, y = np.log(n), np.asarray(cost, dtype=np.float64)
    if x.shape != y.shape or x.size < 2 or not np.all(np.isfinite(x)) or not np.all(np.isfinite(y)):
        raise ValueError("fit_log_growth needs at least two finite (n, cost) pairs of equal length")
    b, a = np.polyfit(x, y, 1)
    ss = float(np.sum((y - y.mean()) ** 2))
    r2 = 1.0 - float(np.sum((y - a - b * x) ** 2)) / ss if ss > 0 else 1.0
    expo = convergence_slope(n, y).slope if np.all(y > 0) and np.ptp(x) > 0 else float("nan")
    return {"a": float(a), "b": float(b), "per_doubling": float(b * math.log(2)), "r2": r2, "loglog_exponent": expo}
