"""Speed measurements: ours vs Mitsuba 3 on renders and on raw ray casting (issue 9).

Three measurements, each a plain function returning a JSON-able dict:

:func:`render_benchmark`
    Each scene rendered by our tracer (each strategy) and by Mitsuba's ``path``
    integrator (each available variant) at the same resolution, spp, ``max_depth``,
    Russian roulette and thread count. Mitsuba gets one untimed warm-up render per
    variant first (JIT kernels compile and are cached; the warm-up's extra time is
    reported as ``compile_seconds``); ours gets one small warm-up too. Then ``repeats``
    rounds, each running every configuration once, interleaved (ours, Mitsuba, ours, ...)
    so that a change in machine load hits both sides of a pair alike. Ratios are
    medians over the rounds of the per-round ratio (paired).
:func:`ray_benchmark`
    Closest-hit queries on a generated noisy torus of ~100k / ~1M triangles with
    primary (camera) and random rays: ours (``core_scene(...).intersect``) vs Mitsuba's
    ``scene.ray_intersect_preliminary`` (Embree) on the *same* rays (generated in
    float32, passed as float64 to ours), in Mrays/s; hit/miss and distance agreement;
    BVH build time per million triangles (ours) and Mitsuba's scene load time.
:func:`scaling_benchmark`
    Paths/s vs resolution, vs thread count (1 and 2), and cost per ray (and paths/s of
    a lit mesh scene) vs triangle count, with the cost fitted as ``a + b ln n``.

Timing
------
Every timed call records wall time (``time.perf_counter``) and process CPU time
(``time.process_time``: all threads of this process, Dr.Jit's worker threads
included). The machine these run on may be shared: wall-clock figures are then noisy
and biased by other load, and ``cpu/wall`` below the thread count shows contention (or
idle workers). CPU-time throughputs (``paths_per_cpu_second``) are reported beside the
wall-clock ones for that reason. Speed is measured and reported, never asserted.

Examples
--------
>>> from benchmarks.speed import render_benchmark
>>> out = render_benchmark(["cornell_box"], width=16, height=16, spp=4, repeats=1,
...                        strategies=("mis",), variants=("scalar_rgb",),
...                        reference="ours", reference_spp=64)  # doctest: +SKIP
>>> sorted(out["summary"][0])[:3]  # doctest: +SKIP
['cpu_over_wall', 'efficiency', 'label']
"""
from __future__ import annotations

import math
import os
import platform
import statistics
import time

import numpy as np

__all__ = ["WALL_CLOCK_NOTE", "DEFAULT_STRATEGIES", "DEFAULT_VARIANTS", "REFERENCE_KINDS",
           "render_benchmark", "ray_benchmark", "scaling_benchmark",
           "torus_mesh", "mesh_scene", "primary_rays", "random_rays",
           "intersect_ours", "intersect_mitsuba", "hit_agreement", "fit_log_growth",
           "environment"]

#: printed under every table and stored in every JSON.
WALL_CLOCK_NOTE = ("wall-clock figures are noisy when the machine is shared (other processes steal "
                   "cores); process CPU time (all threads) is recorded beside them; cpu/wall well below "
                   "the thread count means contention or idle workers")
#: our strategies, the one matched to Mitsuba's ``path`` integrator first.
DEFAULT_STRATEGIES = ("mis", "mixture", "cosine", "uniform", "light")
#: Mitsuba variants compared against, the bar first.
DEFAULT_VARIANTS = ("llvm_ad_rgb", "scalar_rgb")
#: where the error reference comes from: a (cached) high-spp Mitsuba render via
#: ``benchmarks.references``, or a high-spp render of ours (``mis``).
REFERENCE_KINDS = ("mitsuba", "ours")


# --------------------------------------------------------------------------- helpers

def _int(name, value, minimum=1):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def _names(name, values, allowed=None):
    if isinstance(values, str):
        values = [v for v in values.split(",") if v]
    values = list(values)
    if not values:
        raise ValueError(f"{name} must name at least one entry")
    if allowed is not None:
        bad = [v for v in values if v not in allowed]
        if bad:
            raise ValueError(f"unknown {name} {bad}; choose from {', '.join(allowed)}")
    if len(set(values)) != len(values):
        raise ValueError(f"{name} has duplicates: {values}")
    return values


def _median(xs):
    xs = [x for x in xs if x is not None and math.isfinite(x)]
    return statistics.median(xs) if xs else float("nan")


def _spread(xs):
    """(max - min) / median of positive finite values; NaN for fewer than two."""
    xs = [x for x in xs if x is not None and math.isfinite(x)]
    if len(xs) < 2:
        return float("nan")
    m = statistics.median(xs)
    return (max(xs) - min(xs)) / m if m > 0 else float("nan")


def _timed(fn):
    """``(result, wall_seconds, cpu_seconds)`` of ``fn()``."""
    c0, t0 = time.process_time(), time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t0, time.process_time() - c0


def environment() -> dict:
    """Machine and software identity for a JSON record (load average included).

    Examples
    --------
    >>> sorted(environment())[:3]
    ['cpu_count', 'loadavg', 'machine']
    """
    import reference_tracer as rt

    try:
        load = list(os.getloadavg())
    except OSError:
        load = None
    cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return {"cpu_count": cpus, "loadavg": load, "machine": platform.machine(),
            "python": platform.python_version(), "reference_tracer": getattr(rt, "__version__", None),
            "note": WALL_CLOCK_NOTE}


def _use_variant(variant):
    """Select ``variant``; ``(mitsuba, drjit)`` modules, or raise RuntimeError/ValueError."""
    from mitsuba_scenes.variants import select_variant

    select_variant(variant)
    import drjit as dr
    import mitsuba as mi

    return mi, dr


