"""The oracle of the grazing-ray case: a float64 ray and shape intersected again exactly
(``fractions.Fraction``), and the forward-error bounds within which a float64 decision may
differ from the exact one."""
from __future__ import annotations

import math
from fractions import Fraction

import numpy as np

__all__ = ["exact_intersection", "triangle_error_bound", "quad_error_bound", "classify_rays"]

#: unit roundoff of float64
UNIT_ROUNDOFF = 2.0 ** -53


def _frac3(v) -> np.ndarray:
    return np.array([Fraction(x) for x in v], dtype=object)


def exact_intersection(o, d, p, e1, e2) -> dict:
    """Exact intersection of the float64 ray ``o + t d`` with ``p + s1 e1 + s2 e2``.

    ``p``, ``e1``, ``e2``: float64 or already exact (``Fraction``: a triangle's ``b - a``,
    ``c - a``). Returns ``parallel`` (exact determinant 0), else ``t``, ``s1``, ``s2``
    (``Fraction``), and always ``plane_distance`` (float) from ``o``.

    >>> ex = exact_intersection([0.25, 0.25, 1.0], [0.0, 0.0, -2.0], [0, 0, 0], [1, 0, 0], [0, 1, 0])
    >>> ex["parallel"], ex["t"], ex["s1"], ex["s2"], ex["plane_distance"]
    (False, Fraction(1, 2), Fraction(1, 4), Fraction(1, 4), 1.0)
    """
    o, d, p, e1, e2 = (_frac3(v) for v in (o, d, p, e1, e2))
    s = o - p
    n = np.cross(e1, e2)
    nn = n @ n
    out = {"plane_distance": math.sqrt(float((n @ s) ** 2 / nn)) if nn else math.inf}
    # Cramer's rule for [-d, e1, e2] (t, s1, s2)^T = s, with triple products.
    q = np.cross(d, e2)
    det = e1 @ q
    if det == 0:
        out["parallel"] = True
        return out
    r = np.cross(s, e1)
    out.update(parallel=False, t=(e2 @ r) / det, s1=(s @ q) / det, s2=(d @ r) / det)
    return out


def triangle_error_bound(o, d, a, b, c) -> float:
    """Barycentric forward-error bound of the watertight test (float64) for one ray:
    32 u S^2 / (A |cos|) to first order (S = max |v - o|, A the area, each sheared edge
    function off by ~64 u S^2, det >= 2 A |cos|)."""
    o, d, a, b, c = (np.asarray(x, dtype=np.float64) for x in (o, d, a, b, c))
    S = max(np.abs(a - o).max(), np.abs(b - o).max(), np.abs(c - o).max())
    n = np.cross(b - a, c - a)
    area = 0.5 * np.linalg.norm(n)
    cos = abs(n @ d) / (np.linalg.norm(n) * np.linalg.norm(d))
    return 32.0 * UNIT_ROUNDOFF * S * S / (area * cos) if area > 0 and cos > 0 else math.inf


def quad_error_bound(o, d, Q, u, v, t) -> float:
    """Parallelogram-coordinate forward-error bound of the quad test for one ray:
    32 u (|Q| + |o| + t |d|) / (|cos| h_min) to first order (the hit point's rounding over
    the parallelogram's smaller height)."""
    o, d, Q, u, v = (np.asarray(x, dtype=np.float64) for x in (o, d, Q, u, v))
    n = np.cross(u, v)
    area = np.linalg.norm(n)
    h_min = area / max(np.linalg.norm(u), np.linalg.norm(v))
    cos = abs(n @ d) / (area * np.linalg.norm(d))
    scale = np.linalg.norm(Q) + np.linalg.norm(o) + abs(t) * np.linalg.norm(d)
    return 32.0 * UNIT_ROUNDOFF * scale / (cos * h_min) if cos > 0 else math.inf


def classify_rays(shape: str, verts, origins, directions, hit_t, hit_prim) -> dict:
    """Per-ray comparison of the core's hits (``hit_t``, ``hit_prim``) with exact arithmetic.

    ``verts``: a triangle's ``(a, b, c)`` or a quad's ``(Q, u, v)``. Returns per-ray arrays:
    ``exact_hit``, ``parallel``, ``plane_distance``, ``margin`` (exact signed distance of
    the crossing to the boundary, in shape coordinates), ``delta`` (its error bound),
    ``t_exact``, ``delta_plane``, ``violation``, ``boundary_disagreement``, ``hit``, ``nan``,
    ``t_rel_error``.
    """
    verts = np.asarray(verts, dtype=np.float64)
    if shape == "triangle":
        a, b, c = verts
        p, e1, e2 = _frac3(a), _frac3(b) - _frac3(a), _frac3(c) - _frac3(a)
        size = max(np.linalg.norm(b - a), np.linalg.norm(c - a), np.linalg.norm(c - b))
    else:
        Q, u, v = verts
        p, e1, e2 = Q, u, v
        size = max(np.linalg.norm(u), np.linalg.norm(v))
    n = len(origins)
    out = {k: np.full(n, np.nan) for k in ("margin", "delta", "t_exact", "plane_distance", "delta_plane")}
    out.update(exact_hit=np.zeros(n, dtype=bool), parallel=np.zeros(n, dtype=bool))
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
