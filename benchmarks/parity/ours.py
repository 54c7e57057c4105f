"""Our side of AOV parity: the shapes' bounding boxes (matched against Mitsuba's shapes).

Our first-hit AOVs themselves are the tracer's: :func:`reference_tracer.probe.first_hit_aovs`
(the core's ``intersect`` on the camera's rays, :func:`reference_tracer.probe.camera_rays`).
"""
from __future__ import annotations

import numpy as np

import reference_tracer as rt

__all__ = ["shape_bounds"]


def _points(shape) -> np.ndarray:
    if isinstance(shape, rt.Sphere):
        c, r = shape.world_center(), shape.world_radius()
        return np.array([c - r, c + r])
    if isinstance(shape, rt.Quad):
        Q, u, v = shape.world_corners()
        return np.array([Q, Q + u, Q + v, Q + u + v])
    if isinstance(shape, rt.Box):
        return np.array([p for Q, u, v in shape.world_quads() for p in (Q, Q + u, Q + v, Q + u + v)])
    if isinstance(shape, rt.Triangle):
        return shape.world_vertices()
    return shape.world_triangles().reshape(-1, 3)


def shape_bounds(scene: rt.Scene) -> np.ndarray:
    """(N, 6) world bounding boxes ``(min, max)`` of the scene's shapes."""
    out = [np.concatenate([p.min(axis=0), p.max(axis=0)]) for p in (_points(s) for s in scene.shapes)]
    return np.array(out, dtype=np.float64).reshape(-1, 6)