def _available_variants(variants, log):
    """The working subset of ``variants`` and ``{variant: reason}`` for the rest.

    A variant named in ``variants`` that is not compiled in or does not run here (e.g.
    no usable libLLVM) is skipped with its reason; LLVM is selected first because Dr.Jit
    reads the libLLVM path when it is first imported.
    """
    ok, skipped = [], {}
    for v in sorted(variants, key=lambda v: not v.startswith("llvm")):
        try:
            _use_variant(v)
            ok.append(v)
        except (RuntimeError, ValueError) as exc:
            skipped[v] = str(exc)
            if log:
                log(f"Mitsuba {v}: skipped ({exc})")
    return [v for v in variants if v in ok], skipped


def _mitsuba_versions():
    from mitsuba_scenes.variants import versions

    v = versions()
    return {"mitsuba": v["mitsuba"], "drjit": v["drjit"], "libllvm": os.environ.get("DRJIT_LIBLLVM_PATH")}


def _mse_pair(img, ref):
    """``(mse, mse_corrected)`` of ``img`` against ``ref`` (a dict with mean/variance/spp)."""
    from benchmarks.metrics import mse, mse_corrected

    raw = mse(img, ref["mean"])
    corr = mse_corrected(img, ref["mean"], ref["variance"], ref["spp"])
    return raw, corr


def _efficiency(mse_value, seconds):
    """1 / (MSE * seconds); NaN when the (noise-corrected) MSE is not positive."""
    from benchmarks.metrics import efficiency

    if not (math.isfinite(mse_value) and mse_value > 0 and seconds > 0):
        return float("nan")
    return efficiency(mse_value, seconds)


# --------------------------------------------------------------------------- renders

def _reference(scene, *, kind, spp, variant, threads, cache, log):
    """The error reference: dict(mean, variance, spp, kind, label, cached, seconds)."""
    import reference_tracer as rt

    if kind == "mitsuba":
        from benchmarks.references import reference

        t0 = time.perf_counter()
        ref = reference(scene, spp=spp, variant=variant, threads=threads, cache=cache, log=log)
        took = time.perf_counter() - t0
        if log and not ref.cached:
            log(f"  reference: rendered Mitsuba {ref.variant} {spp} spp in {took:.1f} s (now cached)")
        return {"mean": ref.mean, "variance": ref.variance, "spp": ref.spp, "kind": "mitsuba",
                "variant": ref.variant, "cached": bool(ref.cached), "seconds": took,
                "label": f"Mitsuba {ref.variant} {ref.spp} spp ({'cached' if ref.cached else 'rendered now'})"}
    r = rt.render(scene, spp=spp, strategy="mis", seed=0xC0FFEE, threads=threads)
    return {"mean": r.mean, "variance": r.variance, "spp": spp, "kind": "ours", "variant": None,
            "cached": False, "seconds": r.seconds, "label": f"ours (mis) {spp} spp, rendered now"}


def _ours_run(scene, *, spp, strategy, seed, threads, ref):
    import reference_tracer as rt

    r, wall, cpu = _timed(lambda: rt.render(scene, spp=spp, strategy=strategy, seed=seed, threads=threads))
    h, w, _ = r.mean.shape
    paths = h * w * spp
    raw, corr = _mse_pair(r.mean, ref)
    return {"seconds": r.seconds, "call_seconds": wall, "process_seconds": cpu, "paths": paths,
            "paths_per_second": paths / r.seconds, "paths_per_cpu_second": paths / cpu if cpu > 0 else float("nan"),
            "rays": r.rays, "rays_per_second": r.rays / r.seconds, "ms_per_spp": 1e3 * r.seconds / spp,
            "cpu_over_wall": cpu / wall if wall > 0 else float("nan"), "mse": raw, "mse_corrected": corr,
            "rmse": math.sqrt(raw), "efficiency": _efficiency(corr, r.seconds),
            "nonfinite_samples": r.nonfinite_samples}


def _mitsuba_render_fn(mi, mscene, spp, seed):
    def go():
        img = mi.render(mscene, spp=int(spp), seed=int(seed))
        return np.array(img, dtype=np.float64)   # forces evaluation and waits for it
    return go


def _mitsuba_run(variant, mscene, *, spp, seed, threads, ref, shape):
    mi, dr = _use_variant(variant)
    dr.set_thread_count(int(threads))
    img, wall, cpu = _timed(_mitsuba_render_fn(mi, mscene, spp, seed))
    if img.shape != shape:
        raise RuntimeError(f"Mitsuba returned an image of shape {img.shape}, expected {shape}")
    h, w, _ = img.shape
    paths = h * w * spp
    raw, corr = _mse_pair(img, ref)
    return {"seconds": wall, "call_seconds": wall, "process_seconds": cpu, "paths": paths,
            "paths_per_second": paths / wall, "paths_per_cpu_second": paths / cpu if cpu > 0 else float("nan"),
            "rays": None, "rays_per_second": None, "ms_per_spp": 1e3 * wall / spp,
            "cpu_over_wall": cpu / wall if wall > 0 else float("nan"), "mse": raw, "mse_corrected": corr,
            "rmse": math.sqrt(raw), "efficiency": _efficiency(corr, wall),
            "nonfinite_samples": int(np.sum(~np.isfinite(img)))}


def _load_mitsuba(variant, scene, threads):
    """Load ``scene`` in ``variant`` and warm it up; ``(mscene, info)``."""
    from mitsuba_scenes import to_mitsuba
    from mitsuba_scenes.render import mesh_merge_safe

    mi, dr = _use_variant(variant)
    dr.set_thread_count(int(threads))
    mscene, load, _ = _timed(lambda: mi.load_dict(to_mitsuba(scene), optimize=mesh_merge_safe(scene)))
    return mscene, {"load_seconds": load}


