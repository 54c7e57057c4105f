"""Case ``grazing_rays``: rays within 1e-7 rad of a triangle's or quad's plane, and
exactly parallel rays, decided by the core and again in exact rational arithmetic."""
from __future__ import annotations

import numpy as np

import reference_tracer as rt
from reference_tracer.probe import core_scene

from .exact import classify_rays
from .probes import contiguous, probe_scene
from .record import stress_case

__all__ = ["grazing_rays"]


def _grazing_batch(rng, shape, verts, n_grazing, n_parallel):
    """Rays within 1e-7 rad of the plane of ``verts`` aimed around its boundary, plus
    rays exactly parallel to the plane (directions are exact in-plane differences)."""
    if shape == "triangle":
        a, b, c = verts
        P0, e1, e2 = a, b - a, c - a       # exact differences
        parallel_dirs = [e1, e2, c - b]
    else:
        P0, e1, e2 = verts
        parallel_dirs = [e1, e2, e1 - e2]     # u - v = P1 - P2 exactly
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
    corners = np.array(verts) if shape == "triangle" else np.array([P0, P0 + e1, P0 + e2])
    po[inplane] = corners[rng.integers(0, 3, inplane.sum())]
    return contiguous(np.vstack([o, po])), contiguous(np.vstack([d, dp]))


@stress_case
def grazing_rays(*, shapes: int = 25, rays_per_shape: int = 80, seed: int = 0):
    """Grazing (|angle to the plane| in [1e-9, 1e-7] rad) and exactly parallel rays.

    Rays aimed around random triangles' and quads' boundaries, decided by the core and
    again exactly (:func:`~.exact.classify_rays`): the two may differ only within the
    forward-error bound of the boundary; a parallel ray misses unless it lies in the plane
    to rounding; every hit has a finite distance.

    Parameters
    ----------
    shapes : int
        Random triangles, and as many quads.
    rays_per_shape : int
        Rays per shape; a fifth of them exactly parallel.
    """
    rng = np.random.default_rng(seed)
    mat = rt.Lambertian(0.5)
    n_par = rays_per_shape // 5
    stats_ = {}
    for shape in ("triangle", "quad"):
        parts = []
        for _ in range(shapes):
            k = int(rng.integers(-20, 21))
            P = rng.uniform(1.0, 2.0, (3, 3)) * 2.0 ** k   # in [1, 2)^3 2^k: differences exact (Sterbenz)
            verts = P if shape == "triangle" else np.array([P[0], P[1] - P[0], P[2] - P[0]])
            shp = rt.Triangle(*P, mat) if shape == "triangle" else rt.Quad(*verts, mat)
            o, d = _grazing_batch(rng, shape, verts, rays_per_shape - n_par, n_par)
            hit = core_scene(probe_scene([shp])).intersect(o, d)
            parts.append(classify_rays(shape, verts, o, d, hit["t"], hit["prim"]))
        cl = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
        off = cl["parallel"] & (cl["plane_distance"] > cl["delta_plane"])
        dis = cl["boundary_disagreement"]
        stats_[shape] = {
            "rays": len(cl["hit"]), "violations": int(cl["violation"].sum()),
            "boundary_disagreements": int(dis.sum()), "nan": int(cl["nan"].sum()),
            "parallel_rays": int(cl["parallel"].sum()), "parallel_off_plane_hits": int((off & cl["hit"]).sum()),
            "in_plane_hits": int((cl["parallel"] & ~off & cl["hit"]).sum()),
            "exact_hits": int(cl["exact_hit"].sum()), "hits": int(cl["hit"].sum()),
            "max_margin_over_delta": float(np.max(np.abs(cl["margin"][dis]) / cl["delta"][dis], initial=0.0)),
            "max_t_rel_error": float(cl["t_rel_error"].max())}
    passed = all(s["violations"] == 0 and s["nan"] == 0 for s in stats_.values())
    tri, quad = stats_["triangle"], stats_["quad"]
    figure = (f"inconsistent with exact: triangle {tri['violations']}/{tri['rays']}, quad "
              f"{quad['violations']}/{quad['rays']} (within error bound: {tri['boundary_disagreements']}, "
              f"{quad['boundary_disagreements']}); NaN {tri['nan'] + quad['nan']}")
    return figure, passed, stats_
