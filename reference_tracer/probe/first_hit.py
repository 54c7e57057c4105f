"""First-hit AOVs of the camera's rays (what AOV parity compares with Mitsuba's): hit distance,
shading normal, diffuse albedo, emitted radiance and shape index of every pixel, and the maps they
need (each primitive's shape, each material's diffuse albedo).
"""
from __future__ import annotations

import numpy as np

from ..material_textures import reflectance_of
from ..materials import DiffuseLight, Lambertian
from ..plastics import Plastic, RoughPlastic
from ..render import core_scene
from ..scene import Scene
from ..shapes import Box, Quad, Sphere, Triangle
from ..textures import Texture
from .camera import camera_rays_with_reach

__all__ = ["primitive_shapes", "diffuse_albedo", "first_hit_aovs"]


def primitive_shapes(scene: Scene) -> np.ndarray:
    """The shape index of each primitive of the compiled scene (what ``intersect``'s ``prim`` counts).

    The core holds spheres, then quads (six per box), then triangles (one per triangle,
    every triangle of a mesh), each block in shape order.

    Parameters
    ----------
    scene : Scene

    Returns
    -------
    ndarray of int64, shape (primitive_count,)

    Examples
    --------
    >>> import reference_tracer as rt
    >>> m = rt.Lambertian(0.5)
    >>> cam = rt.Camera(lookfrom=(0, 0, -3), lookat=(0, 0, 0), width=4, height=4)
    >>> scene = rt.Scene(camera=cam, shapes=[rt.Box((0, 0, 0), (1, 1, 1), m), rt.Sphere((0, 0, 0), 1, m)])
    >>> primitive_shapes(scene).tolist()
    [1, 0, 0, 0, 0, 0, 0]
    """
    spheres, quads, tris = [], [], []
    for i, s in enumerate(scene.shapes):
        if isinstance(s, Sphere):
            spheres.append(i)
        elif isinstance(s, Quad):
            quads.append(i)
        elif isinstance(s, Box):
            quads.extend([i] * 6)
        elif isinstance(s, Triangle):
            tris.append(i)
        else:
            tris.extend([i] * len(s.world_triangles()))
    return np.array(spheres + quads + tris, dtype=np.int64)


def diffuse_albedo(material):
    """The diffuse albedo a first-hit AOV shows for ``material``.

    A Lambertian's albedo, an emitter's own (when it reflects), a plastic's diffuse
    reflectance (Mitsuba's ``eval_diffuse_reflectance`` of its diffuse lobe), else black.
    Where that albedo is a texture, the texture itself (:func:`first_hit_aovs` shows its
    value at each hit, which the core computes).

    Examples
    --------
    >>> import reference_tracer as rt
    >>> diffuse_albedo(rt.Lambertian(0.5)), diffuse_albedo(rt.Metal(0.9))
    ((0.5, 0.5, 0.5), (0.0, 0.0, 0.0))
    """
    if isinstance(material, (Lambertian, Plastic, RoughPlastic, DiffuseLight)):
        value = reflectance_of(material)
        if value is not None:
            return value if isinstance(value, Texture) else tuple(value)
    return (0.0, 0.0, 0.0)


def first_hit_aovs(scene: Scene, *, offset=(0.5, 0.5)) -> dict:
    """First-hit AOVs of the camera's ray through ``pixel + offset`` of every pixel.

    Parameters
    ----------
    scene : Scene
    offset : tuple of float, optional
        Where in each pixel the ray passes (default: the centre).

    Returns
    -------
    dict
        ``t`` (H, W) hit distance (inf on a miss), ``normal`` (H, W, 3) unit shading normal
        of the front side (0 on a miss), ``albedo`` (H, W, 3) (:func:`diffuse_albedo`),
        ``emitted`` (H, W, 3) radiance toward the camera (on a miss the environment's in
        the ray's direction: the constant background or an EnvMap),
        ``shape`` (H, W) shape index (-1 on a miss).

    Examples
    --------
    >>> import reference_tracer as rt
    >>> cam = rt.Camera(lookfrom=(0, 0, -3), lookat=(0, 0, 0), width=2, height=2)
    >>> scene = rt.Scene(camera=cam, shapes=[rt.Sphere((0, 0, 0), 1, rt.Lambertian(0.5))])
    >>> aovs = first_hit_aovs(scene, offset=(1.0, 1.0))
    >>> float(aovs["t"][0, 0]), aovs["albedo"][0, 0].tolist()
    (2.0, [0.5, 0.5, 0.5])
    """
    cam = scene.camera
    if cam.is_thin_lens:
        raise ValueError("first_hit_aovs: a thin lens has no single ray per pixel point (its AOVs would be "
                         "averages over the aperture)")
    h, w = cam.height, cam.width
    yy, xx = np.mgrid[0:h, 0:w]
    o, d, reach = camera_rays_with_reach(cam, xx.ravel() + offset[0], yy.ravel() + offset[1])
    core = core_scene(scene)
    hit = core.intersect(o, d, threads=1)
    t = np.asarray(hit["t"], dtype=np.float64)
    t = np.where(t < reach, t, np.inf)  # beyond the far clip plane: a miss, as in the renders
    valid = np.isfinite(t)
    prims = np.asarray(hit["prim"], dtype=np.int64)
    shape = np.full(t.shape, -1, dtype=np.int64)
    shape[valid] = primitive_shapes(scene)[prims[valid]]
    # the shading normal (Mitsuba's AOV is si.sh_frame.n): the interpolated vertex normals
    # on smooth meshes, else the geometric normal; emission's side is the shading normal's
    shading = hit.get("shading_normal", hit["normal"])
    normal = np.where(valid[:, None], np.asarray(shading, dtype=np.float64), 0.0)
    albedo = np.zeros((t.size, 3))
    # on a miss, the environment's radiance in the ray's direction (a constant or an EnvMap)
    emitted = np.asarray(core.background(np.ascontiguousarray(d, dtype=np.float64)), dtype=np.float64)
    front = np.einsum("ij,ij->i", normal, -d) > 0
    for i, s in enumerate(scene.shapes):
        m = shape == i
        if not m.any():
            continue
        value = diffuse_albedo(s.material)
        albedo[m] = np.asarray(hit["reflectance"])[m] if isinstance(value, Texture) else value
        emitted[m] = 0.0
        if isinstance(s.material, DiffuseLight):
            emitted[m & front] = s.material.radiance
    return {"t": t.reshape(h, w), "normal": normal.reshape(h, w, 3), "albedo": albedo.reshape(h, w, 3),
            "emitted": emitted.reshape(h, w, 3), "shape": shape.reshape(h, w)}