def render_benchmark(scenes=("cornell_box",), *, width: int = 128, height: int = 128, spp: int = 64,
                     threads: int = 2, repeats: int = 5, strategies=DEFAULT_STRATEGIES,
                     variants=DEFAULT_VARIANTS, max_depth: int | None = None, rr_depth="scene",
                     reference: str = "mitsuba", reference_spp: int = 4096, seed: int = 0,
                     cache=None, log=None) -> dict:
    """Paired, interleaved render timings of ours vs Mitsuba, with error at equal spp.

    Parameters
    ----------
    scenes : sequence of str
        Suite scene names (``mitsuba_scenes.list_scenes()``).
    width, height, spp, threads, repeats : int, keyword-only
        Image size, samples per pixel, worker threads (both renderers), timed rounds.
    strategies : sequence of str or comma-separated str, keyword-only
        Our strategies (``reference_tracer.STRATEGIES``).
    variants : sequence of str or comma-separated str, keyword-only
        Mitsuba variants; one that does not work here is skipped (``skipped_variants``).
        An empty list is not allowed.
    max_depth : int or None, keyword-only
        Override the scene's ``max_depth`` (None keeps it; the suite's default is 50).
    rr_depth : int, None or 'scene', keyword-only
        Override Russian roulette (``None`` disables it; ``'scene'`` keeps the scene's).
    reference : {'mitsuba', 'ours'}, keyword-only
        Error reference: ``mitsuba`` is ``benchmarks.references.reference`` (cached in
        ``$RTBENCH_CACHE``; rendered once if missing, with the first working variant),
        ``ours`` a fresh ``mis`` render of ours. Both carry a per-sample variance, and
        the efficiency uses the MSE with the reference's own noise removed
        (``metrics.mse_corrected``).
    reference_spp : int, keyword-only
        Samples per pixel of the reference (> ``spp``).
    seed : int, keyword-only
        Round ``r`` renders ours with seed ``seed + r`` and Mitsuba with a seed hashed
        from it (``mitsuba_scenes.batch_seeds``).
    cache : path or None, keyword-only
        Reference cache root.
    log : callable or None, keyword-only
        Called with progress lines.

    Returns
    -------
    dict
        ``config``, ``environment``, ``mitsuba`` (versions, per-variant load and compile
        seconds), ``skipped_variants``, ``references`` (per scene), ``runs`` (one record
        per timed render) and ``summary`` (one row per scene and configuration: medians
        and, for ours, ``ratio`` / ``efficiency_ratio`` / ``cpu_ratio`` per variant, each
        the median over rounds of the paired per-round ratio).
    """
    import reference_tracer as rt
    from mitsuba_scenes import get_scene, list_scenes
    from mitsuba_scenes.render import batch_seeds

    scenes = _names("scenes", scenes, list_scenes())
    strategies = _names("strategies", strategies, rt.STRATEGIES)
    variants = _names("variants", variants)
    width, height = _int("width", width), _int("height", height)
    spp, threads, repeats = _int("spp", spp), _int("threads", threads), _int("repeats", repeats)
    reference_spp = _int("reference_spp", reference_spp, 2)
    seed = _int("seed", seed, 0)
    if reference not in REFERENCE_KINDS:
        raise ValueError(f"reference must be one of {REFERENCE_KINDS}, got {reference!r}")
    if reference_spp <= spp:
        raise ValueError(f"reference_spp ({reference_spp}) must exceed spp ({spp})")
    if max_depth is not None:
        max_depth = int(max_depth)
        if not (max_depth == -1 or max_depth >= 1):
            raise ValueError(f"max_depth must be >= 1 or -1, got {max_depth}")
    if rr_depth not in ("scene", None):
        rr_depth = _int("rr_depth", rr_depth)

    env_before = environment()
    ok_variants, skipped = _available_variants(variants, log)
    result = {"config": {"scenes": scenes, "width": width, "height": height, "spp": spp, "threads": threads,
                         "repeats": repeats, "strategies": strategies, "variants": variants,
                         "reference": reference, "reference_spp": reference_spp, "seed": seed},
              "environment": env_before, "skipped_variants": skipped, "mitsuba": {}, "references": {},
              "runs": [], "summary": []}
    if ok_variants:
        result["mitsuba"]["versions"] = _mitsuba_versions()
    elif reference == "mitsuba":
        raise ValueError(f"no Mitsuba variant of {variants} works here ({skipped}); "
                         f"use reference='ours'")

    for name in scenes:
        scene = get_scene(name).with_camera_size(width, height)
        if max_depth is not None or rr_depth != "scene":
            scene = rt.Scene(scene.camera, scene.shapes,
                             scene.max_depth if max_depth is None else max_depth,
                             scene.rr_depth if rr_depth == "scene" else rr_depth, scene.background)
        settings = {"max_depth": scene.max_depth, "rr_depth": scene.rr_depth}
        if log:
            log(f"{name} {width}x{height}, {spp} spp, max_depth {scene.max_depth}, rr_depth {scene.rr_depth}, "
                f"{threads} threads")
        # set-up, untimed: our BVH build + a small warm-up render; Mitsuba load + warm-up
        from reference_tracer.render import core_scene

        _, build_wall, _ = _timed(lambda: core_scene(scene))
        ref_variant = ok_variants[0] if ok_variants else None
        ref = _reference(scene, kind=reference, spp=reference_spp, variant=ref_variant, threads=threads,
                         cache=cache, log=log)
        result["references"][name] = {k: v for k, v in ref.items() if k not in ("mean", "variance")}
        ours_info = {"build_seconds": float(core_scene(scene).build_seconds), "compile_and_build_seconds": build_wall}
        rt.render(scene, spp=max(1, spp // 8), strategy=strategies[0], seed=0xA11CE, threads=threads)
        msc = {}
        for v in ok_variants:
            mscene, info = _load_mitsuba(v, scene, threads)
            mi, dr = _use_variant(v)
            _, warm, _ = _timed(_mitsuba_render_fn(mi, mscene, spp, 0x5EED))
            info["warmup_seconds"] = warm
            msc[v] = (mscene, info)
            if log:
                log(f"  Mitsuba {v}: load {info['load_seconds']:.2f} s, warm-up render {warm:.2f} s")

        per = {}   # label -> list of run dicts, one per round
        shape = (height, width, 3)
        for r in range(repeats):
            s_ours = seed + r
            s_mi = batch_seeds(seed + r, 1)[0]
            # interleave: ours strategy, Mitsuba variant, ours strategy, ...
            order = []
            for k in range(max(len(strategies), len(ok_variants))):
                if k < len(strategies):
                    order.append(("ours", strategies[k]))
                if k < len(ok_variants):
                    order.append(("mitsuba", ok_variants[k]))
            if r % 2 == 1:
                order.reverse()   # alternate who goes first
            for renderer, what in order:
                if renderer == "ours":
                    rec = _ours_run(scene, spp=spp, strategy=what, seed=s_ours, threads=threads, ref=ref)
                    rec.update(strategy=what, variant=None, seed=s_ours)
                else:
                    rec = _mitsuba_run(what, msc[what][0], spp=spp, seed=s_mi, threads=threads, ref=ref,
                                       shape=shape)
                    rec.update(strategy="path", variant=what, seed=s_mi)
                rec.update(scene=name, renderer=renderer, round=r, spp=spp, width=width, height=height,
                           threads=threads, **settings)
                label = f"ours {what}" if renderer == "ours" else f"Mitsuba {what}"
                per.setdefault(label, []).append(rec)
                result["runs"].append(rec)
                if log:
                    log(f"  round {r + 1}/{repeats} {label}: {rec['paths_per_second'] / 1e6:.3f} Mpaths/s, "
                        f"RMSE {rec['rmse']:.4g}, cpu/wall {rec['cpu_over_wall']:.2f}")

        for v in ok_variants:   # JIT compile time: warm-up minus a typical timed render
            info = msc[v][1]
            timed = _median([x["seconds"] for x in per[f"Mitsuba {v}"]])
            info["compile_seconds"] = max(0.0, info["warmup_seconds"] - timed) if v.startswith(("llvm", "cuda")) else 0.0
            result["mitsuba"].setdefault(name, {})[v] = info
        result.setdefault("ours", {})[name] = ours_info

        for label, runs in per.items():
            row = {"scene": name, "label": label, "renderer": runs[0]["renderer"],
                   "strategy": runs[0]["strategy"], "variant": runs[0]["variant"], "runs": len(runs)}
            for key in ("paths_per_second", "paths_per_cpu_second", "rays_per_second", "ms_per_spp", "seconds",
                        "process_seconds", "cpu_over_wall", "mse", "mse_corrected", "rmse", "efficiency"):
                vals = [x[key] for x in runs if x[key] is not None]
                row[key] = _median(vals) if vals else None
            row["rmse"] = math.sqrt(row["mse"])
            row["rmse_corrected"] = math.sqrt(row["mse_corrected"]) if row["mse_corrected"] > 0 else float("nan")
            row["paths_per_second_spread"] = _spread([x["paths_per_second"] for x in runs])
            if row["renderer"] == "ours":
                for v in ok_variants:
                    mruns = per[f"Mitsuba {v}"]
                    pairs = list(zip(runs, mruns))
                    row[f"ratio_{v}"] = _median([a["paths_per_second"] / b["paths_per_second"] for a, b in pairs])
                    row[f"cpu_ratio_{v}"] = _median([a["paths_per_cpu_second"] / b["paths_per_cpu_second"]
                                                     for a, b in pairs])
                    row[f"efficiency_ratio_{v}"] = _median([a["efficiency"] / b["efficiency"] for a, b in pairs])
            result["summary"].append(row)
    result["available_variants"] = ok_variants
    result["environment_after"] = environment()
    return result


# --------------------------------------------------------------------------- geometry and rays

def torus_mesh(triangles: int, *, seed: int = 0):
    """A closed, bumpy torus of about ``triangles`` triangles (major radius 1, minor 0.35).

    The tube radius carries smooth bumps and a small random jitter per vertex, so the
    triangles are irregular. Vertices are rounded to float32 (and returned as float64),
    so ours and Mitsuba see the very same geometry. Faces are counter-clockwise seen from
    outside.

    Parameters
    ----------
    triangles : int
        Target count (>= 32); the result has ``2 * M * N`` triangles with ``M ~ 2 N``.
    seed : int, keyword-only

    Returns
    -------
    vertices : (V, 3) float64
    faces : (F, 3) int64

    Examples
    --------
    >>> v, f = torus_mesh(1000)
    >>> len(f), v.dtype.name
    (992, 'float64')
    """
    triangles = _int("triangles", triangles, 32)
    n = max(4, int(round(math.sqrt(triangles / 4.0))))
    m = max(4, int(round(triangles / (2.0 * n))))
    rng = np.random.default_rng(seed)
    u = np.arange(m) * (2 * math.pi / m)
    v = np.arange(n) * (2 * math.pi / n)
    uu, vv = np.meshgrid(u, v, indexing="ij")
    r = 0.35 * (1.0 + 0.08 * np.sin(7 * uu) * np.sin(5 * vv) + 0.004 * rng.standard_normal(uu.shape))
    ring = 1.0 + r * np.cos(vv)
    verts = np.stack([ring * np.cos(uu), ring * np.sin(uu), r * np.sin(vv)], axis=-1).reshape(-1, 3)
    verts = verts.astype(np.float32).astype(np.float64)
    i, j = np.meshgrid(np.arange(m), np.arange(n), indexing="ij")
    a, b = i * n + j, ((i + 1) % m) * n + j
    c, d = ((i + 1) % m) * n + (j + 1) % n, i * n + (j + 1) % n
    faces = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    return verts, faces.astype(np.int64)


#: camera of the mesh scenes and of the primary rays
_CAM = {"lookfrom": (0.0, -3.0, 2.0), "lookat": (0.0, 0.0, 0.0), "vup": (0.0, 0.0, 1.0), "vfov": 40.0}


def mesh_scene(triangles: int, *, seed: int = 0, width: int = 64, height: int = 64, lit: bool = False):
    """A ``reference_tracer.Scene`` holding one :func:`torus_mesh` (grey Lambertian).

    ``lit=True`` adds a white background (constant emitter), so that renders of it
    measure paths/s; the ray benchmark needs no light.

    Examples
    --------
    >>> len(mesh_scene(1000).shapes)
    1
    """
    import reference_tracer as rt

    v, f = torus_mesh(triangles, seed=seed)
    cam = rt.Camera(width=width, height=height, **_CAM)
    return rt.Scene(camera=cam, shapes=[rt.Mesh(v, f, rt.Lambertian(0.5))], max_depth=8,
                    background=(1.0, 1.0, 1.0) if lit else (0.0, 0.0, 0.0))


def primary_rays(count: int, *, seed: int = 0):
    """Pinhole-camera rays (jittered pixel grid, about ``count``) looking at the torus.

    Returns float32 ``(origins, directions)`` of shape (N, 3), directions unit length.

    Examples
    --------
    >>> o, d = primary_rays(100)
    >>> o.shape, o.dtype.name
    ((100, 3), 'float32')
    """
    count = _int("count", count)
    side = max(1, int(math.ceil(math.sqrt(count))))
    rng = np.random.default_rng(seed)
    eye, at, up = (np.array(_CAM[k]) for k in ("lookfrom", "lookat", "vup"))
    w = (eye - at) / np.linalg.norm(eye - at)
    u = np.cross(up, w)
    u /= np.linalg.norm(u)
    v = np.cross(w, u)
    half = math.tan(math.radians(_CAM["vfov"]) / 2)
    k = np.arange(count)
    px = (k % side + rng.random(count)) / side
    py = (k // side + rng.random(count)) / side
    d = (2 * px - 1)[:, None] * half * u + (1 - 2 * py)[:, None] * half * v - w
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = np.broadcast_to(eye, d.shape)
    return np.ascontiguousarray(o, dtype=np.float32), np.ascontiguousarray(d, dtype=np.float32)


def random_rays(count: int, *, seed: int = 0):
    """Incoherent rays: origins uniform in a box around the torus, directions uniform.

    Returns float32 ``(origins, directions)`` of shape (N, 3).

    Examples
    --------
    >>> o, d = random_rays(10)
    >>> bool(np.allclose(np.linalg.norm(d, axis=1), 1, atol=1e-6))
    True
    """
    count = _int("count", count)
    rng = np.random.default_rng(seed + 0x9E3779B9)
    o = rng.uniform((-1.6, -1.6, -0.6), (1.6, 1.6, 0.6), size=(count, 3))
    d = rng.standard_normal((count, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return np.ascontiguousarray(o, dtype=np.float32), np.ascontiguousarray(d, dtype=np.float32)


def intersect_ours(core, origins, directions, *, threads: int = 1, repeats: int = 3):
    """Time ``core.intersect`` (closest hit) ``repeats`` times on the same rays.

    Returns
    -------
    dict
        ``t`` (inf on a miss), ``prim``, ``seconds`` (list: the query's own wall time,
        GIL released), ``call_seconds`` and ``process_seconds`` (lists),
        ``packet_fraction`` (the share of rays the batch traced as coherent packets).
    """
    o = np.ascontiguousarray(origins, dtype=np.float64)
    d = np.ascontiguousarray(directions, dtype=np.float64)
    secs, calls, cpus, out = [], [], [], None
    for _ in range(_int("repeats", repeats)):
        out, wall, cpu = _timed(lambda: core.intersect(o, d, threads=int(threads)))
        secs.append(float(out["seconds"]))
        calls.append(wall)
        cpus.append(cpu)
    return {"t": np.asarray(out["t"]), "prim": np.asarray(out["prim"]), "seconds": secs,
            "call_seconds": calls, "process_seconds": cpus,
            "packet_fraction": float(out["packet_rays"]) / max(1, len(o))}


def intersect_mitsuba(mscene, origins, directions, *, repeats: int = 3):
    """Time Mitsuba's ``ray_intersect_preliminary`` on the active variant.

    With a scalar variant the rays are cast one Python call at a time, for agreement
    checks only: nothing is timed then (``seconds`` is empty). With a JIT variant the
    rays are built and evaluated first (untimed), then one untimed call compiles the
    kernel; each timed call is ``ray_intersect_preliminary`` + ``dr.eval`` +
    ``dr.sync_thread()``. Dr.Jit's thread count is whatever ``dr.set_thread_count`` set.

    Returns
    -------
    dict
        ``t`` (inf on a miss), ``prim``, ``seconds``, ``process_seconds`` (lists),
        ``first_call_seconds`` (the compiling call).
    """
    import drjit as dr
    import mitsuba as mi

    if mi.variant() is None:
        raise ValueError("no Mitsuba variant is active")
    o = np.ascontiguousarray(origins, dtype=np.float32)
    d = np.ascontiguousarray(directions, dtype=np.float32)
    if mi.variant().startswith("scalar"):
        return _intersect_mitsuba_scalar(mi, mscene, o, d)

    def rays():
        ray = mi.Ray3f(mi.Point3f(o[:, 0], o[:, 1], o[:, 2]), mi.Vector3f(d[:, 0], d[:, 1], d[:, 2]))
        dr.eval(ray)
        dr.sync_thread()
        return ray

    def query(ray):
        pi = mscene.ray_intersect_preliminary(ray, coherent=False)
        dr.eval(pi.t, pi.prim_index)
        dr.sync_thread()
        return pi

    ray = rays()
    _, first, _ = _timed(lambda: query(ray))
    secs, cpus, pi = [], [], None
    for _ in range(_int("repeats", repeats)):
        ray = rays()
        pi, wall, cpu = _timed(lambda: query(ray))
        secs.append(wall)
        cpus.append(cpu)
    t = np.array(pi.t, dtype=np.float64)
    t[~np.isfinite(t) | (t >= 1e30)] = np.inf
    prim = np.array(pi.prim_index, dtype=np.int64)
    prim[~np.isfinite(t)] = -1
    return {"t": t, "prim": prim, "seconds": secs, "process_seconds": cpus, "first_call_seconds": first}


def _intersect_mitsuba_scalar(mi, mscene, o, d):
    """One Python call per ray (scalar variants): for agreement checks only, never timed."""
    t = np.full(len(o), np.inf)
    prim = np.full(len(o), -1, dtype=np.int64)
    for i in range(len(o)):
        pi = mscene.ray_intersect_preliminary(mi.Ray3f(mi.Point3f(*o[i].tolist()), mi.Vector3f(*d[i].tolist())))
        ti = float(pi.t)
        if math.isfinite(ti) and ti < 1e30:
            t[i], prim[i] = ti, int(pi.prim_index)
    return {"t": t, "prim": prim, "seconds": [], "process_seconds": [], "first_call_seconds": None}


def hit_agreement(t_a, t_b, *, rtol: float = 1e-4) -> dict:
    """Agreement of two closest-hit results on the same rays.

    Parameters
    ----------
    t_a, t_b : (N,) array
        Hit distances, ``inf`` on a miss.
    rtol : float, keyword-only
        Relative tolerance for the distance agreement.

    Returns
    -------
    dict
        ``hit_agreement`` (fraction of rays whose hit/miss agree), ``hit_fraction_a`` /
        ``_b``, ``t_agreement`` (fraction of rays hit by both whose distances agree
        within ``rtol``), ``t_rel_median`` and ``t_rel_max`` (relative differences over
        rays hit by both), ``both_hit`` (count), ``rays``.

    Examples
    --------
    >>> hit_agreement(np.array([1.0, np.inf, 2.0]), np.array([1.0, np.inf, np.inf]))["hit_agreement"]
    0.6666666666666666
    """
    a, b = np.asarray(t_a, dtype=np.float64), np.asarray(t_b, dtype=np.float64)
    if a.shape != b.shape or a.ndim != 1 or a.size == 0:
        raise ValueError(f"t_a and t_b must be non-empty 1-D arrays of the same shape, got {a.shape}, {b.shape}")
    ha, hb = np.isfinite(a), np.isfinite(b)
    both = ha & hb
    rel = np.abs(a[both] - b[both]) / np.maximum(np.abs(b[both]), 1e-30)
    return {"rays": int(a.size), "hit_agreement": float(np.mean(ha == hb)), "hit_fraction_a": float(ha.mean()),
            "hit_fraction_b": float(hb.mean()), "both_hit": int(both.sum()),
            "t_agreement": float(np.mean(rel <= rtol)) if rel.size else float("nan"),
            "t_rel_median": float(np.median(rel)) if rel.size else float("nan"),
            "t_rel_max": float(rel.max()) if rel.size else float("nan"), "t_rtol": rtol}


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
    x = np.log(np.asarray(n, dtype=np.float64))
    y = np.asarray(cost, dtype=np.float64)
    if x.shape != y.shape or x.size < 2 or not np.all(np.isfinite(x)) or not np.all(np.isfinite(y)):
        raise ValueError("fit_log_growth needs at least two finite (n, cost) pairs of equal length")
    b, a = np.polyfit(x, y, 1)
    pred = a + b * x
    ss = float(np.sum((y - y.mean()) ** 2))
    r2 = 1.0 - float(np.sum((y - pred) ** 2)) / ss if ss > 0 else 1.0
    expo = float(np.polyfit(x, np.log(np.maximum(y, 1e-300)), 1)[0]) if np.all(y > 0) else float("nan")
    return {"a": float(a), "b": float(b), "per_doubling": float(b * math.log(2)), "r2": r2,
            "loglog_exponent": expo}


# --------------------------------------------------------------------------- ray benchmark

def _mitsuba_mesh(scene, variant, threads):
    from mitsuba_scenes import to_mitsuba

    mi, dr = _use_variant(variant)
    dr.set_thread_count(int(threads))
    mscene, load, _ = _timed(lambda: mi.load_dict(to_mitsuba(scene)))
    return mscene, load


def ray_benchmark(*, triangles=(100_000, 1_000_000), rays: int = 1 << 20, threads: int = 2, repeats: int = 3,
                  kinds=("primary", "random"), variant: str | None = "llvm_ad_rgb", seed: int = 0,
                  log=None) -> dict:
    """Closest-hit throughput, ours vs Mitsuba (Embree), on generated tori.

    Parameters
    ----------
    triangles : sequence of int, keyword-only
        Mesh sizes (:func:`torus_mesh`).
    rays : int, keyword-only
        Rays per kind.
    threads : int, keyword-only
        Threads for both (ours: ``intersect(threads=)``; Mitsuba: ``dr.set_thread_count``).
    repeats : int, keyword-only
        Timed queries per side (median reported); interleaved ours/Mitsuba.
    kinds : sequence of {'primary', 'random'}, keyword-only
    variant : str or None, keyword-only
        Mitsuba JIT variant; None (or one that does not work here) measures ours only.

    Returns
    -------
    dict
        ``rows``: per (triangles, kind) ``ours_mrays_per_second``,
        ``mitsuba_mrays_per_second``, ``ratio`` (ours / Mitsuba, median of the paired
        per-repeat ratios), CPU-time figures, agreement (:func:`hit_agreement`), ours'
        ``build_seconds`` and ``build_seconds_per_mtri``, Mitsuba's ``load_seconds``
        and ``first_call_seconds``; plus ``config``, ``environment``, ``mitsuba``.
    """
    from reference_tracer.render import core_scene

    sizes = [_int("triangles", t, 32) for t in (triangles if not isinstance(triangles, (int, np.integer))
                                                else [triangles])]
    if not sizes:
        raise ValueError("triangles must name at least one mesh size")
    kinds = _names("kinds", kinds, ("primary", "random"))
    rays, threads, repeats = _int("rays", rays), _int("threads", threads), _int("repeats", repeats)
    out = {"config": {"triangles": sizes, "rays": rays, "threads": threads, "repeats": repeats, "kinds": kinds,
                      "variant": variant, "seed": seed},
           "environment": environment(), "rows": [], "mitsuba": {}}
    use_mi = False
    if variant is not None:
        if variant.startswith("scalar"):
            raise ValueError("the ray benchmark needs a JIT Mitsuba variant (llvm_ad_rgb) or None")
        ok, skipped = _available_variants([variant], log)
        use_mi = bool(ok)
        out["mitsuba"] = {"variant": variant if use_mi else None, "skipped": skipped}
        if use_mi:
            out["mitsuba"]["versions"] = _mitsuba_versions()
    gen = {"primary": primary_rays, "random": random_rays}
    for n_target in sizes:
        scene = mesh_scene(n_target, seed=seed)
        ntri = int(len(scene.shapes[0].faces))
        core, wall_build, _ = _timed(lambda: core_scene(scene))
        build = float(core.build_seconds)
        mscene, load = _mitsuba_mesh(scene, variant, threads) if use_mi else (None, None)
        if log:
            log(f"{ntri} triangles: our BVH build {build:.3f} s ({build / ntri * 1e6:.3f} s/Mtri), "
                f"{core.bvh_nodes} nodes, depth {core.bvh_depth}"
                + (f"; Mitsuba load {load:.3f} s" if use_mi else ""))
        for kind in kinds:
            o, d = gen[kind](rays, seed=seed)
            n = len(o)
            ours_secs, ours_cpu, mi_secs, mi_cpu, first = [], [], [], [], None
            ours = mres = None
            for _ in range(repeats):   # interleaved, one timed query per side per round
                ours = intersect_ours(core, o, d, threads=threads, repeats=1)
                ours_secs += ours["seconds"]
                ours_cpu += ours["process_seconds"]
                if use_mi:
                    _use_variant(variant)[1].set_thread_count(int(threads))
                    mres = intersect_mitsuba(mscene, o, d, repeats=1)
                    mi_secs += mres["seconds"]
                    mi_cpu += mres["process_seconds"]
                    first = mres["first_call_seconds"] if first is None else first
            row = {"triangles": ntri, "kind": kind, "rays": n, "threads": threads,
                   "build_seconds": build, "build_seconds_per_mtri": build / ntri * 1e6,
                   "compile_and_build_seconds": wall_build, "bvh_nodes": int(core.bvh_nodes),
                   "bvh_depth": int(core.bvh_depth),
                   "ours_seconds": ours_secs, "ours_process_seconds": ours_cpu,
                   "ours_mrays_per_second": n / _median(ours_secs) / 1e6,
                   "ours_mrays_per_cpu_second": n / _median(ours_cpu) / 1e6 if _median(ours_cpu) > 0 else None,
                   "ours_ns_per_ray": _median(ours_secs) / n * 1e9,
                   "hit_fraction": float(np.isfinite(ours["t"]).mean()),
                   "ours_packet_fraction": ours["packet_fraction"]}
            if use_mi:
                agree = hit_agreement(ours["t"], mres["t"])
                both = np.isfinite(ours["t"]) & np.isfinite(mres["t"])
                row.update({"mitsuba_seconds": mi_secs, "mitsuba_process_seconds": mi_cpu,
                            "mitsuba_mrays_per_second": n / _median(mi_secs) / 1e6,
                            "mitsuba_mrays_per_cpu_second": n / _median(mi_cpu) / 1e6 if _median(mi_cpu) > 0 else None,
                            "mitsuba_ns_per_ray": _median(mi_secs) / n * 1e9,
                            "ratio": _median([m / o_ for o_, m in zip(ours_secs, mi_secs)]),
                            "mitsuba_load_seconds": load, "mitsuba_first_call_seconds": first,
                            "prim_agreement": float(np.mean(ours["prim"][both] == mres["prim"][both]))
                            if both.any() else float("nan"),
                            **{f"agree_{k}": v for k, v in agree.items()}})
            out["rows"].append(row)
            if log:
                msg = f"  {kind}: ours {row['ours_mrays_per_second']:.2f} Mrays/s"
                if use_mi:
                    msg += (f", Mitsuba {row['mitsuba_mrays_per_second']:.2f} Mrays/s, ratio {row['ratio']:.2f}, "
                            f"hit agreement {row['agree_hit_agreement']:.5f}")
                log(msg)
        del core, mscene
        scene._core_cache.clear()
    out["environment_after"] = environment()
    return out


# --------------------------------------------------------------------------- scaling

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
    import reference_tracer as rt
    from mitsuba_scenes import get_scene, list_scenes
    from reference_tracer.render import core_scene

    if scene not in list_scenes():
        raise ValueError(f"unknown scene {scene!r}; the suite has: {', '.join(list_scenes())}")
    resolutions = sorted({_int("resolution", r) for r in resolutions})
    thread_counts = sorted({_int("thread count", t) for t in thread_counts})
    sizes = sorted({_int("triangles", t, 32) for t in triangles})
    if len(sizes) < 2:
        raise ValueError("the mesh sweep needs at least two triangle counts")
    spp, mesh_spp, rays = _int("spp", spp), _int("mesh_spp", mesh_spp), _int("rays", rays)
    threads, repeats = _int("threads", threads), _int("repeats", repeats)
    if strategy not in rt.STRATEGIES:
        raise ValueError(f"strategy must be one of {rt.STRATEGIES}, got {strategy!r}")
    use_mi = False
    skipped = {}
    if variant is not None:
        if variant.startswith("scalar"):
            raise ValueError("the scaling benchmark needs a JIT Mitsuba variant (llvm_ad_rgb) or None")
        ok, skipped = _available_variants([variant], log)
        use_mi = bool(ok)
    out = {"config": {"scene": scene, "resolutions": resolutions, "spp": spp, "thread_counts": thread_counts,
                      "triangles": sizes, "rays": rays, "mesh_spp": mesh_spp, "strategy": strategy,
                      "variant": variant if use_mi else None, "threads": threads, "repeats": repeats},
           "environment": environment(), "skipped_variants": skipped,
           "resolution": [], "threads": [], "mesh": [], "fits": {}}

    def measure(sc, *, spp_, threads_):
        """Median paths/s (wall and CPU) of ours and Mitsuba on ``sc``; interleaved rounds."""
        core_scene(sc)
        rt.render(sc, spp=1, strategy=strategy, seed=1, threads=threads_)   # warm-up
        mscene = None
        if use_mi:
            mscene, _ = _load_mitsuba(variant, sc, threads_)
            mi, _dr = _use_variant(variant)
            _mitsuba_render_fn(mi, mscene, spp_, 7)()   # warm-up (JIT)
        ours, ours_cpu, mits, mits_cpu = [], [], [], []
        paths = sc.camera.width * sc.camera.height * spp_
        for r in range(repeats):
            res, _, cpu = _timed(lambda: rt.render(sc, spp=spp_, strategy=strategy, seed=seed + r, threads=threads_))
            ours.append(paths / res.seconds)
            ours_cpu.append(paths / cpu if cpu > 0 else float("nan"))
            if use_mi:
                mi, dr = _use_variant(variant)
                dr.set_thread_count(int(threads_))
                _, wall, cpu = _timed(_mitsuba_render_fn(mi, mscene, spp_, 1000 + r))
                mits.append(paths / wall)
                mits_cpu.append(paths / cpu if cpu > 0 else float("nan"))
        row = {"ours_paths_per_second": _median(ours), "ours_paths_per_cpu_second": _median(ours_cpu),
               "ours_spread": _spread(ours)}
        if use_mi:
            row.update({"mitsuba_paths_per_second": _median(mits), "mitsuba_paths_per_cpu_second": _median(mits_cpu),
                        "ratio": _median([a / b for a, b in zip(ours, mits)])})
        return row

    base = get_scene(scene)
    for res in resolutions:
        row = {"resolution": res, "threads": threads, "spp": spp,
               **measure(base.with_camera_size(res, res), spp_=spp, threads_=threads)}
        out["resolution"].append(row)
        if log:
            log(f"resolution {res}: ours {row['ours_paths_per_second'] / 1e6:.3f} Mpaths/s"
                + (f", Mitsuba {row['mitsuba_paths_per_second'] / 1e6:.3f}" if use_mi else ""))
    top = base.with_camera_size(resolutions[-1], resolutions[-1])
    for t in thread_counts:
        row = {"threads": t, "resolution": resolutions[-1], "spp": spp, **measure(top, spp_=spp, threads_=t)}
        out["threads"].append(row)
        if log:
            log(f"{t} thread(s): ours {row['ours_paths_per_second'] / 1e6:.3f} Mpaths/s"
                + (f", Mitsuba {row['mitsuba_paths_per_second'] / 1e6:.3f}" if use_mi else ""))
    one = {r["threads"]: r for r in out["threads"]}
    if 1 in one:
        for r in out["threads"]:
            r["ours_speedup"] = r["ours_paths_per_second"] / one[1]["ours_paths_per_second"]
            if use_mi:
                r["mitsuba_speedup"] = r["mitsuba_paths_per_second"] / one[1]["mitsuba_paths_per_second"]

    for n_target in sizes:
        lit = mesh_scene(n_target, seed=seed, lit=True)
        ntri = int(len(lit.shapes[0].faces))
        core = core_scene(lit)
        o, d = random_rays(rays, seed=seed)
        ours = intersect_ours(core, o, d, threads=threads, repeats=repeats)
        row = {"triangles": ntri, "rays": len(o), "threads": threads,
               "build_seconds": float(core.build_seconds), "bvh_depth": int(core.bvh_depth),
               "ours_ns_per_ray": _median(ours["seconds"]) / len(o) * 1e9}
        if use_mi:
            mscene, load = _mitsuba_mesh(lit, variant, threads)
            mres = intersect_mitsuba(mscene, o, d, repeats=repeats)
            row.update({"mitsuba_ns_per_ray": _median(mres["seconds"]) / len(o) * 1e9,
                        "mitsuba_load_seconds": load})
        row.update(measure(lit, spp_=mesh_spp, threads_=threads))
        out["mesh"].append(row)
        lit._core_cache.clear()
        if log:
            log(f"{ntri} triangles: ours {row['ours_ns_per_ray']:.0f} ns/ray, "
                f"{row['ours_paths_per_second'] / 1e6:.3f} Mpaths/s"
                + (f"; Mitsuba {row['mitsuba_ns_per_ray']:.0f} ns/ray" if use_mi else ""))
    tri = [r["triangles"] for r in out["mesh"]]
    out["fits"]["ours_ns_per_ray"] = fit_log_growth(tri, [r["ours_ns_per_ray"] for r in out["mesh"]])
    if use_mi:
        out["fits"]["mitsuba_ns_per_ray"] = fit_log_growth(tri, [r["mitsuba_ns_per_ray"] for r in out["mesh"]])
    out["environment_after"] = environment()
    return out
