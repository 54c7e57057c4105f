"""Distance queries over the surfaces of shapes after their transforms: whether a surface comes
within a radius of a point (:func:`surface_within`) and the farthest point of them all
(:func:`farthest_distance`), for the importer's clip planes and the translation's records.
"""
from __future__ import annotations

import numpy as np

from .mesh import Mesh
from .shapes import Quad, Sphere, Triangle

__all__ = ["surface_within", "farthest_distance"]

#: triangles a distance query holds in memory at once (a mesh file may have millions).
_CHUNK = 1 << 16


def _triangles(shape):
    """The world-space triangles of a shape other than a sphere, as chunks of (K, 3, 3) arrays."""
    if isinstance(shape, Mesh):
        v = shape.world_vertices()
        for start in range(0, len(shape.faces), _CHUNK):
            yield v[shape.faces[start:start + _CHUNK]]
        return
    if isinstance(shape, Triangle):
        yield shape.world_vertices()[None]
        return
    quads = [shape.world_corners()] if isinstance(shape, Quad) else shape.world_quads()
    yield np.array([t for Q, u, v in quads for t in ((Q, Q + u, Q + u + v), (Q, Q + u + v, Q + v))])


def _point_triangle_distances(p: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Distances from point ``p`` to each triangle of ``tri`` (K, 3, 3): to its plane where
    the foot of the perpendicular lies inside it, else to its nearest edge; infinite for a
    triangle of zero area (a mesh may hold some: they are never hit)."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    n = np.cross(b - a, c - a)
    nn = np.einsum("ij,ij->i", n, n)
    area = nn > 0.0
    nn = np.where(area, nn, 1.0)
    offset = np.einsum("ij,ij->i", p - a, n) / nn
    foot = p - offset[:, None] * n
    inside = np.ones(len(tri), dtype=bool)
    edge = np.full(len(tri), np.inf)
    for s, e in ((a, b), (b, c), (c, a)):
        d = e - s
        dd = np.einsum("ij,ij->i", d, d)
        inside &= np.einsum("ij,ij->i", np.cross(d, foot - s), n) >= 0.0
        t = np.clip(np.einsum("ij,ij->i", p - s, d) / np.where(dd > 0.0, dd, 1.0), 0.0, 1.0)
        edge = np.minimum(edge, np.linalg.norm(p - (s + t[:, None] * d), axis=1))
    return np.where(area, np.where(inside, np.abs(offset) * np.sqrt(nn), edge), np.inf)


def surface_within(shapes, point, radius: float) -> bool:
    """Whether a surface of ``shapes`` (after their transforms) has a point within ``radius``
    of ``point``.

    Exact up to rounding: a sphere's surface by its centre and radius, every other shape by
    its triangles (a quad and each face of a box as two), each triangle's distance to the
    point; boxes around a mesh and its triangles skip what lies farther.

    Examples
    --------
    >>> from reference_tracer import Lambertian
    >>> floor = Quad((-1, -1, 0), (2, 0, 0), (0, 2, 0), Lambertian(0.5))
    >>> surface_within([floor], (0.5, 3.0, 0.2), 2.01), surface_within([floor], (0.5, 3.0, 0.2), 1.9)
    (True, False)
    """
    p = np.asarray(point, dtype=np.float64)
    r = float(radius)
    for shape in shapes:
        if isinstance(shape, Sphere):
            if abs(np.linalg.norm(shape.world_center() - p) - shape.world_radius()) <= r:
                return True
            continue
        if isinstance(shape, Mesh):
            v = shape.world_vertices()
            if np.linalg.norm(np.maximum(np.maximum(v.min(axis=0) - p, p - v.max(axis=0)), 0.0)) > r:
                continue
        for tri in _triangles(shape):
            gap = np.maximum(np.maximum(tri.min(axis=1) - p, p - tri.max(axis=1)), 0.0)
            near = tri[np.linalg.norm(gap, axis=1) <= r]
            if len(near) and (_point_triangle_distances(p, near) <= r).any():
                return True
    return False


def farthest_distance(shapes, point) -> float:
    """The largest distance from ``point`` to a point of the surfaces of ``shapes`` (after
    their transforms; 0 for none): a sphere's far side, every other shape's farthest vertex
    (a mesh's unused vertices count too).

    Examples
    --------
    >>> from reference_tracer import Lambertian
    >>> farthest_distance([Sphere((3, 4, 0), 1.0, Lambertian(0.5))], (0, 0, 0))
    6.0
    """
    p = np.asarray(point, dtype=np.float64)
    far = 0.0
    for shape in shapes:
        if isinstance(shape, Sphere):
            far = max(far, float(np.linalg.norm(shape.world_center() - p)) + shape.world_radius())
        elif isinstance(shape, (Mesh, Triangle)):
            far = max(far, float(np.linalg.norm(shape.world_vertices() - p, axis=1).max()))
        else:
            quads = [shape.world_corners()] if isinstance(shape, Quad) else shape.world_quads()
            corners = np.array([c for Q, u, v in quads for c in (Q, Q + u, Q + v, Q + u + v)])
            far = max(far, float(np.linalg.norm(corners - p, axis=1).max()))
    return far
