"""The ray-casting benchmark: closest-hit queries, ours vs Mitsuba (Embree), on the same rays.

Closest-hit queries on a generated noisy torus (:func:`torus_mesh`, e.g. ~100k / ~1M
triangles) with primary (camera) and random rays: ours (``core_scene(...).intersect``)
vs Mitsuba's ``scene.ray_intersect_preliminary`` (Embree) on the *same* rays (generated
in float32, passed as float64 to ours), in Mrays/s; hit/miss and distance agreement
(:func:`hit_agreement`); BVH build time per million triangles (ours) and Mitsuba's scene
load time.

Examples
--------
>>> out = ray_benchmark(triangles=(1000,), rays=1000, repeats=1, variant=None)
>>> [(r["kind"], r["rays"]) for r in out["rows"]]
[('primary', 1000), ('random', 1000)]
"""
from __future__ import annotations

import math

import numpy as np

import reference_tracer as rt
from reference_tracer.probe import core_scene
from reference_tracer.validation import positive_int

from .common import (check_jit_variant, environment, load_mitsuba, median, mitsuba_versions, name_list, timed,
                     use_variant)

__all__ = ["ray_benchmark", "torus_mesh", "mesh_scene", "primary_rays", "random_rays", "intersect_ours",
           "intersect_mitsuba", "hit_agreement", "RAY_KINDS"]

