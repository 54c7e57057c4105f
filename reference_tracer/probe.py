"""Probes of the C++ core: ray queries, first-hit AOVs and the sampling routines, one batch at a time.

This module is the public door to what the tracer computes *inside* a render, for the
code that checks it (the harness's chi-square tests, AOV parity, stress cases and speed
benchmarks, and the tests). Nothing here renders an image: :func:`reference_tracer.render`
does. The compiled extension loads on first use, as for ``render``.

Ray queries
    :func:`core_scene` compiles a :class:`~reference_tracer.Scene` (BVH built) and returns
    the core's scene object, whose batch queries take C-contiguous float64 arrays of
    origins and directions, shape (N, 3):

    - ``intersect(origins, directions, brute_force=False, threads=1, batch=True,
      wavefront=False, preliminary=False)``: dict of ``t`` (inf on a miss), ``prim``
      (primitive id, -1 on a miss; :func:`primitive_shapes` maps it to a shape), ``point``
      and front ``normal`` (not with ``preliminary``; ``shading_normal`` too where a mesh
      has vertex normals; ``uv``, Mitsuba's texture coordinates, and ``reflectance``, the
      material's reflectance there, where a material has a texture), ``seconds``, ``packet_rays``, ``chunk``, ``chunk_offset``;
    - ``occluded(origins, directions, t_max, wavefront=False)``: (N,) uint8;
    - ``sample_lights(refs, u, width=1)``: light sampling from points ``refs`` with
      uniforms ``u`` (N, 3): dict ``wi``, ``pdf``, ``pdf_all``, ``dist``, ``valid`` and the
      radiance fields; ``width`` points at a time, one of ``LANE_WIDTHS`` (1: the scalar
      integrator's sampler, more: the packs of the wavefront one; every width must give
      width 1's samples bit for bit);
    - ``light_pdf(refs, dirs)``: density of light sampling (every emitter and the background);
    - ``shape_hits(origins, directions, t_max, width=1)``: each sphere's and quad's own test
      on every ray (dict ``hit``, ``t``, the spheres' re-projected ``point`` and ``normal``)
      and ``triangle_hits(origins, directions, width=1)``: the nearest watertight hit among
      the triangles, one at a time or (``width=4``) in blocks of four (dict ``t``,
      ``index``): testing seams, run at each width of ``LANE_WIDTHS`` (every width must
      give width 1's results bit for bit, ``docs/core.md``);
    - ``packet_order(origins, directions)``: how ``intersect`` gathers rays into packets;
    - properties ``primitive_count``, ``emitter_count``, ``bvh_nodes``, ``bvh_depth``,
      ``bvh_blocks``, ``bvh_float_blocks``, ``bvh_bytes``, ``build_seconds``.

    :func:`camera_rays` gives the camera's rays through film points, :func:`first_hit_aovs`
    the first-hit AOVs of every pixel (what AOV parity compares with Mitsuba's).

Sampling routines
    :func:`warp_sample`, :func:`warp_pdf`, :func:`bsdf_sample`, :func:`bsdf_eval_pdf` and
    :func:`rough_plastic_table` run the core's own inline routines (``sampling/warp.h``,
    the material dispatch of ``materials/material.h``) once per row of an array
    (``reference_tracer/cpp/sampling_probe.cpp``).

Layout of the core
    :func:`child_visit_order` and the constants ``PACK_WIDTH`` (rays per pack of the
    batched queries: 8 in AVX-512 builds, else 4), ``PACKET_RAYS`` (rays per packet of
    coherent rays), ``RAY_CHUNK`` (rays a thread of ``intersect`` orders into packets at a
    time), ``CACHED_TREE_BYTES`` (trees above it are traversed without prefetching) and
    ``LANE_WIDTHS`` (the widths, in lanes of doubles, that the core's routines over a lane
    type are compiled for, 1 being the scalar one: ``(1, 4, 8)``), read from the compiled
    core on first access.

Examples
--------
>>> import numpy as np
>>> import reference_tracer as rt
>>> from reference_tracer import probe
>>> cam = rt.Camera(lookfrom=(0, 0, -3), lookat=(0, 0, 0), width=4, height=4)
>>> scene = rt.Scene(camera=cam, shapes=[rt.Sphere((0, 0, 0), 1, rt.Lambertian(0.5))])
>>> hit = probe.core_scene(scene).intersect(np.array([[0.0, 0, -3]]), np.array([[0.0, 0, 1]]))
>>> float(hit["t"][0]), int(hit["prim"][0])
(2.0, 0)
>>> probe.first_hit_aovs(scene)["shape"].tolist()
[[-1, 0, 0, -1], [0, 0, 0, 0], [0, 0, 0, 0], [-1, 0, 0, -1]]
"""
from __future__ import annotations

