"""Probe scenes and rays shared by the hard cases (and their tests): small scenes, closed
meshes, aimed rays."""
from __future__ import annotations

import dataclasses

import numpy as np

import reference_tracer as rt
from reference_tracer.probe import core_scene

__all__ = ["contiguous", "probe_scene", "icosphere", "edge_and_vertex_rays", "count_escapes", "transform_scene",
           "creased_furnace_scene"]


def contiguous(a) -> np.ndarray:
    """``a`` as a C-contiguous float64 array (what the core's ray queries take)."""
    return np.ascontiguousarray(a, dtype=np.float64)


def probe_scene(shapes, *, width=4, lookfrom=(0.0, 0.0, -10.0), lookat=(0.0, 0.0, 0.0), vfov=60.0,
                **scene) -> rt.Scene:
    """A scene holding ``shapes`` seen by a small square camera, for ray queries and small renders;
    ``scene``: further arguments of ``rt.Scene`` (``background``, ``max_depth``)."""
    cam = rt.Camera(lookfrom=lookfrom, lookat=lookat, vup=(0, 1, 0), vfov=vfov, width=width, height=width)
    return rt.Scene(camera=cam, shapes=list(shapes), **scene)


def icosphere(subdivisions: int, *, radius: float = 1.0):
    """A closed icosphere (trimesh): vertices (N, 3), faces (M, 3), unique edges (E, 2)."""
    import trimesh  # deferred: trimesh takes about 1.5 s to import

    ico = trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius)
    return (np.asarray(ico.vertices, dtype=np.float64), np.asarray(ico.faces, dtype=np.int64),
            np.asarray(ico.edges_unique, dtype=np.int64))


def edge_and_vertex_rays(vertices, edges, origins, rng):
    """Directions ``target - origin`` from ``origins`` aimed exactly at mesh edges and vertices,
    and each ray's kind: 0 a random point of an edge (``a + s (b - a)`` in float64), 1 an
    edge's midpoint, 2 a vertex (a third each)."""
    n = len(origins)
    kind = rng.integers(0, 3, n)
    e = edges[rng.integers(0, len(edges), n)]
    a, b = vertices[e[:, 0]], vertices[e[:, 1]]
    s = np.where(kind == 1, 0.5, rng.uniform(0.0, 1.0, n))[:, None]
    target = np.where((kind == 2)[:, None], vertices[rng.integers(0, len(vertices), n)], a + s * (b - a))
    return contiguous(target - origins), kind


def count_escapes(scene: rt.Scene, origins, directions, *, triangle_test: str) -> dict:
    """Cast rays with ``triangle_test``; count misses (escapes) and non-finite hit distances."""
    core = core_scene(scene, triangle_test=triangle_test)
    hit = core.intersect(contiguous(origins), contiguous(directions))
    t = hit["t"]
    miss = hit["prim"] < 0
    return {"escapes": int(miss.sum()), "nan": int(np.isnan(t).sum()), "escaped": miss,
            "nonfinite_hits": int((~miss & ~np.isfinite(t)).sum())}


def transform_scene(scene: rt.Scene, *, scale: float = 1.0, offset=(0.0, 0.0, 0.0)) -> rt.Scene:
    """The same scene scaled uniformly about the origin, then translated: its shapes and its camera
    (every length of it: position, lens, view size, clip planes; its filter is in pixels).

    Its image is the original's. A point, spot or projector light would not keep it (the
    irradiance it gives falls with the squared distance): ``ValueError``. Directional and
    environment lights, at infinity, stay as they are.
    """
    moving = [type(light).__name__ for light in scene.lights
              if not isinstance(light, (rt.DirectionalLight, rt.EnvMap))]
    if moving:
        raise ValueError(f"transform_scene: a scaled scene with {', '.join(moving)} would not render the same image")
    off = np.asarray(offset, dtype=np.float64)
    c = scene.camera

    def length(v):
        return None if v is None else v * scale

    cam = dataclasses.replace(c, lookfrom=tuple(np.asarray(c.lookfrom) * scale + off),
                              lookat=tuple(np.asarray(c.lookat) * scale + off),
                              aperture_radius=c.aperture_radius * scale, focus_distance=length(c.focus_distance),
                              view_height=length(c.view_height), view_width=length(c.view_width),
                              near_clip=c.near_clip * scale, far_clip=c.far_clip * scale)
    shapes = [s.scale(scale).translate(tuple(off)) for s in scene.shapes]
    return dataclasses.replace(scene, camera=cam, shapes=shapes)


def creased_furnace_scene(*, width: int = 24) -> rt.Scene:
    """A white furnace with creases: a sphere resting on a box, an icosphere mesh beside it
    touching the box too, all albedo 1, background 1, unlimited depth. With ``cosine``
    sampling every sample is exactly 1 (at every scale): a path that re-hits its own
    surface from behind (acne) or slips through a mesh edge lowers its pixel."""
    white = rt.Lambertian(1.0)
    V, F, _ = icosphere(3, radius=0.6)
    shapes = [rt.Box((-2.5, -1.0, -2.0), (2.5, 0.0, 2.0), white),
              rt.Sphere((0.0, 1.0, 0.0), 1.0, white),
              rt.Mesh(V + [1.45, 0.6, -0.7], F, white)]
    return probe_scene(shapes, width=width, lookfrom=(0.4, 2.2, -5.0), lookat=(0.3, 0.4, 0.0), vfov=40.0,
                       background=1.0, max_depth=-1)

