"""cornell_mesh: triangle meshes - a generated torus (flat-shaded, non-convex) in the box.

The Cornell box with the short box replaced by a torus mesh generated here (major
radius 80, minor radius 35, tilted 30 degrees about x and turned about y), white
Lambertian. Tests mesh winding (counter-clockwise is the front face), flat shading of
meshes without vertex normals and self-shadowing of a non-convex mesh.

Examples
--------
>>> from mitsuba_scenes.scenes.cornell_mesh import torus
>>> v, f = torus(major=2.0, minor=0.5, segments=8, rings=4)
>>> v.shape, f.shape
((32, 3), (64, 3))
"""
from __future__ import annotations

import numpy as np

import reference_tracer as rt

from .cornell_box import WHITE, camera, ceiling_light, room, tall_box


def torus(*, major: float, minor: float, segments: int = 32, rings: int = 16):
    """Vertices and counter-clockwise (outward) faces of a torus about the y axis.

    Parameters
    ----------
    major, minor : float, keyword-only
        Radius of the centre circle and of the tube, ``0 < minor < major``.
    segments, rings : int, keyword-only
        Subdivisions around the centre circle and around the tube (>= 3).

    Returns
    -------
    vertices : (segments * rings, 3) float64
    faces : (2 * segments * rings, 3) int64
    """
    if not 0 < minor < major:
        raise ValueError(f"torus needs 0 < minor < major, got minor={minor}, major={major}")
    if segments < 3 or rings < 3:
        raise ValueError(f"torus needs segments >= 3 and rings >= 3, got {segments} and {rings}")
    i, j = np.meshgrid(np.arange(segments), np.arange(rings), indexing="ij")
    u = 2 * np.pi * i / segments          # around y
    v = 2 * np.pi * j / rings             # around the tube
    r = major + minor * np.cos(v)
    verts = np.stack([r * np.cos(u), minor * np.sin(v), -r * np.sin(u)], axis=-1).reshape(-1, 3)
    idx = lambda a, b: (a % segments) * rings + (b % rings)  # noqa: E731
    a, b, c, d = idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1)
    faces = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    return verts, faces


def build(*, width: int = 64, height: int = 64, max_depth: int = 50, rr_depth=5,
          segments: int = 32, rings: int = 16) -> rt.Scene:
    v, f = torus(major=80.0, minor=35.0, segments=segments, rings=rings)
    mesh = rt.Mesh(v, f, rt.Lambertian(WHITE)).rotate_x(30).rotate_y(-20).translate((190, 110, 170))
    return rt.Scene(camera=camera(width, height), shapes=[*room(), ceiling_light(), tall_box(), mesh],
                    max_depth=max_depth, rr_depth=rr_depth)