import numpy as np

from .materials import DiffuseLight, Lambertian, Plastic, RoughPlastic, reflectance_of
from .render import core_scene
from .scene import Camera, Scene
from .shapes import Box, Quad, Sphere, Triangle
from .textures import Texture

__all__ = ["core_scene", "camera_rays", "camera_rays_with_reach", "primitive_shapes", "diffuse_albedo", "first_hit_aovs",
           "warp_sample", "warp_pdf", "bsdf_sample", "bsdf_eval_pdf", "rough_plastic_table",
           "child_visit_order"]

_CORE_CONSTANTS = ("PACK_WIDTH", "PACKET_RAYS", "RAY_CHUNK", "CACHED_TREE_BYTES")


def _core():
    from . import _core  # the C++ core loads on first use, as for render: importing this module does not need it

    return _core


def __getattr__(name: str):
    # The layout constants live in the compiled core; reading one loads it.
    if name in _CORE_CONSTANTS:
        return int(getattr(_core(), name))
    if name == "LANE_WIDTHS":
        return tuple(int(w) for w in _core().LANE_WIDTHS)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def camera_rays(camera: Camera, px, py, lens=None) -> tuple:
    """The camera's rays through film points ``(px, py)``, in pixels.

    The formulas of ``Camera::generate`` in ``reference_tracer/cpp/scene.h``: pixel (0, 0)
    is top left, ``vfov`` vertical, pixel centres at ``x + 0.5``. Rays start on the near
    clip plane (at the eye or the aperture point where there is none); an orthographic
    camera's are parallel, from its view rectangle.

    Parameters
    ----------
    camera : Camera
    px, py : array_like
        Film coordinates in pixels, one entry per ray.
    lens : array_like, shape (N, 2), optional
        A thin lens's aperture numbers in [0, 1)^2, one pair per ray (required for a thin
        lens, which has no single ray per film point; refused otherwise).

    Returns
    -------
    origins, directions : ndarray
        C-contiguous float64 arrays of shape (N, 3), directions of unit length.

    Raises
    ------
    ValueError
        A thin lens without ``lens``, or ``lens`` for any other camera.

    Examples
    --------
    >>> import reference_tracer as rt
    >>> cam = rt.Camera(lookfrom=(0, 0, 1), lookat=(0, 0, 0), vfov=90, width=2, height=2)
    >>> o, d = camera_rays(cam, [1.0], [1.0])
    >>> d.round(6).tolist()
    [[0.0, 0.0, -1.0]]
    >>> ortho = rt.Camera(lookfrom=(0, 0, 1), lookat=(0, 0, 0), width=2, height=2,
    ...                   projection="orthographic", view_height=4.0, near_clip=0.5)
    >>> o, d = camera_rays(ortho, [0.0], [0.0])
    >>> o.tolist(), d.tolist()
    ([[-2.0, 2.0, 0.5]], [[0.0, 0.0, -1.0]])
    """
    o, d, _ = camera_rays_with_reach(camera, px, py, lens)
    return o, d


