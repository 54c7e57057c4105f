"""The ray-casting benchmark: closest hits, ours vs Mitsuba (Embree), on the same rays.

:func:`ray_benchmark` casts primary (camera) and random rays, made in float32, at a bumpy torus (:func:`torus_mesh`):
ours (``core_scene(...).intersect``, and other ``builds`` of our core) against Mitsuba's
``ray_intersect_preliminary``, paired per round; hit agreement (:func:`hit_agreement`) and build times beside.

Examples
--------
>>> out = ray_benchmark(triangles=(1000,), rays=1000, repeats=1, variant=None)
>>> [(r["kind"], r["rays"]) for r in out["rows"]]
[('primary', 1000), ('random', 1000)]
"""
from __future__ import annotations

import contextlib
import functools
import math

import numpy as np

import reference_tracer as rt
from reference_tracer.probe import camera_rays, core_scene
from reference_tracer.validation import positive_int

from .builds import CoreWorker
from .common import (check_jit_variant, environment, load_mitsuba, median, mitsuba_kernel_workers, mitsuba_versions,
                     name_list, timed, use_mitsuba_kernels, use_variant)

__all__ = ["ray_benchmark", "resident_mib", "torus_mesh", "mesh_scene", "primary_rays", "random_rays", "intersect_ours",
           "intersect_mitsuba", "hit_agreement", "query_torus", "query_torus_mitsuba", "torus_tree", "RAY_KINDS",
           "MIN_TRIANGLES"]

#: the fewest triangles of a :func:`torus_mesh` (4 x 4 quads, two triangles each)
MIN_TRIANGLES = 32
#: the ray sets: camera rays toward the torus, and incoherent rays around it.
RAY_KINDS = ("primary", "random")


def torus_mesh(triangles: int, *, seed: int = 0):
    """A closed, bumpy torus of about ``triangles`` (>= :data:`MIN_TRIANGLES`) triangles: ``(vertices (V, 3)
    float64, faces (F, 3) int64)``, radii 1 and 0.35 with smooth bumps and jitter, faces counter-clockwise seen from
    outside, vertices rounded to float32 so that ours and Mitsuba see the very same geometry."""
    triangles = positive_int("triangles", triangles, minimum=MIN_TRIANGLES)
    n = max(4, int(round(math.sqrt(triangles / 4.0))))
    m = max(4, int(round(triangles / (2.0 * n))))
    rng = np.random.default_rng(seed)
    uu, vv = np.meshgrid(np.arange(m) * (2 * math.pi / m), np.arange(n) * (2 * math.pi / n), indexing="ij")
    r = 0.35 * (1.0 + 0.08 * np.sin(7 * uu) * np.sin(5 * vv) + 0.004 * rng.standard_normal(uu.shape))
    ring = 1.0 + r * np.cos(vv)
    verts = np.stack([ring * np.cos(uu), ring * np.sin(uu), r * np.sin(vv)], axis=-1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(m), np.arange(n), indexing="ij")
    a, b = i * n + j, ((i + 1) % m) * n + j
    c, d = ((i + 1) % m) * n + (j + 1) % n, i * n + (j + 1) % n
    faces = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    return verts.astype(np.float32).astype(np.float64), faces.astype(np.int64)


#: camera of the mesh scenes and of the primary rays
_CAM = {"lookfrom": (0.0, -3.0, 2.0), "lookat": (0.0, 0.0, 0.0), "vup": (0.0, 0.0, 1.0), "vfov": 40.0}


def mesh_scene(triangles: int, *, seed: int = 0, lit: bool = False):
    """A 64x64 ``reference_tracer.Scene`` of one grey Lambertian :func:`torus_mesh`; ``lit=True`` adds a white
    background (a constant emitter) for renders of it."""
    v, f = torus_mesh(triangles, seed=seed)
    return rt.Scene(camera=rt.Camera(width=64, height=64, **_CAM), shapes=[rt.Mesh(v, f, rt.Lambertian(0.5))],
                    max_depth=8, background=(1.0, 1.0, 1.0) if lit else (0.0, 0.0, 0.0))


