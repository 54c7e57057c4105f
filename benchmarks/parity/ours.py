"""Our first-hit AOVs at pixel centres: the C++ core's ``intersect`` on the camera's rays."""
from __future__ import annotations

import numpy as np

import reference_tracer as rt

__all__ = ["camera_rays", "our_aovs", "shape_bounds", "prim_shapes", "albedo_of"]


def camera_rays(camera: rt.Camera, px, py) -> tuple:
    """``(origins, directions)`` of our camera through film points ``(px, py)`` in pixels.

    The same formula as ``Camera::generate`` in ``reference_tracer/cpp/scene.h``
    (pixel (0, 0) top left, ``vfov`` vertical); pixel centres are ``x + 0.5``.

    Examples
    --------
    >>> cam = rt.Camera(lookfrom=(0, 0, 1), lookat=(0, 0, 0), vfov=90, width=2, height=2)
    >>> o, d = camera_rays(cam, [1.0], [1.0])
    >>> d.round(6).tolist()
    [[0.0, 0.0, -1.0]]
    """
    eye = np.asarray(camera.lookfrom, dtype=np.float64)
    fwd = np.subtract(camera.lookat, eye)
    fwd = fwd / np.linalg.norm(fwd)
    right = np.cross(fwd, camera.vup)
    right = right / np.linalg.norm(right)
    up = np.cross(right, fwd)
    hh = np.tan(0.5 * np.radians(camera.vfov))
    hw = hh * camera.width / camera.height
    sx = (2.0 * np.asarray(px, dtype=np.float64) / camera.width - 1.0) * hw
    sy = (1.0 - 2.0 * np.asarray(py, dtype=np.float64) / camera.height) * hh
    d = fwd[None, :] + sx[:, None] * right[None, :] + sy[:, None] * up[None, :]
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return np.ascontiguousarray(np.broadcast_to(eye, d.shape)), np.ascontiguousarray(d)


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


def prim_shapes(scene: rt.Scene) -> np.ndarray:
    """Shape index of each core primitive: spheres, then quads (6 per box), then triangles,
    each block in shape order (``reference_tracer._compile.compile_scene``)."""
    spheres, quads, tris = [], [], []
    for i, s in enumerate(scene.shapes):
        if isinstance(s, rt.Sphere):
            spheres.append(i)
        elif isinstance(s, rt.Quad):
            quads.append(i)
        elif isinstance(s, rt.Box):
            quads.extend([i] * 6)
        elif isinstance(s, rt.Triangle):
            tris.append(i)
        else:
            tris.extend([i] * len(s.world_triangles()))
    return np.array(spheres + quads + tris, dtype=np.int64)


def albedo_of(material):
    """The diffuse albedo an AOV shows: a Lambertian's, an emitter's own, a plastic's base
    (Mitsuba's eval_diffuse_reflectance of its diffuse lobe), else black; a texture where
    it is one (its value at each hit: the core's ``reflectance``)."""
    if isinstance(material, rt.Lambertian):
        value = material.albedo
    elif isinstance(material, (rt.Plastic, rt.RoughPlastic)):
        value = material.diffuse_reflectance
    elif isinstance(material, rt.DiffuseLight) and material.albedo is not None:
        value = material.albedo
    else:
        return (0.0, 0.0, 0.0)
    return value if isinstance(value, rt.Texture) else tuple(value)


def our_aovs(scene: rt.Scene, *, offset=(0.5, 0.5)) -> dict:
    """First-hit AOVs of our tracer through ``pixel + offset`` (default: the centres).

    Returns
    -------
    dict
        ``t`` (H, W) hit distance (inf on a miss), ``normal`` (H, W, 3) unit shading normal
        of the front side (0 on a miss), ``albedo`` (H, W, 3), ``emitted`` (H, W, 3) radiance
        toward the camera (the background on a miss), ``shape`` (H, W) shape index (-1
        on a miss).
    """
    from reference_tracer.render import core_scene

    cam = scene.camera
    h, w = cam.height, cam.width
    yy, xx = np.mgrid[0:h, 0:w]
    o, d = camera_rays(cam, xx.ravel() + offset[0], yy.ravel() + offset[1])
    hit = core_scene(scene).intersect(o, d, threads=1)
    t = np.asarray(hit["t"], dtype=np.float64)
    valid = np.isfinite(t)
    prims = np.asarray(hit["prim"], dtype=np.int64)
    shape = np.full(t.shape, -1, dtype=np.int64)
    shape[valid] = prim_shapes(scene)[prims[valid]]
    # the shading normal (Mitsuba's AOV is si.sh_frame.n): the interpolated vertex normals
    # on smooth meshes, else the geometric normal; emission's side is the shading normal's
    shading = hit.get("shading_normal", hit["normal"])
    normal = np.where(valid[:, None], np.asarray(shading, dtype=np.float64), 0.0)
    albedo = np.zeros((t.size, 3))
    emitted = np.tile(np.asarray(scene.background, dtype=np.float64), (t.size, 1))
    front = np.einsum("ij,ij->i", normal, -d) > 0
    for i, s in enumerate(scene.shapes):
        m = shape == i
        if not m.any():
            continue
        value = albedo_of(s.material)
        albedo[m] = np.asarray(hit["reflectance"])[m.ravel()] if isinstance(value, rt.Texture) else value
        emitted[m] = 0.0
        if isinstance(s.material, rt.DiffuseLight):
            emitted[m & front] = s.material.radiance
    return {"t": t.reshape(h, w), "normal": normal.reshape(h, w, 3), "albedo": albedo.reshape(h, w, 3),
            "emitted": emitted.reshape(h, w, 3), "shape": shape.reshape(h, w)}