def camera_rays_with_reach(camera: Camera, px, py, lens=None) -> tuple:
    """:func:`camera_rays` and each ray's reach: a hit at or beyond it (the far clip plane) is a miss.

    Returns
    -------
    origins, directions : ndarray, shape (N, 3)
    reach : ndarray, shape (N,)
        ``inf`` where the camera has no far clip plane.

    Examples
    --------
    >>> import reference_tracer as rt
    >>> cam = rt.Camera(lookfrom=(0, 0, 1), lookat=(0, 0, 0), vfov=90, width=2, height=2, far_clip=3.0)
    >>> camera_rays_with_reach(cam, [1.0], [1.0])[2].tolist()
    [3.0]
    """
    if camera.is_thin_lens and lens is None:
        raise ValueError("a thin lens has no single ray per film point: give lens, the aperture's uniform "
                         "numbers (N, 2)")
    if lens is not None and not camera.is_thin_lens:
        raise ValueError("lens is a thin lens's (Camera.aperture_radius > 0)")
    eye = np.asarray(camera.lookfrom, dtype=np.float64)
    fwd, right, up = (np.asarray(v, dtype=np.float64) for v in camera.basis())
    px, py = np.asarray(px, dtype=np.float64), np.asarray(py, dtype=np.float64)
    if camera.is_orthographic:
        vw, vh = camera.view_size
        sx = (2.0 * px / camera.width - 1.0) * (0.5 * vw)
        sy = (1.0 - 2.0 * py / camera.height) * (0.5 * vh)
        o = eye[None, :] + sx[:, None] * right + sy[:, None] * up + camera.near_clip * fwd
        d = np.broadcast_to(fwd, o.shape)
        reach = np.full(len(o), camera.far_clip - camera.near_clip)
        return np.ascontiguousarray(o), np.ascontiguousarray(d), reach
    hh = np.tan(0.5 * np.radians(camera.vfov))
    hw = hh * camera.width / camera.height
    sx = (2.0 * px / camera.width - 1.0) * hw
    sy = (1.0 - 2.0 * py / camera.height) * hh
    if camera.is_pinhole:  # the plain pinhole's arithmetic (Camera::direction)
        d = fwd[None, :] + sx[:, None] * right[None, :] + sy[:, None] * up[None, :]
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        return (np.ascontiguousarray(np.broadcast_to(eye, d.shape)), np.ascontiguousarray(d),
                np.full(len(d), np.inf))
    ar = au = np.zeros_like(sx)
    f = 1.0
    if camera.is_thin_lens:
        u = np.asarray(lens, dtype=np.float64).reshape(-1, 2)
        if len(u) != len(sx):
            raise ValueError(f"lens: one pair per ray expected, got {len(u)} for {len(sx)} rays")
        dx, dy = _disk_concentric(u[:, 0], u[:, 1])
        ar, au = -camera.aperture_radius * dx, camera.aperture_radius * dy  # Mitsuba's x is our -right
        f = camera.focus_distance
    local = np.stack([f * sx - ar, f * sy - au, np.full_like(sx, f)], axis=1)
    length = np.linalg.norm(local, axis=1)
    d = local[:, :1] * right + local[:, 1:2] * up + local[:, 2:] * fwd
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    inv_z = length / f
    near_t = camera.near_clip * inv_z
    reach = camera.far_clip * inv_z - near_t if np.isfinite(camera.far_clip) else np.full(len(d), np.inf)
    o = eye[None, :] + ar[:, None] * right + au[:, None] * up + near_t[:, None] * d
    return np.ascontiguousarray(o), np.ascontiguousarray(d), reach


def _disk_concentric(u1, u2):
    """Mitsuba's ``warp::square_to_uniform_disk_concentric``, vectorised."""
    a, b = 2.0 * u1 - 1.0, 2.0 * u2 - 1.0
    q13 = np.abs(a) < np.abs(b)
    r, rp = np.where(q13, b, a), np.where(q13, a, b)
    with np.errstate(invalid="ignore", divide="ignore"):
        phi = 0.25 * np.pi * rp / r
    phi = np.where(q13, 0.5 * np.pi - phi, phi)
    phi = np.where((a == 0) & (b == 0), 0.0, phi)
    return r * np.cos(phi), r * np.sin(phi)


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


def warp_sample(name: str, u, param: float = 0.0, *, packed: bool = False) -> np.ndarray:
    """Warp uniform numbers with a routine of ``sampling/warp.h``.

    Parameters
    ----------
    name : str
        ``uniform_hemisphere``, ``cosine_hemisphere``, ``uniform_sphere``, ``uniform_cone``
        or ``concentric_disk``.
    u : ndarray, shape (n, 2)
        C-contiguous float64 uniform numbers in [0, 1).
    param : float, optional
        ``1 - cos(theta_max)`` for ``uniform_cone``.
    packed : bool, optional
        The pack version the wavefront integrator runs (``cosine_hemisphere`` and
        ``concentric_disk`` only).

    Returns
    -------
    ndarray
        (n, 3) local directions (+z the normal), (n, 2) points for ``concentric_disk``.

    Examples
    --------
    >>> import numpy as np
    >>> warp_sample("cosine_hemisphere", np.array([[0.5, 0.5]])).round(6).tolist()
    [[0.0, 0.0, 1.0]]
    """
    return _core().warp_sample(name, u, float(param), packed=packed)


def warp_pdf(name: str, points, param: float = 0.0) -> np.ndarray:
    """Density of :func:`warp_sample`'s output at ``points``.

    Parameters
    ----------
    name : str
        As for :func:`warp_sample`.
    points : ndarray
        (n, 3) C-contiguous float64 directions (density per solid angle) or (n, 2) disk
        points (per area).
    param : float, optional
        As for :func:`warp_sample`.

    Returns
    -------
    ndarray, shape (n,)

    Examples
    --------
    >>> import numpy as np
    >>> round(float(warp_pdf("uniform_sphere", np.array([[0.0, 0.0, 1.0]]))[0]) * 4 * np.pi, 12)
    1.0
    """
    return _core().warp_pdf(name, points, float(param))