def primary_rays(count: int, *, seed: int = 0):
    """``count`` pinhole-camera rays (a jittered pixel grid, row after row) at the torus: float32 ``(origins,
    directions)`` of shape (N, 3), directions of unit length."""
    count = positive_int("count", count)
    side = max(1, int(math.ceil(math.sqrt(count))))
    rng, k = np.random.default_rng(seed), np.arange(count)
    o, d = camera_rays(rt.Camera(width=side, height=side, **_CAM), k % side + rng.random(count),
                       k // side + rng.random(count))
    return o.astype(np.float32), d.astype(np.float32)


def random_rays(count: int, *, seed: int = 0):
    """Incoherent rays: origins uniform in a box around the torus, directions uniform; float32 as
    :func:`primary_rays`."""
    count = positive_int("count", count)
    rng = np.random.default_rng(seed + 0x9E3779B9)
    o = rng.uniform((-1.6, -1.6, -0.6), (1.6, 1.6, 0.6), size=(count, 3))
    d = rng.standard_normal((count, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return o.astype(np.float32), d.astype(np.float32)


_MAKE = {"primary": primary_rays, "random": random_rays}


def intersect_ours(core, origins, directions, *, threads: int = 1, preliminary: bool = False):
    """One timed closest-hit query ``core.intersect``: with ``preliminary=True`` distance and primitive only (as
    Mitsuba's ``ray_intersect_preliminary``), else hit point and normal too. A dict: ``t`` (inf on a miss), ``prim``,
    ``seconds`` (the query's own), ``call_seconds`` and ``process_seconds`` (the call's), ``packet_fraction`` (the
    share of rays traced as coherent packets)."""
    o, d = (np.ascontiguousarray(x, dtype=np.float64) for x in (origins, directions))
    out, wall, cpu = timed(lambda: core.intersect(o, d, threads=int(threads), preliminary=bool(preliminary)))
    return {"t": np.asarray(out["t"]), "prim": np.asarray(out["prim"]), "seconds": float(out["seconds"]),
            "call_seconds": wall, "process_seconds": cpu, "packet_fraction": float(out["packet_rays"]) / max(1, len(o))}


_KEPT = {}   # a worker's meshes and rays, kept between calls: each is made once


def _torus_core(triangles: int, seed: int):
    if (triangles, seed) not in _KEPT:
        _KEPT[triangles, seed] = core_scene(mesh_scene(triangles, seed=seed))
    return _KEPT[triangles, seed]


def torus_tree(triangles: int, *, seed: int = 0) -> dict:
    """Our tree of the torus of :func:`query_torus`, built by this process's core (kept): the figures of
    :func:`ray_benchmark`'s rows that describe it (build time, nodes, depth, bytes a triangle)."""
    core = _torus_core(triangles, seed)
    return _tree_figures(core, int(core.primitive_count))   # the torus is all the scene holds


def _tree_figures(core, ntri: int) -> dict:
    build = float(core.build_seconds)
    return {"build_seconds": build, "build_seconds_per_mtri": build / ntri * 1e6, "bvh_nodes": int(core.bvh_nodes),
            "bvh_depth": int(core.bvh_depth), "bvh_bytes_per_triangle": int(core.bvh_bytes) / ntri}


def query_torus(triangles: int, *, kind: str, rays: int, seed: int = 0, threads: int = 1, preliminary: bool = True):
    """:func:`intersect_ours` once on ``rays`` rays of ``kind`` at the torus of ``triangles`` triangles, as
    :func:`ray_benchmark` makes them; kept for the next call (of a :class:`.builds.CoreWorker`)."""
    _torus_core(triangles, seed)
    if (kind, rays, seed) not in _KEPT:
        _KEPT[kind, rays, seed] = _MAKE[kind](rays, seed=seed)
    return intersect_ours(_KEPT[triangles, seed], *_KEPT[kind, rays, seed], threads=threads, preliminary=preliminary)


def query_torus_mitsuba(triangles: int, *, kind: str, rays: int, seed: int = 0, threads: int = 1,
                        variant: str = "llvm_ad_rgb", isa: str):
    """:func:`intersect_mitsuba` on the torus and rays of :func:`query_torus`, with Mitsuba's kernels compiled for
    ``isa`` (:func:`.common.use_mitsuba_kernels`): run in a :class:`.builds.CoreWorker`, the scene and rays kept
    for the next call."""
    use_mitsuba_kernels(variant, isa, threads)
    key = ("mitsuba", variant, triangles, seed)
    if key not in _KEPT:
        _KEPT[key] = load_mitsuba(variant, mesh_scene(triangles, seed=seed), threads, check_merge=False)[0]
    if (kind, rays, seed) not in _KEPT:
        _KEPT[kind, rays, seed] = _MAKE[kind](rays, seed=seed)
    return intersect_mitsuba(_KEPT[key], *_KEPT[kind, rays, seed])


def intersect_mitsuba(mscene, origins, directions):
    """One timed ``ray_intersect_preliminary`` of Mitsuba's active JIT variant, after an untimed one that compiles the
    kernel (rays built untimed; the query + ``dr.eval`` + ``dr.sync_thread()`` on Dr.Jit's threads). A dict: ``t``
    (inf on a miss), ``prim``, ``seconds``, ``process_seconds``, ``first_call_seconds``."""
    import drjit as dr  # deferred: after the variant and libLLVM are chosen (select_variant)
    import mitsuba as mi  # deferred: after the variant and libLLVM are chosen (select_variant)

    if not str(mi.variant()).startswith(("llvm", "cuda")):
        raise ValueError(f"a JIT Mitsuba variant must be active, not {mi.variant()}")
    o, d = (np.ascontiguousarray(x, dtype=np.float32) for x in (origins, directions))

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

    _, first, _ = timed(functools.partial(query, rays()))
    pi, wall, cpu = timed(functools.partial(query, rays()))
    t = np.array(pi.t, dtype=np.float64)
    t[~np.isfinite(t) | (t >= 1e30)] = np.inf
    prim = np.array(pi.prim_index, dtype=np.int64)
    prim[~np.isfinite(t)] = -1
    return {"t": t, "prim": prim, "seconds": wall, "process_seconds": cpu, "first_call_seconds": first}


def hit_agreement(t_a, t_b, *, rtol: float = 1e-4) -> dict:
    """Agreement of two closest-hit results (hit distances, inf on a miss) on the same rays: ``hit_agreement`` (the
    fraction whose hit/miss agree), ``hit_fraction_a`` / ``_b``, ``t_agreement`` (the fraction hit by both whose
    distances agree within ``rtol``), ``t_rel_median`` and ``t_rel_max`` over those, ``both_hit``, ``rays``,
    ``t_rtol``.

    >>> hit_agreement(np.array([1.0, np.inf, 2.0]), np.array([1.0, np.inf, np.inf]))["hit_agreement"]
    0.6666666666666666
    """
    a, b = np.asarray(t_a, dtype=np.float64), np.asarray(t_b, dtype=np.float64)
    if a.shape != b.shape or a.ndim != 1 or a.size == 0:
        raise ValueError(f"t_a and t_b must be non-empty 1-D arrays of the same shape, got {a.shape}, {b.shape}")
    ha, hb = np.isfinite(a), np.isfinite(b)
    both = ha & hb
    rel = np.abs(a[both] - b[both]) / np.maximum(np.abs(b[both]), 1e-30)
    nan = float("nan")
    return {"rays": int(a.size), "hit_agreement": float(np.mean(ha == hb)), "hit_fraction_a": float(ha.mean()),
            "hit_fraction_b": float(hb.mean()), "both_hit": int(both.sum()),
            "t_agreement": float(np.mean(rel <= rtol)) if rel.size else nan,
            "t_rel_median": float(np.median(rel)) if rel.size else nan,
            "t_rel_max": float(rel.max()) if rel.size else nan, "t_rtol": rtol}


def resident_mib() -> tuple:
    """``(now, peak)``: this process's resident memory and its high-water mark in MiB (``VmRSS``, ``VmHWM`` of
    ``/proc/self/status``); ``(None, None)`` where that file is not there."""
    try:
        with open("/proc/self/status") as f:
            fields = dict(line.split(":", 1) for line in f if ":" in line)
        return tuple(float(fields[k].split()[0]) / 1024.0 for k in ("VmRSS", "VmHWM"))
    except (OSError, KeyError, ValueError, IndexError):
        return None, None


def _grown(before, after):
    """The growth from ``before`` to ``after`` (MiB), or None where either is unknown."""
    return None if before is None or after is None else after - before


def ray_benchmark(*, triangles=(100_000, 1_000_000), rays: int = 1 << 20, threads: int = 2, repeats: int = 3,
                  kinds=RAY_KINDS, variant: str | None = "llvm_ad_rgb", seed: int = 0, log=None, builds=None) -> dict:
    """Closest-hit throughput, ours vs Mitsuba (Embree), on generated tori.

    Parameters
    ----------
    triangles : sequence of int, keyword-only
        Mesh sizes (:func:`torus_mesh`).
    rays, threads, repeats, seed : int, keyword-only
        Rays per kind; threads of either side; timed queries per side, interleaved.
    kinds : sequence of {'primary', 'random'}, keyword-only
    variant : str or None, keyword-only
        Mitsuba JIT variant; None (or one that does not work here) measures ours only.
    builds : mapping of str to path, keyword-only
        Other builds of our core (name: module), querying in worker processes in the same rounds.

    Returns
    -------
    dict
        ``config``, ``environment``, ``mitsuba`` and ``rows`` per mesh, kind and ``build`` (None: the installed core):
        ``ours_mrays_per_second`` (distance and primitive, timed from the call to its return as Mitsuba's side is) and
        ``ours_full_mrays_per_second`` (hit point and normal too), ``mitsuba_mrays_per_second``, ``ratio`` and
        ``ratio_full`` (medians of the paired ``round_ratios``, ``round_ratios_full``; a build for another ISA paired
        with Mitsuba's kernels for that ISA where this CPU's are wider, ``mitsuba_kernels`` naming it, and
        ``mitsuba["targets"]`` what they were compiled for), CPU-time figures, agreement
        (``agree_*``), our tree's ``build_seconds`` and ``bvh_depth``, ``mitsuba_load_seconds``. Memory:
        ``bvh_bytes_per_triangle`` (our tree and its triangle blocks, exact), and the growth of this process's
        resident memory across our scene's build (``ours_rss_growth_mib``: its arrays and tree) and Mitsuba's load
        (``mitsuba_rss_growth_mib``: the mesh and Embree's tree), with the process's peak (``peak_rss_mib``).
        Memory freed by the previous mesh may be reused, so the growths are lower bounds.
    """
    sizes = [positive_int("triangles", t, minimum=MIN_TRIANGLES)
             for t in (triangles if not isinstance(triangles, (int, np.integer)) else [triangles])]
    if not sizes:
        raise ValueError("triangles must name at least one mesh size")
    kinds = name_list("kinds", kinds, RAY_KINDS)
    rays, threads = positive_int("rays", rays), positive_int("threads", threads)
    repeats = positive_int("repeats", repeats)
    builds = {str(k): str(v) for k, v in (builds or {}).items()}
    out = {"config": {"triangles": sizes, "rays": rays, "threads": threads, "repeats": repeats, "kinds": kinds,
                      "variant": variant, "seed": seed, "builds": builds},
           "environment": environment(), "rows": [], "mitsuba": {}}
    use_mi, skipped = check_jit_variant(variant, "ray", log)
    if variant is not None:
        out["mitsuba"] = {"variant": variant if use_mi else None, "skipped": skipped}
        if use_mi:
            out["mitsuba"]["versions"] = mitsuba_versions()
    with contextlib.ExitStack() as stack:
        workers = {name: stack.enter_context(CoreWorker(module)) for name, module in builds.items()}
        kernels = {}
        if use_mi:
            kernels, out["mitsuba"]["targets"], out["mitsuba"]["targets_skipped"] = mitsuba_kernel_workers(
                workers, variant, log)
        for n_target in sizes:
            scene = mesh_scene(n_target, seed=seed)
            ntri = int(len(scene.shapes[0].faces))
            rss_before, _ = resident_mib()
            core, wall_build, _ = timed(lambda: core_scene(scene))
            build = float(core.build_seconds)
            rss_ours, _ = resident_mib()
            mscene, load = load_mitsuba(variant, scene, threads, check_merge=False) if use_mi else (None, None)
            rss_mitsuba, peak = resident_mib()
            if log:
                log(f"{ntri} triangles: our BVH build {build:.3f} s, {core.bvh_nodes} nodes, depth {core.bvh_depth}"
                    + (f"; Mitsuba load {load:.3f} s" if use_mi else ""))
            base = {"requested_triangles": n_target, "triangles": ntri, "rays": rays, "threads": threads}
            built = {None: {**_tree_figures(core, ntri), "compile_and_build_seconds": wall_build,
                            "ours_rss_growth_mib": _grown(rss_before, rss_ours), "peak_rss_mib": peak}}
            # each build's own tree, built in its worker (its memory is that process's: not measured)
            built.update({b: w("benchmarks.speed.rays.torus_tree", n_target, seed=seed) for b, w in workers.items()})
            for kind in kinds:
                o, d = _MAKE[kind](rays, seed=seed)
                sides = {None: functools.partial(intersect_ours, core, o, d, threads=threads)}
                sides.update({b: functools.partial(w, "benchmarks.speed.rays.query_torus", n_target, kind=kind,
                                                   rays=rays, seed=seed, threads=threads) for b, w in workers.items()})
                theirs = {}
                if use_mi:
                    theirs[None] = functools.partial(_native_mitsuba, mscene, o, d, variant=variant, threads=threads)
                    theirs.update({b: functools.partial(w, "benchmarks.speed.rays.query_torus_mitsuba", n_target,
                                                        kind=kind, rays=rays, seed=seed, threads=threads,
                                                        variant=variant, isa=b) for b, w in kernels.items()})
                for row in _ray_rows(sides, theirs, len(o), repeats=repeats):
                    out["rows"].append({**base, "kind": kind, **built[row["build"]],
                                        "mitsuba_load_seconds": load,
                                        "mitsuba_rss_growth_mib": _grown(rss_ours, rss_mitsuba) if use_mi else None,
                                        **row})
                    if log:
                        log(f"  {kind}, {row['build'] or 'installed'} build: ours {row['ours_mrays_per_second']:.2f} "
                            f"Mrays/s" + (f", Mitsuba {row['mitsuba_mrays_per_second']:.2f}" if use_mi else ""))
            del core, mscene
            scene._core_cache.clear()
    out["environment_after"] = environment()
    return out


def _native_mitsuba(mscene, o, d, *, variant, threads):
    use_variant(variant, threads)
    return intersect_mitsuba(mscene, o, d)


def _ray_rows(sides, theirs, n, *, repeats) -> list:
    """``repeats`` interleaved rounds of a timed query per side (``sides``: build -> function of ``preliminary``
    returning :func:`intersect_ours`'s output), full and like for like, and of each of Mitsuba's (``theirs``: None,
    this CPU's kernels, and builds whose ISA Mitsuba also ran with, -> a function returning :func:`intersect_mitsuba`'s
    output; empty: ours only); a row per side, paired with Mitsuba's kernels for its ISA where they ran."""
    got = {side: ([], []) for side in sides}   # like-for-like and full queries, a round each
    answers = {side: [] for side in theirs}
    for _ in range(repeats):
        # Timed from the Python call to its return, as Mitsuba's side is: the query's own time leaves out allocating
        # and handing over our output arrays (0.5-1.4% of the like-for-like query on 1M triangles, up to 28% of the
        # full one).
        for side, query in sides.items():
            got[side][0].append(query(preliminary=True))
            got[side][1].append(query(preliminary=False))
        for side, query in theirs.items():
            answers[side].append(query())
    rows = []
    for side, (ours, full) in got.items():
        if not all(np.array_equal(ours[-1][k], full[-1][k]) for k in ("t", "prim")):
            raise RuntimeError("the preliminary and the full closest-hit queries disagree")
        row = {"build": side, **_rates("ours", n, ours), **_rates("ours_full", n, full),
               "ours_query_seconds": [q["seconds"] for q in ours],
               "hit_fraction": float(np.isfinite(ours[-1]["t"]).mean()),
               "ours_packet_fraction": ours[-1]["packet_fraction"]}
        if theirs:   # paired per round: a round's sides ran back to back
            kernels = side if side in theirs else None
            their = answers[kernels]
            row.update(_rates("mitsuba", n, their, wall="seconds"), mitsuba_kernels=kernels)
            for suffix in ("", "_full"):
                ratios = [m / x for x, m in zip(row[f"ours{suffix}_seconds"], row["mitsuba_seconds"])]
                row.update({f"ratio{suffix}": median(ratios), f"ratio{suffix}_min": min(ratios),
                            f"ratio{suffix}_max": max(ratios), f"round_ratios{suffix}": ratios})
            t, prim = their[-1]["t"], their[-1]["prim"]
            both = np.isfinite(ours[-1]["t"]) & np.isfinite(t)
            row.update({"mitsuba_first_call_seconds": their[0]["first_call_seconds"],
                        "prim_agreement": float(np.mean(ours[-1]["prim"][both] == prim[both]))
                        if both.any() else float("nan"),
                        **{f"agree_{k}": v for k, v in hit_agreement(ours[-1]["t"], t).items()}})
        rows.append(row)
    return rows


def _rates(who, n, queries, *, wall="call_seconds") -> dict:
    """``{who}_seconds`` ... ``{who}_ns_per_ray`` of ``queries`` of ``n`` rays each (their ``wall`` and CPU times)."""
    secs, cpus = [q[wall] for q in queries], [q["process_seconds"] for q in queries]
    wall, cpu = median(secs), median(cpus)
    return {f"{who}_seconds": secs, f"{who}_process_seconds": cpus, f"{who}_mrays_per_second": n / wall / 1e6,
            f"{who}_mrays_per_cpu_second": n / cpu / 1e6 if cpu > 0 else None, f"{who}_ns_per_ray": wall / n * 1e9}
