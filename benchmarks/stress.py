"""Numerical stability on hard cases: the measurements behind ``rtbench stress`` (issue 8).

Every case is a function that measures a figure on the tracer and returns a
:class:`StressRecord` (case, figure, verdict, details). ``tests/test_stress_*.py``
assert on the same functions; ``rtbench stress`` prints them as a table.

Cases
-----
``watertight_mesh``
    Rays aimed exactly at shared edges and vertices of closed icospheres, cast from
    inside: escapes per triangle test (the shipped default must leak none).
``grazing_rays``
    Rays within 1e-7 rad of a triangle's or quad's plane, and exactly parallel rays:
    hit/miss compared with exact rational arithmetic on the same float64 ray.
``degenerate_input``
    Zero-area, collinear and all-equal-vertex triangles, duplicate vertices, 100,000
    triangles with one bounding box: build time, never hit, no NaN.
``scale_invariance``
    The Cornell box at scale 1e-4, 1, 1e4 and translated 1e5 away: the same image
    within noise; a white furnace with creases at every scale: exactly 1 per sample.
``light_sampling``
    Points on a quad light, on its plane, behind it, grazing it, inside / on / just
    outside a sphere light: finite pdfs, estimates equal to closed-form solid angles,
    and renders of a floor cutting a sphere light agree across strategies.
``glass``
    A camera inside a glass sphere (rays start inside; total internal reflection traps
    the tangential ones) against closed forms, and ior 1.0 against no glass.
``white_furnace``
    An albedo-1 sphere in a constant background 1: exactly 1 per sample for ``cosine``,
    1 in expectation for every other strategy.
``fireflies``
    ``small_light``: samples above 100x the image mean, per strategy.
``suite_nonfinite``
    Every suite scene under every strategy: NaN/Inf samples discarded.

Statistical decisions use :func:`image_ztest` (nominal false-positive rate 1e-4 per
comparison) or a z-score against a closed form with |z| <= 5 (5.7e-7 per check).
"""
from __future__ import annotations

import inspect
import math
import time
from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np
from scipy import stats

import reference_tracer as rt
from reference_tracer.render import core_scene

__all__ = [
    "StressRecord", "CASES", "run_cases", "UNIT_ROUNDOFF",
    "watertight_mesh", "grazing_rays", "degenerate_input", "scale_invariance", "light_sampling",
    "glass", "white_furnace", "fireflies", "suite_nonfinite",
    "icosphere", "edge_and_vertex_rays", "count_escapes", "probe_scene",
    "exact_intersection", "triangle_error_bound", "quad_error_bound", "classify_rays",
    "image_ztest", "constant_ztest", "transform_scene", "white_furnace_scene", "creased_furnace_scene",
    "triangle_solid_angle", "quad_solid_angle", "fresnel_dielectric", "camera_rays",
    "small_light_scene", "firefly_counts", "same_box_triangles", "LUMINANCE", "SCALES",
]

#: Unit roundoff of float64, 2^-53.
UNIT_ROUNDOFF = 2.0 ** -53
#: Rec. 709 luminance weights (as the C++ core's ``luminance``).
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


@dataclass
class StressRecord:
    """One hard case: its measured figure and the verdict.

    Attributes
    ----------
    case : str
        Case name (the function's name).
    figure : str
        The measured figure(s), one line for the table.
    passed : bool
    details : dict
        Every number behind the figure (JSON-able).
    seconds : float
        Wall time of the measurement.
    """

    case: str
    figure: str
    passed: bool
    details: dict = field(default_factory=dict)
    seconds: float = 0.0

    @property
    def verdict(self) -> str:
        return "pass" if self.passed else "FAIL"


def _record(case, figure, passed, details, t0):
    return StressRecord(case=case, figure=figure, passed=bool(passed), details=details,
                        seconds=time.perf_counter() - t0)


# --------------------------------------------------------------------------- geometry helpers

def _c(a) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64)


def probe_scene(shapes, *, background=0.0, width=4, height=4, lookfrom=(0.0, 0.0, -10.0),
                lookat=(0.0, 0.0, 0.0), max_depth=50) -> rt.Scene:
    """A scene holding ``shapes`` with a small camera, for ray queries and small renders."""
    cam = rt.Camera(lookfrom=lookfrom, lookat=lookat, vup=(0, 1, 0), vfov=60.0, width=width, height=height)
    return rt.Scene(camera=cam, shapes=list(shapes), background=background, max_depth=max_depth)


def icosphere(subdivisions: int, *, radius: float = 1.0):
    """A closed icosphere (trimesh): vertices (N, 3), faces (M, 3), unique edges (E, 2)."""
    import trimesh

    ico = trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius)
    if not ico.is_watertight:  # pragma: no cover - trimesh guarantees it
        raise RuntimeError("trimesh icosphere is not closed")
    return (np.asarray(ico.vertices, dtype=np.float64), np.asarray(ico.faces, dtype=np.int64),
            np.asarray(ico.edges_unique, dtype=np.int64))


def edge_and_vertex_rays(vertices, edges, origins, rng):
    """Rays from ``origins`` aimed exactly at mesh edges and vertices.

    A third of the rays aim at a uniformly random point of a random edge (``a + s (b - a)``
    in float64), a third at an edge's midpoint, a third at a vertex.

    Returns
    -------
    directions : (N, 3) float64
        ``target - origin``.
    kind : (N,) int
        0 random edge point, 1 edge midpoint, 2 vertex.
    """
    n = len(origins)
    kind = rng.integers(0, 3, n)
    e = edges[rng.integers(0, len(edges), n)]
    a, b = vertices[e[:, 0]], vertices[e[:, 1]]
    s = np.where(kind == 1, 0.5, rng.uniform(0.0, 1.0, n))[:, None]
    target = np.where((kind == 2)[:, None], vertices[rng.integers(0, len(vertices), n)], a + s * (b - a))
    return _c(target - origins), kind


def count_escapes(scene: rt.Scene, origins, directions, *, triangle_test: str) -> dict:
    """Cast rays with ``triangle_test``; count misses (escapes) and non-finite hit distances."""
    hit = core_scene(scene, triangle_test=triangle_test).intersect(_c(origins), _c(directions))
    t = hit["t"]
    miss = hit["prim"] < 0
    return {"escapes": int(miss.sum()), "nan": int(np.isnan(t).sum()), "escaped": miss,
            "nonfinite_hits": int((~miss & ~np.isfinite(t)).sum())}


def _frac3(v):
    return [Fraction(float(x)) for x in v]


def exact_intersection(o, d, p, e1, e2) -> dict:
    """Exact (rational) intersection of the float64 ray ``o + t d`` with ``p + s1 e1 + s2 e2``.

    ``p``, ``e1``, ``e2`` may be float64 or already exact (lists of ``Fraction``): for a
    triangle pass ``e1 = b - a`` and ``e2 = c - a`` computed in ``Fraction`` so no rounding
    enters; for a quad pass its ``u`` and ``v`` as the core receives them.

    Returns
    -------
    dict
        ``parallel`` (the exact determinant is 0); otherwise ``t``, ``s1``, ``s2`` as
        ``Fraction``. Always ``plane_distance``: the exact distance from ``o`` to the plane,
        as a float.
    """
    o, d = _frac3(o), _frac3(d)
    p = p if isinstance(p[0], Fraction) else _frac3(p)
    e1 = e1 if isinstance(e1[0], Fraction) else _frac3(e1)
    e2 = e2 if isinstance(e2[0], Fraction) else _frac3(e2)
    s = [o[i] - p[i] for i in range(3)]

    def cross(x, y):
        return [x[1] * y[2] - x[2] * y[1], x[2] * y[0] - x[0] * y[2], x[0] * y[1] - x[1] * y[0]]

    def dot(x, y):
        return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]

    n = cross(e1, e2)
    nn = dot(n, n)
    out = {"plane_distance": math.sqrt(float(dot(n, s) ** 2 / nn)) if nn else math.inf}
    # Cramer's rule for [-d, e1, e2] (t, s1, s2)^T = s, with triple products.
    q = cross(d, e2)
    det = dot(e1, q)
    if det == 0:
        out["parallel"] = True
        return out
    r = cross(s, e1)
    out.update(parallel=False, t=dot(e2, r) / det, s1=dot(s, q) / det, s2=dot(d, r) / det)
    return out


def triangle_error_bound(o, d, a, b, c) -> float:
    """Barycentric forward-error bound of the watertight test (float64) for one ray.

    In the sheared frame the vertex coordinates carry an absolute error of at most
    ~6 u S (u = 2^-53, S = max |v - o| over the vertices, |shear| <= 1), so each edge
    function U = Cx By - Cy Bx is off by at most ~64 u S^2; the barycentric is U / det
    with det >= 2 A |cos| (A the area, cos between the normal and the ray). Hence
    delta = 32 u S^2 / (A |cos|), to first order.
    """
    o, d, a, b, c = (np.asarray(x, dtype=np.float64) for x in (o, d, a, b, c))
    S = max(np.abs(a - o).max(), np.abs(b - o).max(), np.abs(c - o).max())
    n = np.cross(b - a, c - a)
    area = 0.5 * np.linalg.norm(n)
    cos = abs(n @ d) / (np.linalg.norm(n) * np.linalg.norm(d))
    return 32.0 * UNIT_ROUNDOFF * S * S / (area * cos) if area > 0 and cos > 0 else math.inf