#: the ray sets: camera rays toward the torus, and incoherent rays around it.
RAY_KINDS = ("primary", "random")


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
    triangles = positive_int("triangles", triangles, minimum=32)
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
    count = positive_int("count", count)
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
    count = positive_int("count", count)
    rng = np.random.default_rng(seed + 0x9E3779B9)
    o = rng.uniform((-1.6, -1.6, -0.6), (1.6, 1.6, 0.6), size=(count, 3))
    d = rng.standard_normal((count, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return np.ascontiguousarray(o, dtype=np.float32), np.ascontiguousarray(d, dtype=np.float32)


def intersect_ours(core, origins, directions, *, threads: int = 1, repeats: int = 3, preliminary: bool = False):
    """Time ``core.intersect`` (closest hit) ``repeats`` times on the same rays.

    ``preliminary=True`` asks for the distance and primitive only, what Mitsuba's
    ``ray_intersect_preliminary`` returns; otherwise the hit point and normal are filled
    in too.

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
    for _ in range(positive_int("repeats", repeats)):
        out, wall, cpu = timed(lambda: core.intersect(o, d, threads=int(threads), preliminary=bool(preliminary)))
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
    _, first, _ = timed(lambda: query(ray))
    secs, cpus, pi = [], [], None
    for _ in range(positive_int("repeats", repeats)):
        ray = rays()
        pi, wall, cpu = timed(lambda: query(ray))
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




def ray_benchmark(*, triangles=(100_000, 1_000_000), rays: int = 1 << 20, threads: int = 2, repeats: int = 3,
                  kinds=RAY_KINDS, variant: str | None = "llvm_ad_rgb", seed: int = 0, log=None) -> dict:
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
        ``rows``: per (triangles, kind), ``requested_triangles`` (the size asked for;
        ``triangles`` is the mesh's own count), ``ours_mrays_per_second`` (distance and primitive,
        as Mitsuba's preliminary intersection; timed from the Python call to its return, as
        Mitsuba's side is; ``ours_query_seconds``: the query's own wall time inside it),
        ``ours_full_mrays_per_second`` (with the hit point and normal), ``mitsuba_mrays_per_second``, ``ratio`` and ``ratio_full``
        (ours / Mitsuba, median of the paired per-repeat ratios; ``ratio_min`` /
        ``ratio_max`` and ``ratio_full_min`` / ``_max`` their range, ``round_ratios`` and
        ``round_ratios_full`` each repeat's), CPU-time figures, agreement (:func:`hit_agreement`), ours'
        ``build_seconds`` and ``build_seconds_per_mtri``, Mitsuba's ``load_seconds``
        and ``first_call_seconds``; plus ``config``, ``environment``, ``mitsuba``.
    """
    sizes = [positive_int("triangles", t, minimum=32)
             for t in (triangles if not isinstance(triangles, (int, np.integer)) else [triangles])]
    if not sizes:
        raise ValueError("triangles must name at least one mesh size")
    kinds = name_list("kinds", kinds, RAY_KINDS)
    rays, threads = positive_int("rays", rays), positive_int("threads", threads)
    repeats = positive_int("repeats", repeats)
    out = {"config": {"triangles": sizes, "rays": rays, "threads": threads, "repeats": repeats, "kinds": kinds,
                      "variant": variant, "seed": seed},
           "environment": environment(), "rows": [], "mitsuba": {}}
    use_mi = False
    if variant is not None:
        use_mi, skipped = check_jit_variant(variant, "ray", log)
        out["mitsuba"] = {"variant": variant if use_mi else None, "skipped": skipped}
        if use_mi:
            out["mitsuba"]["versions"] = mitsuba_versions()
    for n_target in sizes:
        scene = mesh_scene(n_target, seed=seed)
        ntri = int(len(scene.shapes[0].faces))
        core, wall_build, _ = timed(lambda: core_scene(scene))
        build = float(core.build_seconds)
        mscene, load = load_mitsuba(variant, scene, threads, check_merge=False) if use_mi else (None, None)
        if log:
            log(f"{ntri} triangles: our BVH build {build:.3f} s ({build / ntri * 1e6:.3f} s/Mtri), "
                f"{core.bvh_nodes} nodes, depth {core.bvh_depth}"
                + (f"; Mitsuba load {load:.3f} s" if use_mi else ""))
        built = {"build_seconds": build, "build_seconds_per_mtri": build / ntri * 1e6,
                 "compile_and_build_seconds": wall_build, "bvh_nodes": int(core.bvh_nodes),
                 "bvh_depth": int(core.bvh_depth)}
        for kind in kinds:
            row = _ray_row(core, mscene, kind, triangles=ntri, built=built, load_seconds=load, rays=rays,
                           threads=threads, repeats=repeats, variant=variant, seed=seed)
            out["rows"].append({"requested_triangles": n_target, **row})
            if log:
                msg = (f"  {kind}: ours {row['ours_mrays_per_second']:.2f} Mrays/s "
                       f"({row['ours_full_mrays_per_second']:.2f} with hit point and normal)")
                if use_mi:
                    msg += (f", Mitsuba {row['mitsuba_mrays_per_second']:.2f} Mrays/s, ratio {row['ratio']:.2f} "
                            f"({row['ratio_full']:.2f}), hit agreement {row['agree_hit_agreement']:.5f}")
                log(msg)
        del core, mscene
        scene._core_cache.clear()
    out["environment_after"] = environment()
    return out


def _ray_row(core, mscene, kind, *, triangles, built, load_seconds, rays, threads, repeats, variant, seed) -> dict:
    """One row of :func:`ray_benchmark`: ``repeats`` interleaved timed queries per side.

    ``mscene`` None measures ours only; ``built`` holds our BVH's build figures.
    """
    o, d = {"primary": primary_rays, "random": random_rays}[kind](rays, seed=seed)
    n = len(o)
    ours_secs, ours_query, ours_cpu, full_secs, full_cpu, mi_secs, mi_cpu, first = [], [], [], [], [], [], [], None
    ours = full = mres = None
    for _ in range(repeats):   # interleaved, one timed query per side per round
        # The like-for-like query (distance and primitive, as Mitsuba's preliminary
        # intersection), then ours with the hit point and normal filled in.
        # Timed from the Python call to its return, as Mitsuba's side is (its outputs'
        # allocation included): the query's own time leaves out allocating and handing over
        # our output arrays, 0.5-1.4% of the like-for-like query on 1M triangles and up to
        # 28% of the full one (48 bytes a ray of hit point and normal).
        ours = intersect_ours(core, o, d, threads=threads, repeats=1, preliminary=True)
        ours_secs += ours["call_seconds"]
        ours_query += ours["seconds"]
        ours_cpu += ours["process_seconds"]
        full = intersect_ours(core, o, d, threads=threads, repeats=1)
        full_secs += full["call_seconds"]
        full_cpu += full["process_seconds"]
        if mscene is not None:
            use_variant(variant, threads)
            mres = intersect_mitsuba(mscene, o, d, repeats=1)
            mi_secs += mres["seconds"]
            mi_cpu += mres["process_seconds"]
            first = mres["first_call_seconds"] if first is None else first
    if not (np.array_equal(ours["t"], full["t"]) and np.array_equal(ours["prim"], full["prim"])):
        raise RuntimeError(f"{kind} rays: the preliminary and the full closest-hit queries disagree")
    row = {"triangles": triangles, "kind": kind, "rays": n, "threads": threads, **built,
           **_rate_columns("ours", n, ours_secs, ours_cpu), **_rate_columns("ours_full", n, full_secs, full_cpu),
           "ours_query_seconds": ours_query,
           "hit_fraction": float(np.isfinite(ours["t"]).mean()),
           "ours_packet_fraction": ours["packet_fraction"]}
    if mscene is not None:
        # Paired per round: ours and Mitsuba ran back to back, so a round's ratio sees the
        # machine alike on both sides; the range shows how far single rounds scatter.
        ratios = [m / o_ for o_, m in zip(ours_secs, mi_secs)]
        ratios_full = [m / o_ for o_, m in zip(full_secs, mi_secs)]
        agree = hit_agreement(ours["t"], mres["t"])
        both = np.isfinite(ours["t"]) & np.isfinite(mres["t"])
        row.update({**_rate_columns("mitsuba", n, mi_secs, mi_cpu),
                    "ratio": median(ratios), "ratio_min": min(ratios), "ratio_max": max(ratios),
                    "round_ratios": ratios,
                    "ratio_full": median(ratios_full), "ratio_full_min": min(ratios_full),
                    "ratio_full_max": max(ratios_full), "round_ratios_full": ratios_full,
                    "mitsuba_load_seconds": load_seconds, "mitsuba_first_call_seconds": first,
                    "prim_agreement": float(np.mean(ours["prim"][both] == mres["prim"][both]))
                    if both.any() else float("nan"),
                    **{f"agree_{k}": v for k, v in agree.items()}})
    return row


def _rate_columns(who, n, secs, cpus) -> dict:
    """``{who}_seconds`` ... ``{who}_ns_per_ray`` of ``n`` rays timed ``secs`` (wall) and ``cpus``.

    Examples
    --------
    >>> _rate_columns("ours", 1000, [0.001, 0.002], [0.002, 0.002])["ours_mrays_per_second"]
    0.6666666666666666
    """
    wall, cpu = median(secs), median(cpus)
    return {f"{who}_seconds": secs, f"{who}_process_seconds": cpus,
            f"{who}_mrays_per_second": n / wall / 1e6,
            f"{who}_mrays_per_cpu_second": n / cpu / 1e6 if cpu > 0 else None,
            f"{who}_ns_per_ray": wall / n * 1e9}