def bsdf_sample(material: str, wo, u, albedo, param: float, *, width: int = 1, **coating) -> dict:
    """``rt::bsdf_sample`` of a material for each row of ``u``, as the integrator calls it.

    Parameters
    ----------
    material : str
        ``lambertian``, ``metal`` (``param``: fuzz), ``rough_conductor`` and
        ``rough_conductor_beckmann`` (alpha), ``dielectric`` and ``dielectric_schlick``
        (index of refraction), ``plastic``, ``rough_plastic`` and ``rough_plastic_beckmann``
        (alpha).
    wo : ndarray, shape (3,)
        The unit outgoing direction in the local shading frame (+z the normal).
    u : ndarray, shape (n, 3)
        C-contiguous float64 uniform numbers.
    albedo : ndarray, shape (3,)
        The albedo (a plastic's diffuse reflectance).
    param : float
        The material's parameter (above).
    width : int, optional
        1: the scalar routine, one row at a time. 4 or 8 (``LANE_WIDTHS``), for
        ``rough_conductor`` only: the wavefront integrator's plain-GGX sampler on packs of
        that many rows, which must give width 1's valid samples bit for bit (only the valid
        rows' ``wi``, ``weight`` and ``pdf`` are filled).
    **coating
        A plastic's ``eta`` (int_ior / ext_ior), ``specular`` ((3,) specular reflectance)
        and ``nonlinear``: Mitsuba's defaults where not given.

    Returns
    -------
    dict
        ``wi`` (n, 3), ``weight`` (n, 3) = f cos / pdf, ``pdf`` (n,), ``eta`` (n,),
        ``delta`` (n,), ``valid`` (n,).

    Examples
    --------
    >>> import numpy as np
    >>> s = bsdf_sample("lambertian", np.array([0.0, 0, 1]), np.full((1, 3), 0.5), np.full(3, 0.5), 0.0)
    >>> s["weight"].round(6).tolist(), int(s["valid"][0])
    ([[0.5, 0.5, 0.5]], 1)
    """
    return _core().bsdf_sample(material, wo, u, albedo, float(param), width=int(width), **coating)


def bsdf_eval_pdf(material: str, wo, wi, albedo, param: float, **coating) -> dict:
    """``rt::bsdf_eval`` and ``rt::bsdf_pdf`` of a material for each row of ``wi``.

    Parameters as for :func:`bsdf_sample`, with ``wi`` (n, 3) incident directions in
    place of the uniforms.

    Returns
    -------
    dict
        ``value`` (n, 3), f cos, and ``pdf`` (n,).

    Examples
    --------
    >>> import numpy as np
    >>> e = bsdf_eval_pdf("lambertian", np.array([0.0, 0, 1]), np.array([[0.0, 0, 1]]), np.full(3, 0.5), 0.0)
    >>> round(float(e["pdf"][0]) * np.pi, 12)
    1.0
    """
    return _core().bsdf_eval_pdf(material, wo, wi, albedo, float(param), **coating)


def rough_plastic_table(distribution: str, alpha: float, eta: float) -> dict:
    """The rough plastic coating's tables, as a scene's ``RoughPlastic`` computes them.

    Parameters
    ----------
    distribution : str
        ``ggx`` or ``beckmann``.
    alpha : float
        Roughness.
    eta : float
        ``int_ior / ext_ior``.

    Returns
    -------
    dict
        ``transmittance`` (64,) at the cosines ``max(1e-6, k / 63)`` and
        ``internal_reflectance``.

    Examples
    --------
    >>> rough_plastic_table("ggx", 0.1, 1.5)["transmittance"].shape
    (64,)
    """
    return _core().rough_plastic_table(distribution, float(alpha), float(eta))


def child_visit_order(t_near, met) -> tuple:
    """The order in which the BVH traversals visit the children a ray meets in a node of the wide tree.

    Parameters
    ----------
    t_near : sequence of float, length 8
        The children's entry distances (>= 0, not NaN).
    met : sequence of bool, length 8
        Which children the ray meets.

    Returns
    -------
    network, insertion : list of int
        The slots met, nearest first, as the interleaved traversal's sorting network orders
        them and as the single-ray traversal's insertion sort does (the two must agree).

    Examples
    --------
    >>> child_visit_order([3.0, 1.0, 2.0, 0, 0, 0, 0, 0], [True, True, True] + [False] * 5)
    ([1, 2, 0], [1, 2, 0])
    """
    return _core().child_visit_order(list(t_near), list(met))