def quad_error_bound(o, d, Q, u, v, t) -> float:
    """Parallelogram-coordinate forward-error bound of the quad test for one ray.

    t = (n.Q - n.o) / (n.d) with a rounded unit normal: the computed hit point lies off
    the exact one by about u (|Q| + |o| + t |d|) / |cos| times a small count of roundings
    (normal, two dot products, the division, o + t d, hp - Q); the coordinate
    alpha = w.(hp x v) turns a point error into a coordinate error over the height
    |u x v| / |v|. Hence delta = 32 u (|Q| + |o| + t |d|) / (|cos| h_min), with h_min
    the smaller height of the parallelogram, to first order.
    """
    o, d, Q, u, v = (np.asarray(x, dtype=np.float64) for x in (o, d, Q, u, v))
    n = np.cross(u, v)
    area = np.linalg.norm(n)
    h_min = area / max(np.linalg.norm(u), np.linalg.norm(v))
    cos = abs(n @ d) / (area * np.linalg.norm(d))
    scale = np.linalg.norm(Q) + np.linalg.norm(o) + abs(t) * np.linalg.norm(d)
    return 32.0 * UNIT_ROUNDOFF * scale / (cos * h_min) if cos > 0 else math.inf


def classify_rays(shape: str, verts, origins, directions, hit_t, hit_prim) -> dict:
    """Compare float64 hits with exact arithmetic on the same rays (see :func:`grazing_rays`).

    Parameters
    ----------
    shape : {'triangle', 'quad'}
    verts : (3, 3) float64
        ``(a, b, c)`` of the triangle or ``(Q, u, v)`` of the quad.
    origins, directions : (N, 3) float64
    hit_t, hit_prim : (N,) results of the core's ``intersect``.

    Returns
    -------
    dict of per-ray arrays: ``exact_hit`` (bool, or False for parallel rays), ``parallel``,
    ``plane_distance``, ``margin`` (exact signed distance of the crossing point to the
    boundary, in barycentric / parallelogram coordinates; nan when parallel), ``delta``
    (the forward-error bound), ``t_exact`` (float; nan when parallel), ``delta_plane``
    (the rounding-level distance to the plane for parallel rays).
    """
    verts = np.asarray(verts, dtype=np.float64)
    if shape == "triangle":
        a, b, c = verts
        fa, fb, fc = _frac3(a), _frac3(b), _frac3(c)
        p, e1, e2 = fa, [fb[i] - fa[i] for i in range(3)], [fc[i] - fa[i] for i in range(3)]
        size = max(np.linalg.norm(b - a), np.linalg.norm(c - a), np.linalg.norm(c - b))
    else:
        Q, u, v = verts
        p, e1, e2 = Q, u, v
        size = max(np.linalg.norm(u), np.linalg.norm(v))
    n = len(origins)
    out = {k: np.full(n, np.nan) for k in ("margin", "delta", "t_exact", "plane_distance", "delta_plane")}
    out["exact_hit"] = np.zeros(n, dtype=bool)
    out["parallel"] = np.zeros(n, dtype=bool)
    for i in range(n):
        o, d = origins[i], directions[i]
        ex = exact_intersection(o, d, p, e1, e2)
        out["plane_distance"][i] = ex["plane_distance"]
        S = max(np.abs(verts[0] - o).max(), np.abs(o).max(), np.abs(verts).max())
        out["delta_plane"][i] = 64.0 * UNIT_ROUNDOFF * S * S / size
        if ex["parallel"]:
            out["parallel"][i] = True
            continue
        t, s1, s2 = ex["t"], ex["s1"], ex["s2"]
        if shape == "triangle":
            margin = min(s1, s2, 1 - s1 - s2)
            out["delta"][i] = triangle_error_bound(o, d, *verts)
        else:
            margin = min(s1, 1 - s1, s2, 1 - s2)
            out["delta"][i] = quad_error_bound(o, d, *verts, float(t))
        out["margin"][i] = float(margin)
        out["t_exact"][i] = float(t)
        out["exact_hit"][i] = t > 0 and margin >= 0
    hit = np.asarray(hit_prim) >= 0
    disagree = hit != out["exact_hit"]
    grazing = ~out["parallel"]
    # A float decision may differ from the exact one only within the error bound of the
    # boundary; an exactly parallel ray must miss unless it lies (to rounding) in the plane.
    out["violation"] = (grazing & disagree & ~(np.abs(out["margin"]) <= out["delta"])) | \
                       (out["parallel"] & hit & (out["plane_distance"] > out["delta_plane"]))
    out["boundary_disagreement"] = grazing & disagree & ~out["violation"]
    out["hit"] = hit
    t = np.asarray(hit_t)
    out["nan"] = np.isnan(t) | (hit & ~np.isfinite(t))
    both = hit & out["exact_hit"]
    out["t_rel_error"] = np.where(both, np.abs(t - out["t_exact"]) / np.abs(out["t_exact"]), 0.0)
    return out


def _random_cell(rng, scale_exp):
    """Three points in [1, 2)^3 * 2^k: all differences are exact in float64 (Sterbenz)."""
    return rng.uniform(1.0, 2.0, (3, 3)) * 2.0 ** scale_exp


def _grazing_batch(rng, shape, verts, n_grazing, n_parallel):
    """Rays within 1e-7 rad of the plane of ``verts`` aimed around its boundary, plus
    rays exactly parallel to the plane (directions are exact in-plane differences)."""
    if shape == "triangle":
        a, b, c = verts
        P0, e1, e2 = a, b - a, c - a       # exact differences
        parallel_dirs = [e1, e2, c - b]
    else:
        Q, u, v = verts
        P0, e1, e2 = Q, u, v
        parallel_dirs = [u, v, u - v]     # u - v = P1 - P2 exactly
    nrm = np.cross(e1, e2)
    nhat = nrm / np.linalg.norm(nrm)
    t1 = e1 / np.linalg.norm(e1)
    t2 = np.cross(nhat, t1)
    size = max(np.linalg.norm(e1), np.linalg.norm(e2))
    # Target coordinates: half in a margin around the shape, half exactly on an edge.
    s = rng.uniform(-0.05, 1.05, (n_grazing, 2))
    on_edge = rng.random(n_grazing) < 0.5
    which = rng.integers(0, 3, n_grazing)
    if shape == "triangle":
        s[on_edge & (which == 0), 0] = 0.0
        s[on_edge & (which == 1), 1] = 0.0
        m = on_edge & (which == 2)
        s[m, 1] = 1.0 - s[m, 0]
    else:
        m0 = on_edge & (which < 2)
        s[m0, 0] = which[m0].astype(float)   # alpha = 0 or 1
        m1 = on_edge & (which == 2)
        s[m1, 1] = rng.integers(0, 2, m1.sum()).astype(float)
    target = P0 + s[:, :1] * e1 + s[:, 1:] * e2
    psi = rng.uniform(0, 2 * np.pi, n_grazing)
    w = np.cos(psi)[:, None] * t1 + np.sin(psi)[:, None] * t2
    phi = rng.choice([-1.0, 1.0], n_grazing) * 10.0 ** rng.uniform(-9, -7, n_grazing)
    d = np.cos(phi)[:, None] * w + np.sin(phi)[:, None] * nhat
    o = target - rng.uniform(0.5, 2.0, (n_grazing, 1)) * size * d
    # Exactly parallel rays: off the plane (must miss) and in it (from the vertices).
    k = rng.integers(0, 3, n_parallel)
    dp = np.array([parallel_dirs[j] for j in k]) * rng.choice([-1.0, 1.0], (n_parallel, 1))
    sp = rng.uniform(0.0, 1.0, (n_parallel, 2))
    inplane = rng.random(n_parallel) < 0.5
    h = rng.choice([-1.0, 1.0], n_parallel) * size * 10.0 ** rng.uniform(-6, -1, n_parallel)
    po = P0 + sp[:, :1] * e1 + sp[:, 1:] * e2 - 0.7 * dp + h[:, None] * nhat
    corners = np.array([verts[0], verts[1], verts[2]]) if shape == "triangle" else np.array([Q, Q + u, Q + v])
    po[inplane] = corners[rng.integers(0, 3, inplane.sum())]
    return _c(np.vstack([o, po])), _c(np.vstack([d, dp]))


def grazing_rays(*, shapes: int = 25, rays_per_shape: int = 80, seed: int = 0) -> StressRecord:
    """Grazing (|angle to the plane| in [1e-9, 1e-7] rad) and exactly parallel rays.

    For random triangles (watertight test, the default) and quads, rays aimed around the
    boundary are cast with the core and decided again in exact rational arithmetic
    (``fractions.Fraction``) on the same float64 inputs.

    Consistency at the boundary: a float64 decision may differ from the exact one only
    when the exact crossing point lies within the forward-error bound ``delta`` of the
    boundary (:func:`triangle_error_bound`, :func:`quad_error_bound`; in barycentric
    units), i.e. when a relative perturbation of the inputs of a few ulps would flip the
    exact answer too. An exactly parallel ray has no crossing: it must miss unless it
    lies in the plane to rounding (then either answer is consistent). Every hit must
    report a finite distance; no NaN anywhere.

    Parameters
    ----------
    shapes : int, keyword-only
        Random triangles, and as many quads.
    rays_per_shape : int, keyword-only
        Rays per shape; a fifth of them exactly parallel.
    seed : int, keyword-only
    """
    t0 = time.perf_counter()
    rng = np.random.default_rng(seed)
    mat = rt.Lambertian(0.5)
    n_par = rays_per_shape // 5
    stats_ = {}
    for shape in ("triangle", "quad"):
        acc = {"rays": 0, "violations": 0, "boundary_disagreements": 0, "nan": 0, "parallel_rays": 0,
               "parallel_off_plane_hits": 0, "in_plane_hits": 0, "exact_hits": 0, "hits": 0,
               "max_margin_over_delta": 0.0, "max_t_rel_error": 0.0}
        for _ in range(shapes):
            k = int(rng.integers(-20, 21))
            P = _random_cell(rng, k)
            if shape == "triangle":
                verts = P
                shp = rt.Triangle(*P, mat)
            else:
                verts = np.array([P[0], P[1] - P[0], P[2] - P[0]])
                shp = rt.Quad(*verts, mat)
            o, d = _grazing_batch(rng, shape, verts, rays_per_shape - n_par, n_par)
            hit = core_scene(probe_scene([shp])).intersect(o, d)
            cl = classify_rays(shape, verts, o, d, hit["t"], hit["prim"])
            acc["rays"] += len(o)
            acc["violations"] += int(cl["violation"].sum())
            acc["boundary_disagreements"] += int(cl["boundary_disagreement"].sum())
            acc["nan"] += int(cl["nan"].sum())
            acc["parallel_rays"] += int(cl["parallel"].sum())
            off = cl["parallel"] & (cl["plane_distance"] > cl["delta_plane"])
            acc["parallel_off_plane_hits"] += int((off & cl["hit"]).sum())
            acc["in_plane_hits"] += int((cl["parallel"] & ~off & cl["hit"]).sum())
            acc["exact_hits"] += int(cl["exact_hit"].sum())
            acc["hits"] += int(cl["hit"].sum())
            dis = cl["boundary_disagreement"]
            if dis.any():
                acc["max_margin_over_delta"] = max(acc["max_margin_over_delta"],
                                                   float(np.max(np.abs(cl["margin"][dis]) / cl["delta"][dis])))
            acc["max_t_rel_error"] = max(acc["max_t_rel_error"], float(cl["t_rel_error"].max()))
        stats_[shape] = acc
    passed = all(s["violations"] == 0 and s["nan"] == 0 for s in stats_.values())
    tri, quad = stats_["triangle"], stats_["quad"]
    figure = (f"inconsistent with exact: triangle {tri['violations']}/{tri['rays']}, quad "
              f"{quad['violations']}/{quad['rays']} (within error bound: {tri['boundary_disagreements']}, "
              f"{quad['boundary_disagreements']}); NaN {tri['nan'] + quad['nan']}")
    return _record("grazing_rays", figure, passed, stats_, t0)


# --------------------------------------------------------------------------- watertight meshes

def watertight_mesh(*, rays: int = 100_000, subdivisions=(1, 2, 3, 4), seed: int = 0,
                    render_width: int = 32) -> StressRecord:
    """Rays from inside closed icospheres aimed exactly at shared edges and vertices.

    Counts the rays that escape (hit nothing) with each triangle test of
    ``rt.TRIANGLE_TESTS``: Cramer's rule in float32 and float64 leak, the watertight
    test (Woop, Benthin and Wald 2013) must not, and it must be the default of
    ``rt.render``. Also renders a black icosphere around the camera in a white
    background: any pixel above 0 is light leaking through the mesh.

    Parameters
    ----------
    rays : int, keyword-only
        Rays per triangle test, split evenly over the subdivision levels.
    subdivisions : sequence of int, keyword-only
        Icosphere subdivision levels (level s has 20 * 4^s faces).
    seed : int, keyword-only
    render_width : int, keyword-only
        Image size of the leak render (4 spp per subdivision level).
    """
    t0 = time.perf_counter()
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
        origins = _c(origins)
        dirs, kind = edge_and_vertex_rays(V, E, origins, rng)
        scene = probe_scene([rt.Mesh(V, F, rt.Lambertian(0.0))], background=1.0,
                            lookfrom=(0.1, 0.05, -0.2), lookat=(0.3, -0.2, 1.0),
                            width=render_width, height=render_width)
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
    return _record("watertight_mesh", figure, passed, details, t0)


# --------------------------------------------------------------------------- degenerate input

def _build_seconds(scene: rt.Scene, repeats: int) -> tuple:
    """Minimum C++ build time over ``repeats`` fresh builds, and the last core scene."""
    from reference_tracer import _core
    from reference_tracer._compile import compile_scene

    kwargs = compile_scene(scene)
    best, core = math.inf, None
    for _ in range(repeats):
        core = _core.Scene(**kwargs, triangle_test=0)
        best = min(best, core.build_seconds)
    return best, core


def same_box_triangles(n: int, rng) -> np.ndarray:
    """``n`` random triangles whose bounding boxes are all exactly [-1, 1]^3 (one centroid).

    a = (-1, -1, r1), b = (1, r2, -1), c = (r3, 1, 1) with r in (-1, 1): every axis has
    its minimum -1 and maximum 1, so the binned SAH finds no centroid extent at all.
    """
    r = rng.uniform(-0.99, 0.99, (n, 3))
    tris = np.empty((n, 3, 3))
    tris[:, 0] = np.c_[-np.ones(n), -np.ones(n), r[:, 0]]
    tris[:, 1] = np.c_[np.ones(n), r[:, 1], -np.ones(n)]
    tris[:, 2] = np.c_[r[:, 2], np.ones(n), np.ones(n)]
    return tris


def degenerate_input(*, coincident: int = 100_000, seed: int = 0, repeats: int = 3) -> StressRecord:
    """Zero-area, collinear, all-equal and coincident triangles: bounded build, never hit.

    * A mesh of zero-area faces (a repeated index; duplicate vertex positions under
      different indices), exactly collinear faces and an all-vertices-equal mesh, next to
      one ordinary triangle: rays aimed at their vertices and along their segments must
      never report them, must agree with brute force, and renders with and without them
      (the degenerate faces last, so primitive ids match) must be bit-identical.
    * Duplicate vertices: a closed icosphere stored with three private vertices per face
      stays watertight (edge/vertex rays from inside: zero escapes).
    * ``coincident`` triangles whose bounding boxes are all [-1, 1]^3 (one centroid, no
      SAH split possible): the C++ build time (best of ``repeats``) against an ordinary
      mesh of as many small scattered triangles. Both builds are O(n log n) (the builder
      falls back to median splits), so the ratio is about 1; the bound is 4 (timing noise
      on a loaded machine), where a quadratic fallback would be ~n / log n = 1e4 times
      slower. The growth for 10x the triangles is reported beside n log n's (12.5 for
      1e5; memory caches push both measured growths above it). Closest hits on 200 rays
      must equal brute force.

    Parameters
    ----------
    coincident : int, keyword-only
        Triangles with one bounding box (>= 1000).
    seed : int, keyword-only
    repeats : int, keyword-only
        Builds timed per size (the minimum counts).
    """
    t0 = time.perf_counter()
    rng = np.random.default_rng(seed)
    lam = rt.Lambertian(0.5)
    light = rt.DiffuseLight(4.0)
    # --- zero-area, collinear, all-equal, duplicate-position faces
    V = np.array([[0.0, 0.0, 0.0], [1.0, 0.5, 0.25], [2.0, 1.0, 0.5], [0.0, 1.0, 0.0],
                  [0.25, 0.75, 0.5], [0.25, 0.75, 0.5], [-1.0, 0.5, 1.5]])
    F = np.array([[0, 0, 3],      # repeated index
                  [4, 5, 3],      # duplicate positions under distinct indices
                  [0, 1, 2],      # exactly collinear (2 = 2 * 1)
                  [1, 0, 2],      # collinear, other order
                  [3, 3, 3],      # one point
                  [6, 6, 0]])     # segment
    degenerate = rt.Mesh(V, F, lam)
    same = rt.Mesh(np.full((30, 3), 0.3), rng.integers(0, 30, (40, 3)), light)   # all vertices equal
    ordinary = rt.Triangle((-2, -2, 3), (3, -2, 3), (0, 3, 3), lam)
    floor = rt.Quad((-5, -2.5, -5), (0, 0, 10), (10, 0, 0), lam)
    lamp = rt.Quad((-1, 3, -1), (2, 0, 0), (0, 0, 2), light)
    base = [floor, lamp, ordinary]
    with_deg = probe_scene(base + [degenerate, same], background=0.2, lookfrom=(0.3, 0.4, -6),
                           lookat=(0.2, 0.3, 0), width=24, height=24)
    without = probe_scene(base, background=0.2, lookfrom=(0.3, 0.4, -6), lookat=(0.2, 0.3, 0),
                          width=24, height=24)
    n_base = 2 + 1  # quads then the ordinary triangle: ids 0..2
    # Rays at every degenerate vertex and along their segments, from random origins.
    pts = np.vstack([V, V[0] + rng.random((200, 1)) * (V[2] - V[0]), V[6] + rng.random((200, 1)) * (V[0] - V[6]),
                     np.full((1, 3), 0.3)])
    origins = _c(rng.uniform(-4, 4, (len(pts) * 4, 3)) + np.array([0, 0, -6.0]))
    targets = np.repeat(pts, 4, axis=0)
    dirs = _c(targets - origins)
    ray_hits = {}
    for test in rt.TRIANGLE_TESTS:
        cs = core_scene(with_deg, triangle_test=test)
        h, hb = cs.intersect(origins, dirs), cs.intersect(origins, dirs, brute_force=True)
        h0 = core_scene(without, triangle_test=test).intersect(origins, dirs)
        ray_hits[test] = {
            "degenerate_hits": int((h["prim"] >= n_base).sum()),
            "brute_force_mismatch": int((h["prim"] != hb["prim"]).sum() + (h["t"] != hb["t"]).sum()),
            "differs_from_without": int((h["prim"] != h0["prim"]).sum() + (h["t"] != h0["t"]).sum()),
            "nan": int(np.isnan(h["t"]).sum() + (~np.isfinite(h["point"][h["prim"] >= 0])).sum()),
        }
    img_diff, nonfinite = 0, 0
    for strategy in rt.STRATEGIES:
        a = rt.render(with_deg, spp=4, strategy=strategy, seed=seed, threads=1)
        b = rt.render(without, spp=4, strategy=strategy, seed=seed, threads=1)
        img_diff += int((a.mean != b.mean).sum())
        nonfinite += a.nonfinite_samples + b.nonfinite_samples
    core = core_scene(with_deg)
    # --- duplicate vertices: a closed mesh with private vertices per face
    Vi, Fi, Ei = icosphere(3)
    Vs = Vi[Fi].reshape(-1, 3)
    Fs = np.arange(len(Vs)).reshape(-1, 3)
    split = probe_scene([rt.Mesh(Vs, Fs, lam)])
    o = _c(np.zeros((20_000, 3)) + rng.uniform(-0.3, 0.3, (20_000, 3)))
    d, _ = edge_and_vertex_rays(Vi, Ei, o, rng)
    split_escapes = count_escapes(split, o, d, triangle_test="watertight")["escapes"]
    # --- coincident bounding boxes: build time against an ordinary input of the same size
    def mesh_of(tris):
        return probe_scene([rt.Mesh(tris.reshape(-1, 3), np.arange(3 * len(tris)).reshape(-1, 3), lam)])

    tris = same_box_triangles(coincident, rng)
    centres = rng.uniform(-1.0, 1.0, (coincident, 1, 3))
    ordinary_tris = centres + 0.02 * rng.normal(size=(coincident, 3, 3))
    big = mesh_of(tris)
    t_tenth, _ = _build_seconds(mesh_of(tris[: coincident // 10]), repeats)
    t_big, core_big = _build_seconds(big, repeats)
    t_ordinary, _ = _build_seconds(mesh_of(ordinary_tris), repeats)
    t_ordinary_tenth, _ = _build_seconds(mesh_of(ordinary_tris[: coincident // 10]), repeats)
    ratio = t_big / max(t_ordinary, 1e-9)
    growth = t_big / max(t_tenth, 1e-9)
    growth_ordinary = t_ordinary / max(t_ordinary_tenth, 1e-9)
    expected = 10 * math.log(coincident) / math.log(coincident / 10)
    big._core_cache["watertight"] = core_big
    o = _c(rng.uniform(-3, 3, (200, 3)) * [1, 1, 0] + [0, 0, -5])
    d = _c(rng.uniform(-0.8, 0.8, (200, 3)) - o * [1, 1, 0] + [0, 0, 5])
    hb = core_big.intersect(o, d, brute_force=True)
    hh = core_big.intersect(o, d)
    coincident_mismatch = int((hh["prim"] != hb["prim"]).sum() + (hh["t"] != hb["t"]).sum())
    bound = 4.0
    passed = (all(v["degenerate_hits"] == 0 and v["brute_force_mismatch"] == 0 and v["differs_from_without"] == 0
                  and v["nan"] == 0 for v in ray_hits.values())
              and img_diff == 0 and nonfinite == 0 and split_escapes == 0 and ratio <= bound
              and t_big < 10.0 and coincident_mismatch == 0 and core.emitter_count == 1)
    figure = (f"{coincident:,} same-box tris build {t_big * 1e3:.0f} ms = x{ratio:.2f} an ordinary mesh's "
              f"(bound x{bound:g}; x{growth:.0f} for 10x n); degenerate hits "
              f"{sum(v['degenerate_hits'] for v in ray_hits.values())}, image diffs {img_diff}, NaN "
              f"{sum(v['nan'] for v in ray_hits.values()) + nonfinite}")
    details = {"ray_hits": ray_hits, "image_differences": img_diff, "nonfinite_samples": nonfinite,
               "emitters_with_degenerate": int(core.emitter_count), "split_vertex_escapes": split_escapes,
               "build_seconds": {"same_box": {str(coincident // 10): t_tenth, str(coincident): t_big},
                                 "ordinary": {str(coincident // 10): t_ordinary_tenth, str(coincident): t_ordinary}},
               "build_ratio_to_ordinary": ratio, "build_ratio_bound": bound, "growth_10x": growth,
               "growth_10x_ordinary": growth_ordinary, "growth_10x_n_log_n": expected,
               "bvh_depth": int(core_big.bvh_depth), "bvh_nodes": int(core_big.bvh_nodes),
               "coincident_brute_force_mismatch": coincident_mismatch}
    return _record("degenerate_input", figure, passed, details, t0)


# --------------------------------------------------------------------------- statistics

def image_ztest(mean_a, var_a, n_a, mean_b, var_b=None, n_b=None, *, alpha: float = 1e-4,
                pixel_alpha: float = 1e-3, local: bool = True, rel_floor: float = 1e-6) -> dict:
    """Do two images (or an image and an exact one) have the same expectation?

    Per pixel and channel z = (a - b) / sqrt(var_a / n_a + var_b / n_b), with the
    per-sample variances of both renders (independent seeds). Two tests, each at half
    of ``alpha``:

    * global, per channel: Z_c = sum(a - b) / sqrt(sum(var_a / n_a + var_b / n_b)) over
      all pixels (pixels are independent; a sum over thousands is normal to a good
      approximation); reject when max |Z_c| exceeds the two-sided (alpha / 2) / channels
      quantile. Catches a small bias spread over the image (acne, leaks).
    * local: the count of |z| > z(pixel_alpha) must not exceed the binomial
      (N, pixel_alpha) quantile at alpha / 2. Catches a few badly wrong pixels.

    The nominal false-positive rate is ``alpha`` (normal approximation to per-pixel
    means; channels of a pixel are correlated, which widens the count's spread a little).
    With ``local=False`` only the global test runs (for heavy-tailed estimators whose
    per-pixel means at low spp are far from normal). The variance of each difference has
    a floor of (rel_floor * max(|a|, |b|))^2: float32 images round at ~6e-8 relative, so
    two estimators that are exact per sample compare equal. A pixel where that is still
    0 counts as |z| = inf unless the means are equal.

    Returns
    -------
    dict
        ``passed``, ``z_global`` (per channel), ``z_global_limit``, ``outliers``,
        ``outlier_limit``, ``tests``, ``alpha``.
    """
    a = np.asarray(mean_a, dtype=np.float64)
    b = np.asarray(mean_b, dtype=np.float64)
    s2 = np.asarray(var_a, dtype=np.float64) / n_a
    if var_b is not None:
        s2 = s2 + np.asarray(var_b, dtype=np.float64) / n_b
    s2 = s2 + (rel_floor * np.maximum(np.abs(a), np.abs(b))) ** 2
    d = a - b
    a3 = d.reshape(-1, d.shape[-1]) if d.ndim == 3 else d.reshape(-1, 1)
    v3 = s2.reshape(a3.shape)
    channels = a3.shape[1]
    with np.errstate(divide="ignore", invalid="ignore"):
        sd = np.sqrt(v3.sum(axis=0))
        zg = np.where(sd > 0, a3.sum(axis=0) / sd, np.where(a3.sum(axis=0) == 0, 0.0, np.inf))
        z = np.where(v3 > 0, a3 / np.sqrt(v3), np.where(a3 == 0, 0.0, np.inf))
    zg_limit = float(stats.norm.isf(alpha / 2 / channels / 2))
    z_pix = float(stats.norm.isf(pixel_alpha / 2))
    n = a3.size
    outliers = int((np.abs(z) > z_pix).sum())
    limit = int(stats.binom.isf(alpha / 2, n, pixel_alpha))
    passed = bool(np.all(np.abs(zg) <= zg_limit) and (outliers <= limit or not local))
    return {"passed": passed, "local": local, "z_global": [float(x) for x in zg], "z_global_limit": zg_limit,
            "outliers": outliers, "outlier_limit": limit, "pixel_z": z_pix, "tests": int(n), "alpha": alpha,
            "max_abs_z": float(np.max(np.abs(z))) if n else 0.0}


def constant_ztest(result: rt.RenderResult, value: float, *, alpha: float = 1e-4, local: bool = True) -> dict:
    """:func:`image_ztest` of a render against an exact constant image ``value``."""
    return image_ztest(result.mean, result.variance, result.spp, np.full(result.mean.shape, value),
                       alpha=alpha, local=local)


# --------------------------------------------------------------------------- scale

def transform_scene(scene: rt.Scene, *, scale: float = 1.0, offset=(0.0, 0.0, 0.0)) -> rt.Scene:
    """The same scene scaled uniformly about the origin, then translated (camera too)."""
    off = np.asarray(offset, dtype=np.float64)
    c = scene.camera
    cam = rt.Camera(lookfrom=tuple(np.asarray(c.lookfrom) * scale + off),
                    lookat=tuple(np.asarray(c.lookat) * scale + off), vup=c.vup, vfov=c.vfov,
                    width=c.width, height=c.height)
    shapes = [s.scale(scale).translate(tuple(off)) for s in scene.shapes]
    return rt.Scene(camera=cam, shapes=shapes, max_depth=scene.max_depth, rr_depth=scene.rr_depth,
                    background=scene.background)


def white_furnace_scene(*, width: int = 24, height: int | None = None, max_depth: int = 50) -> rt.Scene:
    """An albedo-1 Lambertian unit sphere in a constant background of radiance 1."""
    cam = rt.Camera(lookfrom=(0, 0, -4.0), lookat=(0, 0, 0), vup=(0, 1, 0), vfov=35.0,
                    width=width, height=height or width)
    return rt.Scene(camera=cam, shapes=[rt.Sphere((0, 0, 0), 1.0, rt.Lambertian(1.0))],
                    background=1.0, max_depth=max_depth)


def creased_furnace_scene(*, width: int = 24, height: int | None = None) -> rt.Scene:
    """A white furnace with creases: a sphere resting on a box, an icosphere mesh beside it
    touching the box too, all albedo 1, background 1, unlimited depth.

    With ``cosine`` sampling every path carries weight exactly 1 and ends in the
    background, so every sample is exactly 1: a path that re-hits its own surface from
    behind (acne) or slips through a mesh edge sees a black back face and lowers its
    pixel. Radiance does not change with scale, so this holds at every scale.
    """
    white = rt.Lambertian(1.0)
    V, F, _ = icosphere(3, radius=0.6)
    shapes = [rt.Box((-2.5, -1.0, -2.0), (2.5, 0.0, 2.0), white),
              rt.Sphere((0.0, 1.0, 0.0), 1.0, white),
              rt.Mesh(V + [1.45, 0.6, -0.7], F, white)]
    cam = rt.Camera(lookfrom=(0.4, 2.2, -5.0), lookat=(0.3, 0.4, 0.0), vup=(0, 1, 0), vfov=40.0,
                    width=width, height=height or width)
    return rt.Scene(camera=cam, shapes=shapes, background=1.0, max_depth=-1)


SCALES = (("scale 1e-4", 1e-4, (0.0, 0.0, 0.0)), ("scale 1e4", 1e4, (0.0, 0.0, 0.0)),
          ("translated 1e5", 1.0, (1e5, -1e5, 1e5)))


def scale_invariance(*, width: int = 32, spp: int = 64, strategies=("mis",), furnace_width: int = 24,
                     furnace_spp: int = 8, seed: int = 0) -> StressRecord:
    """The same scene at scale 1e-4, 1 and 1e4, and translated 1e5 away, renders the same.

    * The Cornell box at each scale is compared with a scale-1 render of another seed
      by :func:`image_ztest` (false-positive rate 1e-4 per comparison, every comparison
      with its own reference seed, so they are independent); scale 1 against scale 1 is
      the null comparison (it must pass too).
    * :func:`creased_furnace_scene` at each scale with ``cosine``: every pixel exactly 1.

    The core re-projects hit points onto their primitive and offsets ray origins by 64
    ulps of max |p|: relative to the hit point's magnitude, so the offset follows the
    scene's scale and its distance from the origin.

    Reported beside the verdict: the creased furnace (4 units across) at 1e5 from the
    origin with its size scaled so size / distance is 1e-6 .. 1e-11 - the smallest ratio
    that stays exact. (An earlier offset of 1e-9 (1 + max |p|) closed the creases up near
    1e-8; float64 hit points within a few ulps of the surface allow far smaller ratios.)
    """
    from mitsuba_scenes import get_scene

    t0 = time.perf_counter()
    base_scene = get_scene("cornell_box", width=width, height=width)
    comparisons, nonfinite = {}, 0
    passed = True
    for si, strategy in enumerate(strategies):
        s0 = seed * 1000 + 100 * si
        variants = [("scale 1 (null)", 1.0, (0.0, 0.0, 0.0))] + list(SCALES)
        for k, (label, scale, off) in enumerate(variants):
            # A fresh scale-1 reference per comparison keeps the comparisons independent.
            ref = rt.render(base_scene, spp=spp, strategy=strategy, seed=s0 + 2 * k + 1, threads=2)
            res = rt.render(transform_scene(base_scene, scale=scale, offset=off), spp=spp, strategy=strategy,
                            seed=s0 + 2 * k + 2, threads=2)
            nonfinite += ref.nonfinite_samples + res.nonfinite_samples
            zt = image_ztest(res.mean, res.variance, spp, ref.mean, ref.variance, spp)
            zt["mean_ratio"] = float(res.mean.mean() / ref.mean.mean())
            comparisons[f"{strategy}: {label}"] = zt
            passed &= zt["passed"]
    furnace = creased_furnace_scene(width=furnace_width)
    furnace_bad = {}
    for label, scale, off in [("scale 1", 1.0, (0.0, 0.0, 0.0))] + list(SCALES):
        res = rt.render(transform_scene(furnace, scale=scale, offset=off), spp=furnace_spp, strategy="cosine",
                        seed=seed, threads=2)
        nonfinite += res.nonfinite_samples
        furnace_bad[label] = {"pixels_not_1": int((res.mean != 1.0).sum()),
                              "min": float(res.mean.min()), "max": float(res.mean.max())}
        passed &= furnace_bad[label]["pixels_not_1"] == 0
    # Beyond the cases (reported, not part of the verdict): how small may a scene be
    # relative to its distance from the origin? Float64 hit points are good to ~1e-15 |p|.
    limit = {}
    for ratio in (1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11):
        res = rt.render(transform_scene(furnace, scale=ratio * 1e5, offset=(1e5, 0.0, 0.0)), spp=4,
                        strategy="cosine", seed=seed, threads=2)
        limit[ratio] = int((res.mean != 1.0).sum())
    exact_down_to = min([r for r in limit if all(limit[q] == 0 for q in limit if q >= r)], default=None)
    passed &= nonfinite == 0
    worst = max(max(abs(z) for z in c["z_global"]) for c in comparisons.values())
    outl = max(c["outliers"] for c in comparisons.values())
    lim = min(c["outlier_limit"] for c in comparisons.values())
    figure = (f"Cornell box vs scale 1: max |Z_global| {worst:.2f} (limit "
              f"{next(iter(comparisons.values()))['z_global_limit']:.2f}), outlier pixels <= {outl} "
              f"(limit {lim}); creased furnace pixels != 1: "
              f"{sum(v['pixels_not_1'] for v in furnace_bad.values())} [not in verdict: exact down to "
              f"size/distance {exact_down_to:g}, pixels off at " +
              ", ".join(f"{r:g}: {n}" for r, n in limit.items()) + "]")
    details = {"comparisons": comparisons, "creased_furnace": furnace_bad, "nonfinite_samples": nonfinite,
               "size_over_distance_pixels_off": {str(r): n for r, n in limit.items()},
               "exact_down_to_size_over_distance": exact_down_to,
               "spp": spp, "width": width}
    return _record("scale_invariance", figure, passed, details, t0)


# --------------------------------------------------------------------------- light sampling

def triangle_solid_angle(ref, a, b, c) -> np.ndarray:
    """Solid angle of triangle(s) ``a, b, c`` seen from ``ref`` (Van Oosterom and Strackee 1983).

    Accepts (3,) or (N, 3) references; the triangle vertices are (3,).
    """
    r = np.atleast_2d(np.asarray(ref, dtype=np.float64))
    A, B, C = (np.asarray(x, dtype=np.float64) - r for x in (a, b, c))
    la, lb, lc = (np.linalg.norm(x, axis=1) for x in (A, B, C))
    num = np.abs(np.einsum("ij,ij->i", A, np.cross(B, C)))
    den = la * lb * lc + np.einsum("ij,ij->i", A, B) * lc + np.einsum("ij,ij->i", A, C) * lb \
        + np.einsum("ij,ij->i", B, C) * la
    return 2.0 * np.arctan2(num, den)


def quad_solid_angle(ref, Q, u, v) -> np.ndarray:
    """Solid angle of the parallelogram ``Q + s u + t v`` seen from ``ref``."""
    Q, u, v = (np.asarray(x, dtype=np.float64) for x in (Q, u, v))
    return triangle_solid_angle(ref, Q, Q + u, Q + u + v) + triangle_solid_angle(ref, Q, Q + u + v, Q + v)


def _z_check(samples, exact) -> dict:
    """z of the mean of ``samples`` against ``exact``.

    The standard error has a floor of 1e-12 |exact| (float64 rounding of the samples and
    of the closed form), so an estimator that is constant up to rounding compares exactly.
    """
    x = np.asarray(samples, dtype=np.float64)
    m, sd = float(x.mean()), float(x.std(ddof=1)) if len(x) > 1 else 0.0
    se = sd / math.sqrt(len(x))
    floor = 1e-12 * abs(exact)
    if max(se, floor) > 0:
        z = (m - exact) / max(se, floor)
    else:
        z = 0.0 if m == exact else math.inf
    return {"mean": m, "exact": float(exact), "z": float(z), "n": int(len(x)), "se": se}


def light_sampling(*, samples: int = 100_000, seed: int = 0, width: int = 24, spp: int = 64) -> StressRecord:
    """Light sampling where pdfs degenerate: finite everywhere, estimates unbiased.

    For each reference point, ``samples`` light samples give E[valid / pdf], which is the
    solid angle of the emitter's front side seen from the point: compared (|z| <= 5)
    with the closed form (Van Oosterom-Strackee for the quad; 2 pi (1 - cos theta_max)
    outside a sphere; 4 pi inside an inward-facing sphere; 0 behind a one-sided light,
    on its plane or inside an outward-facing sphere). Each pdf of a valid sample must be
    finite and positive; ``light_pdf`` (the mixture's density) in uniformly random
    directions must be finite and integrate to the probability of a valid sample.

    Then a camera and a floor inside an inward-facing sphere light (every shading point
    inside a sphere light), a small sphere light cut by the floor, a quad light lying in
    the floor's plane (seen exactly edge-on) and one above are rendered with every
    strategy: zero NaN/Inf samples, and each strategy agrees with ``cosine`` (which uses
    no light pdf) by :func:`image_ztest`; all light here is direct, so ``light`` is
    unbiased too.
    """
    t0 = time.perf_counter()
    rng = np.random.default_rng(seed)
    Q, U, V = np.array([-0.5, 1.0, -0.5]), np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0])
    quad = rt.Quad(Q, U, V, rt.DiffuseLight(1.0))                 # normal -y: emits downward
    normal = np.array([0.0, -1.0, 0.0])
    r_s = 0.5
    cases = {}

    def closed_quad(ref):
        if (ref - Q) @ normal <= 0:   # on the plane or behind: nothing of the front is seen
            return 0.0
        return float(quad_solid_angle(ref, Q, U, V)[0])

    refs_quad = {
        "quad: below (front)": np.array([0.2, 0.3, 0.1]),
        "quad: grazing, 1e-9 below the plane, beside": np.array([1.5, 1.0 - 1e-9, 0.2]),
        "quad: grazing, 1e-6 below the plane, beside": np.array([-1.2, 1.0 - 1e-6, -0.9]),
        "quad: on the light": np.array([0.1, 1.0, 0.2]),
        "quad: on its corner": Q.copy(),
        "quad: on its plane, outside": np.array([2.0, 1.0, 0.3]),
        "quad: behind": np.array([0.1, 1.5, 0.0]),
    }
    sphere_out = rt.Sphere((0, 0, 0), r_s, rt.DiffuseLight(1.0))
    sphere_in = rt.Sphere((0, 0, 0), r_s, rt.DiffuseLight(1.0), flip_normals=True)
    on_surface = r_s * np.array([0.6, 0.0, 0.8])

    def closed_sphere(ref, inward):
        x, y, z = (float(c) for c in ref)
        dc2 = x * x + y * y + z * z   # as the core computes it, to pick the same branch
        if dc2 <= r_s * r_s:   # the core's branch: inside or on the sphere -> area sampling
            return 4 * np.pi if inward else 0.0
        if inward:
            return 0.0
        sin2 = r_s * r_s / dc2
        return 2 * np.pi * sin2 / (1 + math.sqrt(1 - sin2))

    refs_sphere = {
        "sphere: outside": (sphere_out, np.array([0.0, 0.0, -2.0]), False),
        "sphere: grazing, 1e-9 outside": (sphere_out, on_surface * (1 + 1e-9), False),
        "sphere: on the surface": (sphere_out, on_surface, False),
        "sphere: inside, facing out": (sphere_out, np.array([0.1, 0.2, 0.0]), False),
        "sphere: inside, facing in (centre)": (sphere_in, np.array([0.0, 0.0, 0.0]), True),
        "sphere: inside, facing in (0.6 r)": (sphere_in, np.array([0.0, 0.3, 0.0]), True),
    }
    jobs = [(k, quad, ref, closed_quad(ref)) for k, ref in refs_quad.items()]
    jobs += [(k, shp, ref, closed_sphere(ref, inward)) for k, (shp, ref, inward) in refs_sphere.items()]
    bad_pdf, worst_z = 0, 0.0
    for name, shape, ref, exact in jobs:
        core = core_scene(probe_scene([shape]))
        refs = _c(np.repeat(ref[None], samples, axis=0))
        s = core.sample_lights(refs, _c(rng.random((samples, 3))))
        valid = s["valid"].astype(bool)
        pdf = s["pdf"]
        nonfinite = int((~np.isfinite(pdf)).sum() + (~np.isfinite(s["pdf_all"])).sum()
                        + (~np.isfinite(s["wi"])).sum() + (valid & ~(pdf > 0)).sum())
        est = np.where(valid, 1.0 / np.where(valid, pdf, 1.0), 0.0)
        chk = _z_check(est, exact)
        dirs = rng.normal(size=(samples, 3))
        lp = core.light_pdf(refs, _c(dirs))
        nonfinite += int((~np.isfinite(lp)).sum() + (lp < 0).sum())
        # Only where uniform directions hit the light often enough to estimate the mass.
        mass = _z_check(4 * np.pi * lp, float(valid.mean())) if exact * samples >= 400 * np.pi \
            or (exact == 0 and not valid.any()) else None
        # pdf of the procedure equals pdf_all for one emitter (valid samples)
        mismatch = int((valid & ~np.isclose(pdf, s["pdf_all"], rtol=1e-6, atol=0)).sum())
        chk.update(valid_fraction=float(valid.mean()), nonfinite=nonfinite, pdf_mass=mass,
                   pdf_all_mismatch=mismatch)
        cases[name] = chk
        bad_pdf += nonfinite + mismatch
        worst_z = max(worst_z, abs(chk["z"]), abs(mass["z"]) if mass else 0.0)
    # --- renders: the camera and a floor inside an inward-facing sphere light (a dome), a
    # small outward sphere light cut by the floor, a quad light lying in the floor's plane
    # (every floor point sees it exactly edge-on) and a quad light above.
    floor = rt.Quad((-2, 0, -2), (0, 0, 4), (4, 0, 0), rt.Lambertian(0.6))
    shapes = [floor, rt.Sphere((0, 0, 0), 3.0, rt.DiffuseLight(0.5), flip_normals=True),
              rt.Sphere((0.4, 0.0, 0.6), 0.6, rt.DiffuseLight(3.0)),
              rt.Quad((-1.8, 0.0, -1.5), (0, 0, 1), (1, 0, 0), rt.DiffuseLight(5.0)),       # faces up, in-plane
              rt.Quad((-1.5, 2.0, 0.5), (1, 0, 0), (0, 0, 0.5), rt.DiffuseLight(2.0))]      # faces down
    cam = rt.Camera(lookfrom=(0.0, 1.8, -2.0), lookat=(0.0, 0.0, 0.3), vup=(0, 1, 0), vfov=70.0,
                    width=width, height=width)
    scene = rt.Scene(camera=cam, shapes=shapes, max_depth=3)
    renders = {s: rt.render(scene, spp=spp, strategy=s, seed=seed + 11 + i, threads=2)
               for i, s in enumerate(rt.STRATEGIES)}
    ref = renders["cosine"]
    agree = {s: image_ztest(r.mean, r.variance, spp, ref.mean, ref.variance, spp)
             for s, r in renders.items() if s != "cosine"}
    render_nonfinite = sum(r.nonfinite_samples for r in renders.values())
    passed = bad_pdf == 0 and worst_z <= 5.0 and render_nonfinite == 0 and all(a["passed"] for a in agree.values())
    figure = (f"{len(jobs)} reference points: max |z| {worst_z:.2f} (limit 5), Inf/NaN/mismatched pdfs {bad_pdf}; "
              f"floor-through-light renders agree with cosine: "
              f"{sum(a['passed'] for a in agree.values())}/{len(agree)}, NaN samples {render_nonfinite}")
    details = {"points": cases, "render_agreement": agree, "render_nonfinite": render_nonfinite,
               "samples": samples}
    return _record("light_sampling", figure, passed, details, t0)


# --------------------------------------------------------------------------- glass

def fresnel_dielectric(cos_i, eta):
    """Unpolarised Fresnel reflectance for |cos_i| on the side given by its sign (numpy)."""
    cos_i = np.asarray(cos_i, dtype=np.float64)
    eta_it = np.where(cos_i >= 0, eta, 1.0 / eta)
    ci = np.abs(cos_i)
    ct2 = 1.0 - (1.0 - ci * ci) / (eta_it * eta_it)
    ct = np.sqrt(np.maximum(ct2, 0.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        rs = (ci - eta_it * ct) / (ci + eta_it * ct)
        rp = (eta_it * ci - ct) / (eta_it * ci + ct)
    return np.where(ct2 <= 0, 1.0, 0.5 * (rs * rs + rp * rp))


def camera_rays(camera: rt.Camera, px, py) -> np.ndarray:
    """Unit directions of the camera's rays through film points (px, py) in pixels (as the core)."""
    fwd, right, up = camera.basis()
    hh = math.tan(0.5 * math.radians(camera.vfov))
    hw = hh * camera.width / camera.height
    sx = (2.0 * np.asarray(px) / camera.width - 1.0) * hw
    sy = (1.0 - 2.0 * np.asarray(py) / camera.height) * hh
    d = fwd + sx[..., None] * right + sy[..., None] * up
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def glass(*, width: int = 32, spp: int = 32, ior: float = 1.5, seed: int = 0, compare_spp: int = 128,
          compare_width: int = 24) -> StressRecord:
    """Glass: rays starting inside, total internal reflection, ior 1.0 equals no glass.

    * Camera at the centre of a glass sphere (radius 1, ``ior``) in a background of 1:
      every ray leaves at normal incidence; reflected rays come back at normal incidence,
      so every sample is exactly ``ior^2`` (radiance scaled by 1/eta^2 on leaving, as
      Mitsuba), unless ``max_depth`` ends a path (probability F^(max_depth - 1) ~ 1e-68).
    * Camera inside the sphere at 0.8 of its radius: a ray's incidence angle is the same
      at every bounce (sin = |o x d| / R), so rays beyond the critical angle are trapped
      for ever (total internal reflection: exactly 0) and the others leave with
      probability 1 - F^(max_depth - 1): pixels whose whole footprint is beyond the
      critical angle must be exactly 0, pixels whose footprint has F^(max_depth-1) < 1e-12
      exactly ``ior^2``. The footprint is checked on a 17 x 17 grid with a margin.
    * A diffuse sphere inside an ior-1.0 glass sphere on a floor, lit by a quad light and
      the background, against the same scene without the glass (``image_ztest``,
      ``cosine`` and ``mis``).
    """
    t0 = time.perf_counter()
    g = rt.Dielectric(ior)
    expected = ior * ior
    nonfinite = 0
    # --- camera at the centre
    cam = rt.Camera(lookfrom=(0, 0, 0), lookat=(0.3, 0.2, 1.0), vup=(0, 1, 0), vfov=100.0, width=width, height=width)
    centre = rt.render(rt.Scene(camera=cam, shapes=[rt.Sphere((0, 0, 0), 1.0, g)], background=1.0),
                       spp=spp, strategy="mis", seed=seed, threads=2)
    nonfinite += centre.nonfinite_samples
    centre_bad = int((centre.mean != np.float32(expected)).sum())
    # --- off-centre camera: TIR
    rho = 0.8
    max_depth = 50
    cam2 = rt.Camera(lookfrom=(rho, 0, 0), lookat=(rho, 0, 1), vup=(0, 1, 0), vfov=100.0, width=width, height=width)
    tir = rt.render(rt.Scene(camera=cam2, shapes=[rt.Sphere((0, 0, 0), 1.0, g)], background=1.0,
                             max_depth=max_depth), spp=spp, strategy="mis", seed=seed + 1, threads=2)
    nonfinite += tir.nonfinite_samples
    grid = np.linspace(0.0, 1.0, 17)
    ys, xs = np.meshgrid(np.arange(width), np.arange(width), indexing="ij")
    px = xs[..., None, None] + grid[None, None, None, :]
    py = ys[..., None, None] + grid[None, None, :, None]
    px, py = np.broadcast_arrays(px, py)
    d = camera_rays(cam2, px, py)
    o = np.array([rho, 0.0, 0.0])
    sin_inc = np.linalg.norm(np.cross(o, d), axis=-1)        # R = 1
    smin, smax = sin_inc.min(axis=(-1, -2)), sin_inc.max(axis=(-1, -2))
    margin = 1e-3
    critical = 1.0 / ior
    all_tir = smin > critical + margin
    cos_max = np.sqrt(1 - np.minimum(smax + margin, 1.0) ** 2)
    all_exit = (smax + margin < critical) & (fresnel_dielectric(-cos_max, ior) ** (max_depth - 1) < 1e-12)
    lum = tir.mean.max(axis=-1)
    tir_bad = int((lum[all_tir] != 0.0).sum())
    exit_bad = int((tir.mean[all_exit] != np.float32(expected)).sum())
    # --- ior 1.0 against no glass
    floor = rt.Quad((-4, -1.02, -4), (0, 0, 8), (8, 0, 0), rt.Lambertian(0.5))
    lamp = rt.Quad((-1, 2.5, -1), (2, 0, 0), (0, 0, 2), rt.DiffuseLight(6.0))
    inner = rt.Sphere((0.1, -0.4, 0.0), 0.55, rt.Lambertian((0.7, 0.4, 0.2)))
    shell = rt.Sphere((0.0, -0.05, 0.0), 0.95, rt.Dielectric(1.0))
    cam3 = rt.Camera(lookfrom=(0.5, 1.0, -4.0), lookat=(0.0, -0.3, 0.0), vup=(0, 1, 0), vfov=40.0,
                     width=compare_width, height=compare_width)
    with_glass = rt.Scene(camera=cam3, shapes=[floor, lamp, inner, shell], background=0.3)
    without = rt.Scene(camera=cam3, shapes=[floor, lamp, inner], background=0.3)
    ior1 = {}
    for i, strategy in enumerate(("cosine", "mis")):
        a = rt.render(with_glass, spp=compare_spp, strategy=strategy, seed=seed + 20 + 2 * i, threads=2)
        b = rt.render(without, spp=compare_spp, strategy=strategy, seed=seed + 21 + 2 * i, threads=2)
        nonfinite += a.nonfinite_samples + b.nonfinite_samples
        ior1[strategy] = image_ztest(a.mean, a.variance, compare_spp, b.mean, b.variance, compare_spp)
    passed = (centre_bad == 0 and tir_bad == 0 and exit_bad == 0 and int(all_tir.sum()) > 0
              and int(all_exit.sum()) > 0 and nonfinite == 0 and all(z["passed"] for z in ior1.values()))
    figure = (f"inside at centre: {centre_bad} px != {expected:g}; TIR px != 0: {tir_bad}/{int(all_tir.sum())}, "
              f"exiting px != {expected:g}: {exit_bad}/{int(all_exit.sum())}; ior 1 vs none: max |Z| "
              f"{max(max(abs(x) for x in z['z_global']) for z in ior1.values()):.2f}")
    details = {"centre_pixels_wrong": centre_bad, "tir_pixels": int(all_tir.sum()), "tir_pixels_wrong": tir_bad,
               "exit_pixels": int(all_exit.sum()), "exit_pixels_wrong": exit_bad, "ior1_vs_none": ior1,
               "nonfinite_samples": nonfinite, "expected_inside": expected}
    return _record("glass", figure, passed, details, t0)


# --------------------------------------------------------------------------- white furnace

def white_furnace(*, width: int = 24, spp: int = 64, seed: int = 0) -> StressRecord:
    """White furnaces: energy is neither gained nor lost, for every strategy.

    * An albedo-1 Lambertian sphere in a constant background of radiance 1: the exact
      image is 1. With ``cosine`` (the BSDF's own sampling) every bounce weighs albedo = 1
      and the path ends in the background, so every *sample* is exactly 1: pixel means
      must be exactly 1 with zero variance. ``uniform`` (weight 2 cos), ``light`` (the
      background sampled over the whole sphere: weight 4 cos above the surface, 0 below),
      ``mixture`` and ``mis`` are exact only in expectation: :func:`constant_ztest`.
    * :func:`creased_furnace_scene` (a sphere resting on a box, a mesh beside it): again
      ``cosine`` exactly 1 per sample; ``mis`` in expectation; ``uniform`` and
      ``mixture`` in expectation by the global test only: their per-bounce weights reach
      2 (2 cos; f / mixture pdf), so a path caught in the crease carries up to 2^k -
      unbiased, but per-pixel means at a few dozen spp are far from normal. ``light``
      misses interreflection on purpose and is not tested there.
    * The suite's ``furnace`` (inside an emitting, reflecting sphere: Le (1 - rho^n) /
      (1 - rho)): inside a sphere the light-sampling weight f cos / pdf equals rho for
      every sample point, so ``cosine``, ``light``, ``mixture`` and ``mis`` are exact
      per sample (``light`` at its own closed form Le (1 + rho), the direct part only);
      ``uniform`` in expectation (global test; weight 2 cos over up to n bounces).
    """
    from mitsuba_scenes import get_scene, list_scenes

    t0 = time.perf_counter()
    plan = [("sphere", white_furnace_scene(width=width), {"cosine": ("exact", 1.0), "uniform": ("expect", 1.0),
             "light": ("expect", 1.0), "mixture": ("expect", 1.0), "mis": ("expect", 1.0)}),
            ("creased", creased_furnace_scene(width=width), {"cosine": ("exact", 1.0), "mis": ("expect", 1.0),
             "uniform": ("global", 1.0), "mixture": ("global", 1.0)})]
    if "furnace" in list_scenes():
        from mitsuba_scenes.scenes.furnace import ALBEDO, RADIANCE, expected_radiance

        scene = get_scene("furnace", width=width, height=width)
        exact = expected_radiance(max_depth=scene.max_depth)
        direct = expected_radiance(max_depth=min(2, scene.max_depth))   # Le (1 + rho)
        assert abs(direct - RADIANCE * (1 + ALBEDO)) < 1e-12 or scene.max_depth < 2
        plan.append(("suite furnace", scene, {"cosine": ("exact", exact), "light": ("exact", direct),
                     "mixture": ("exact", exact), "mis": ("exact", exact), "uniform": ("global", exact)}))
    out, nonfinite, passed = {}, 0, True
    for name, scene, tests in plan:
        for i, (strategy, (mode, value)) in enumerate(tests.items()):
            r = rt.render(scene, spp=spp, strategy=strategy, seed=seed + 7 * i, threads=2)
            nonfinite += r.nonfinite_samples
            entry = {"mode": mode, "exact": value, "mean": float(r.mean.mean()), "min": float(r.mean.min()),
                     "max": float(r.mean.max())}
            if mode == "exact":
                # float32 image of a double sum of identical samples: equal to 1e-6 relative
                rel = np.abs(r.mean.astype(np.float64) / value - 1.0)
                entry["pixels_off"] = int((rel > 1e-6).sum())
                entry["max_rel_error"] = float(rel.max())
                entry["passed"] = entry["pixels_off"] == 0
            else:
                zt = constant_ztest(r, value, local=(mode == "expect"))
                entry.update(z_global=zt["z_global"][0], z_limit=zt["z_global_limit"], outliers=zt["outliers"],
                             outlier_limit=zt["outlier_limit"] if mode == "expect" else None, passed=zt["passed"])
            out[f"{name}/{strategy}"] = entry
            passed &= entry["passed"]
    passed &= nonfinite == 0
    exact_off = sum(v["pixels_off"] for v in out.values() if v["mode"] == "exact")
    n_exact = sum(v["mode"] == "exact" for v in out.values())
    zs = {k: v["z_global"] for k, v in out.items() if "z_global" in v}
    worst = max(zs, key=lambda k: abs(zs[k]))
    figure = (f"per-sample-exact renders ({n_exact}) pixels off: {exact_off}; in expectation ({len(zs)}): "
              f"max |Z| {abs(zs[worst]):.2f} ({worst}; limit {out[worst]['z_limit']:.2f}); sphere means "
              + ", ".join(f"{s} {out['sphere/' + s]['mean']:.4f}" for s in rt.STRATEGIES))
    return _record("white_furnace", figure, passed, {"renders": out, "nonfinite_samples": nonfinite}, t0)


# --------------------------------------------------------------------------- fireflies

def small_light_scene(*, width: int = 64, height: int | None = None, max_depth: int = 50) -> rt.Scene:
    """The suite's ``small_light`` scene (its own build when the suite has not got it yet)."""
    from mitsuba_scenes import get_scene, list_scenes

    if "small_light" in list_scenes():
        return get_scene("small_light", width=width, height=height or width, max_depth=max_depth)
    from mitsuba_scenes.scenes.cornell_box import LIGHT_RADIANCE, camera, ceiling_light, room, short_box, tall_box

    shrink = 5
    cx, cz, w, d = 278.0, 279.5, 130.0 / shrink, 105.0 / shrink
    light = ceiling_light(x=(cx - w / 2, cx + w / 2), z=(cz - d / 2, cz + d / 2),
                          radiance=LIGHT_RADIANCE * shrink ** 2)
    return rt.Scene(camera=camera(width, height or width), shapes=[*room(), light, tall_box(), short_box()],
                    max_depth=max_depth)


def firefly_counts(scene: rt.Scene, *, strategies=rt.STRATEGIES, renders: int = 128, factor: float = 100.0,
                   seed: int = 0, threads: int = 2) -> dict:
    """Per-sample luminances from ``renders`` 1-spp renders; count samples above a threshold.

    Pixels that see an emitter directly (a ``max_depth=1`` render at 64 spp is non-zero
    there), and their 8 neighbours, are left out: their samples are the light itself,
    the same for every strategy. The threshold is ``factor`` times the mean sample of
    the ``mis`` renders over the kept pixels.

    Returns
    -------
    dict
        ``threshold``, ``samples`` (per strategy), ``counts``, ``means``, ``max``.
    """
    direct_scene = rt.Scene(camera=scene.camera, shapes=scene.shapes, max_depth=1, background=scene.background)
    direct = rt.render(direct_scene, spp=64, strategy="cosine", seed=seed, threads=threads).mean.max(axis=-1) > 0
    grown = direct.copy()
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            grown |= np.roll(np.roll(direct, dy, axis=0), dx, axis=1)
    keep = ~grown
    values, nonfinite = {}, 0
    for si, strategy in enumerate(strategies):
        v = []
        for k in range(renders):
            r = rt.render(scene, spp=1, strategy=strategy, seed=seed * 100_000 + 1000 * si + k, threads=threads)
            nonfinite += r.nonfinite_samples
            v.append((r.mean.astype(np.float64) @ LUMINANCE)[keep])
        values[strategy] = np.concatenate(v)
    ref = values["mis"].mean() if "mis" in values else np.mean([x.mean() for x in values.values()])
    threshold = factor * ref
    return {"threshold": float(threshold), "factor": factor, "excluded_pixels": int(grown.sum()),
            "samples": {s: int(v.size) for s, v in values.items()},
            "counts": {s: int((v > threshold).sum()) for s, v in values.items()},
            "means": {s: float(v.mean()) for s, v in values.items()},
            "max": {s: float(v.max()) for s, v in values.items()}, "nonfinite_samples": nonfinite}


def fireflies(*, width: int = 64, renders: int = 128, factor: float = 100.0, seed: int = 0) -> StressRecord:
    """Fireflies on ``small_light`` (a light 1/25 the area of the Cornell box's, 25x as bright).

    Counts samples above ``factor`` x the image mean per strategy (:func:`firefly_counts`).
    Passes when ``mis`` has at least two orders of magnitude fewer than ``uniform``:
    ``uniform >= 100 * max(mis, 1)``.
    """
    t0 = time.perf_counter()
    fc = firefly_counts(small_light_scene(width=width), renders=renders, factor=factor, seed=seed)
    c = fc["counts"]
    passed = c["uniform"] >= 100 * max(c["mis"], 1) and fc["nonfinite_samples"] == 0
    n = next(iter(fc["samples"].values()))
    figure = (f"samples > {factor:g}x mean ({fc['threshold']:.2f}) of {n:,}: "
              + ", ".join(f"{s} {c[s]}" for s in fc["counts"]))
    return _record("fireflies", figure, passed, fc, t0)


# --------------------------------------------------------------------------- suite

def suite_nonfinite(*, width: int = 16, spp: int = 4, seed: int = 0) -> StressRecord:
    """Every suite scene under every strategy (and Cramer's tests for meshes): NaN/Inf samples."""
    from mitsuba_scenes import get_scene, list_scenes

    t0 = time.perf_counter()
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
    return _record("suite_nonfinite", figure, total == 0, {"nonfinite": counts, "renders": renders}, t0)


# --------------------------------------------------------------------------- registry

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
    """Run the named cases (all by default) with quick or full settings.

    Parameters
    ----------
    names : sequence of str or None
    quick : bool, keyword-only
    on_record : callable or None, keyword-only
        Called with each :class:`StressRecord` as it completes.

    Returns
    -------
    list of StressRecord
    """
    names = list(CASES) if names is None else list(names)
    unknown = [n for n in names if n not in CASES]
    if unknown:
        raise ValueError(f"unknown stress case(s) {unknown}; known: {', '.join(CASES)}")
    records = []
    for name in names:
        fn, quick_kw, full_kw = CASES[name]
        rec = fn(**(quick_kw if quick else full_kw))
        records.append(rec)
        if on_record is not None:
            on_record(rec)
    return records
