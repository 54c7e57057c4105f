"""Translate a :class:`reference_tracer.Scene` to Mitsuba 3: a dict and an XML file.

The mapping follows the conventions of docs/conventions.md exactly; anything without an exact
Mitsuba equivalent raises ``ValueError`` naming the object, never an approximation:

=====================================  ==================================================
ours                                   Mitsuba 3
=====================================  ==================================================
``Camera(vfov, lookfrom, ...)``        ``perspective``, ``fov=vfov``, ``fov_axis='y'``,
                                       ``to_world = look_at(lookfrom, lookat, vup)``;
                                       ``hdrfilm`` with the camera's rfilter; ``independent``
``aperture_radius > 0``                ``thinlens``, ``aperture_radius``, ``focus_distance``
``projection='orthographic'``          ``orthographic``, ``to_world = look_at . scale(w/2,
                                       h/2 * aspect, 1)`` for a view of w x h
``near_clip``, ``far_clip``            the same (where 0 / inf: a near plane below any
                                       feature, a far one beyond all)
``Quad(Q, u, v)``                      ``rectangle``, to_world columns (u/2, v/2, n, centre)
``Box(pmin, pmax)``                    ``cube``, to_world = M . T(centre) . S(half size)
``Sphere(c, r)``                       ``sphere`` with world centre and radius (textured:
                                       ``to_world`` with the transform's rotation, which
                                       sets Mitsuba's texture coordinates)
``Triangle``, ``Mesh``                 a mesh (``mi.Mesh`` in the dict, PLY in the XML),
                                       world-space vertices; a Mesh's vertex normals (world
                                       space) where it has them (smooth), else none (flat)
``flip_normals``                       ``flip_normals`` (baked into the winding of meshes
                                       and the axes of quads, but for textured ones, whose
                                       coordinates follow the unflipped order)
``Checkerboard``, ``Bitmap``           ``checkerboard``, ``bitmap`` (the file, or an array
                                       as an ``mi.Bitmap`` / an EXR beside the XML), with
                                       ``to_uv``; a mesh's ``uv`` as its texture coordinates
``MeshAttribute``                      ``mesh_attribute`` (``name``, ``scale``); the mesh's
                                       attributes its textures read go along
                                       (``Mesh.add_attribute`` in the dict, float PLY
                                       properties Mitsuba's ``ply`` groups back in the XML)
``Lambertian``                         ``diffuse``
``Metal(fuzz=0)``                      ``conductor``: ``material='none'``, or RGB ``eta`` and ``k``
``RoughConductor``                     ``roughconductor``: its ``distribution``, ``material='none'``
                                       or RGB ``eta`` and ``k``
``Dielectric(ior)``                    ``dielectric``, ``int_ior=ior``, ``ext_ior=1.0``
``ThinDielectric(ior)``                ``thindielectric``, ``int_ior=ior``, ``ext_ior=1.0``
``RoughDielectric(ior, alpha)``        ``roughdielectric``, ``int_ior=ior``, ``ext_ior=1.0``, its
                                       ``distribution`` and ``alpha``
``Plastic``                            ``plastic``: its reflectances (RGB), ``int_ior``,
                                       ``ext_ior`` and ``nonlinear``
``RoughPlastic``                       ``roughplastic``: as ``plastic``, with its
                                       ``distribution`` and ``alpha``
``two_sided=True``                     ``twosided`` wrapper
``DiffuseLight(L, albedo=a)``          ``area`` emitter + ``diffuse`` BSDF of albedo a (black if None)
``background``                         ``constant`` emitter (none when black)
``EnvMap(image, scale, to_world)``     ``envmap`` with its texels (a ``bitmap`` in the dict, an
                                       OpenEXR file beside the XML), ``scale``, ``to_world``
``PointLight(position, intensity)``    ``point``, ``position``, ``intensity``
``SpotLight(position, direction, ...)`` ``spot``, ``to_world = look_at(position, position +
                                       direction, up)``, ``intensity``, ``cutoff_angle``, ``beam_width``,
                                       a ``texture`` (checkerboard or bitmap) where it has one
``ProjectorLight(position, direction,`` ``projector``, ``to_world = look_at(position, position +
``irradiance, ...)``                   direction, up)``, ``irradiance`` (RGB or a texture),
                                       ``scale``, ``fov`` = x_fov with ``fov_axis`` x
``DirectionalLight(direction, E)``     ``directional``, ``direction``, ``irradiance``
``max_depth``, ``rr_depth``            ``path`` integrator; ``rr_depth=None`` -> larger than max_depth
``direct=Direct(ne, nb)``              ``direct`` integrator, ``emitter_samples=ne``, ``bsdf_samples=nb``
=====================================  ==================================================
"""
from __future__ import annotations

import contextlib
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

import reference_tracer as rt
from reference_tracer.imageio import atomic_write, write_exr
from reference_tracer.materials import textures_of
from reference_tracer.shapes import farthest_distance

from .variants import import_mitsuba

__all__ = ["to_mitsuba", "to_xml", "write_ply", "look_at_matrix", "mitsuba_rr_depth", "scene_extent", "NO_RR_DEPTH"]

#: ``rr_depth`` given to Mitsuba for ``rr_depth=None`` with ``max_depth=-1`` (unlimited):
#: the largest value Mitsuba's integer property holds, so roulette never starts.
NO_RR_DEPTH = 2**31 - 1


# --------------------------------------------------------------------------- helpers
def _f32(x) -> np.ndarray:
    """Round to float32 (what Mitsuba stores) and back to float64."""
    return np.asarray(x, dtype=np.float64).astype(np.float32).astype(np.float64)


def look_at_matrix(origin, target, up) -> np.ndarray:
    """4x4 camera-to-world matrix exactly as Mitsuba's ``Transform4f.look_at``.

    Columns: left = normalize(up x dir), new up = dir x left, dir, origin.

    Examples
    --------
    >>> look_at_matrix((0, 0, -1), (0, 0, 0), (0, 1, 0))[:3, 2].tolist()
    [0.0, 0.0, 1.0]
    """
    o = np.asarray(origin, np.float64)
    d = np.asarray(target, np.float64) - o
    d = d / np.linalg.norm(d)
    left = np.cross(np.asarray(up, np.float64), d)
    left = left / np.linalg.norm(left)
    new_up = np.cross(d, left)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = left, new_up, d, o
    return m


def mitsuba_rr_depth(max_depth: int, rr_depth: int | None) -> int:
    """The ``rr_depth`` Mitsuba gets: ours, or one past ``max_depth`` when disabled.

    Examples
    --------
    >>> mitsuba_rr_depth(50, None), mitsuba_rr_depth(-1, None), mitsuba_rr_depth(8, 5)
    (51, 2147483647, 5)
    """
    if rr_depth is not None:
        return int(rr_depth)
    return NO_RR_DEPTH if max_depth == -1 else int(max_depth) + 1


def _name(i: int, shape) -> str:
    return f"shape_{i:03d}_{type(shape).__name__.lower()}"


def _check_linear(label: str, m: np.ndarray, *, similarity: bool) -> None:
    lin = m[:3, :3]
    det = np.linalg.det(lin)
    if not det > 0:
        raise ValueError(f"{label}: transform must preserve orientation (det > 0), got det {det:.6g}; "
                         f"Mitsuba would turn its normals inside out")
    if similarity:
        s = np.cbrt(det)
        if not np.allclose(lin.T @ lin, (s * s) * np.eye(3), rtol=1e-6, atol=1e-9 * s * s):
            raise ValueError(f"{label}: a sphere needs a similarity transform (rotation, uniform scale, "
                             f"translation); Mitsuba has no ellipsoid")
    if abs(m[3, :3]).max() > 0 or m[3, 3] != 1.0:
        raise ValueError(f"{label}: transform must be affine (last row 0 0 0 1)")


def scene_extent(scene: rt.Scene) -> float:
    """Largest distance from the camera to any point of the scene's geometry (>= 1)."""
    return max(1.0, farthest_distance(scene.shapes, scene.camera.lookfrom))


# --------------------------------------------------------------------------- the neutral form
# The scene is first lowered to a neutral list of plain-Python records; the dict and
# the XML writers both read that list, so they cannot drift apart.

def _rgb(c) -> list:
    return [float(x) for x in _f32(c)]


def _conductor_ior(m) -> dict:
    """A conductor's Fresnel in Mitsuba's terms: ``material='none'`` (Fresnel 1) or RGB ``eta`` and ``k``."""
    if m.eta is None:
        return {"material": "none"}
    return {"eta": {"type": "rgb", "value": _rgb(m.eta)}, "k": {"type": "rgb", "value": _rgb(m.k)}}


def _uv_matrix(to_uv) -> np.ndarray:
    """A texture's ``to_uv`` as the 4x4 matrix Mitsuba's ``<transform>`` holds (rows and
    columns 0 and 1, the translation in column 3)."""
    m = np.eye(4)
    a = np.asarray(to_uv, dtype=np.float64)
    m[:2, :2], m[:2, 3] = a[:, :2], a[:, 2]
    return _f32(m)


def _value_record(v) -> dict:
    """A reflectance in Mitsuba's dict syntax: an RGB value or a texture (plain values; a
    bitmap from an array keeps the array under ``data``: the dict and XML writers give it
    to Mitsuba their own way)."""
    if isinstance(v, rt.Checkerboard):
        return {"type": "checkerboard", "color0": {"type": "rgb", "value": _rgb(v.color0)},
                "color1": {"type": "rgb", "value": _rgb(v.color1)}, "to_uv": _uv_matrix(v.to_uv)}
    if isinstance(v, rt.MeshAttribute):
        return {"type": "mesh_attribute", "name": v.name, "scale": float(v.scale)}
    if isinstance(v, rt.Bitmap):
        rec = {"type": "bitmap", "filter_type": v.filter, "wrap_mode": v.wrap, "to_uv": _uv_matrix(v.to_uv)}
        if v.filename is not None:
            rec.update(filename=v.filename, raw=v.raw)
        else:
            rec["data"] = v.data
        return rec
    return {"type": "rgb", "value": _rgb(v)}


def _textured(m) -> bool:
    return bool(textures_of(m))


def _bsdf_record(label: str, m) -> dict:
    """A nested dict (Mitsuba dict syntax, plain values) for material ``m``."""
    if isinstance(m, rt.Mask):
        # the same texture: Mitsuba's mask reads its eval_1, as rt.Mask does
        opacity = (_value_record(m.opacity) if isinstance(m.opacity, rt.Texture)
                   else float(_f32(m.opacity)))
        return {"type": "mask", "opacity": opacity, "bsdf": _bsdf_record(label, m.material)}
    if isinstance(m, rt.Lambertian):
        b = {"type": "diffuse", "reflectance": _value_record(m.albedo)}
    elif isinstance(m, rt.Metal):
        if m.fuzz > 0:
            raise ValueError(f"{label}: Metal(fuzz={m.fuzz}) has no Mitsuba equivalent (the book's fuzz is "
                             f"not a microfacet model); use RoughConductor(albedo, alpha) or fuzz=0")
        b = {"type": "conductor", **_conductor_ior(m), "specular_reflectance": _value_record(m.albedo)}
    elif isinstance(m, rt.RoughConductor):
        b = {"type": "roughconductor", "distribution": m.distribution, **_conductor_ior(m),
             "alpha": float(_f32(m.alpha)), "specular_reflectance": _value_record(m.albedo)}
    elif isinstance(m, (rt.Plastic, rt.RoughPlastic)):
        # specular_reflectance always given: Mitsuba multiplies by it only then, and its
        # mean (1 when absent) steers the lobe choice the same either way
        b = {"type": "plastic", "diffuse_reflectance": _value_record(m.diffuse_reflectance),
             "specular_reflectance": {"type": "rgb", "value": _rgb(m.specular_reflectance)},
             "int_ior": float(_f32(m.int_ior)), "ext_ior": float(_f32(m.ext_ior)), "nonlinear": bool(m.nonlinear)}
        if isinstance(m, rt.RoughPlastic):
            b.update(type="roughplastic", distribution=m.distribution, alpha=float(_f32(m.alpha)))
    elif isinstance(m, rt.Dielectric):
        if m.fresnel != "exact":
            raise ValueError(f"{label}: Dielectric(fresnel={m.fresnel!r}) has no Mitsuba equivalent (Mitsuba's "
                             f"dielectric uses the exact Fresnel equations); use fresnel='exact'")
        return {"type": "dielectric", "int_ior": float(_f32(m.ior)), "ext_ior": 1.0}
    elif isinstance(m, rt.ThinDielectric):
        return {"type": "thindielectric", "int_ior": float(_f32(m.ior)), "ext_ior": 1.0}
    elif isinstance(m, rt.RoughDielectric):
        return {"type": "roughdielectric", "distribution": m.distribution, "alpha": float(_f32(m.alpha)),
                "int_ior": float(_f32(m.ior)), "ext_ior": 1.0}
    elif isinstance(m, rt.DiffuseLight):
        # A light without albedo reflects nothing: a black diffuse BSDF (Mitsuba would
        # otherwise give the shape its default 0.5 grey diffuse BSDF).
        albedo = m.albedo if m.albedo is not None else (0.0, 0.0, 0.0)
        return {"type": "diffuse", "reflectance": _value_record(albedo)}
    else:
        raise ValueError(f"{label}: material {type(m).__name__} has no Mitsuba translation")
    if getattr(m, "two_sided", False):
        b = {"type": "twosided", "bsdf": b}
    return b


def _rfilter(f) -> dict:
    """Mitsuba's rfilter of our :class:`reference_tracer.Filter`."""
    if f.kind == "tent":
        return {"type": "tent", "radius": float(f.radius)}
    if f.kind == "gaussian":
        return {"type": "gaussian", "stddev": float(f.stddev)}
    return {"type": "box"}


def _lower(scene: rt.Scene) -> dict:
    """Neutral description: camera, integrator, background and shape records."""
    if not isinstance(scene, rt.Scene):
        raise ValueError(f"scene must be a reference_tracer.Scene, got {type(scene).__name__}")
    out = {
        "camera": _camera_record(scene),
        "integrator": ({"type": "path", "max_depth": int(scene.max_depth),
                        "rr_depth": mitsuba_rr_depth(scene.max_depth, scene.rr_depth), "hide_emitters": False}
                       if scene.direct is None else
                       {"type": "direct", "emitter_samples": scene.direct.emitter_samples,
                        "bsdf_samples": scene.direct.bsdf_samples, "hide_emitters": False}),
        "background": _rgb(scene.background) if scene.has_background else None,
        "shapes": [],
        "lights": [_light_record(light) for light in scene.lights],
    }
    errors = []
    for i, s in enumerate(scene.shapes):
        label = f"Scene.shapes[{i}] ({type(s).__name__})"
        try:
            out["shapes"].append(_shape_record(i, label, s))
        except ValueError as exc:
            errors.append(str(exc))
    if errors:
        raise ValueError("scene cannot be translated to Mitsuba exactly:\n  " + "\n  ".join(errors))
    return out


def _perpendicular(d) -> np.ndarray:
    """A unit vector perpendicular to the unit vector ``d`` (a look_at's up)."""
    axis = np.eye(3)[int(np.argmin(np.abs(d)))]
    up = np.cross(d, axis)
    return up / np.linalg.norm(up)


def _light_record(light) -> dict:
    """A light that is not a shape, in Mitsuba's dict syntax (plain values; the envmap's
    texels as an array, its rotation as a 4x4 matrix)."""
    if isinstance(light, rt.EnvMap):
        tw = np.eye(4)
        tw[:3, :3] = light.to_world
        return {"type": "envmap", "pixels": light.pixels, "scale": float(_f32(light.scale)), "to_world": _f32(tw)}
    if isinstance(light, rt.PointLight):
        return {"type": "point", "position": [float(x) for x in _f32(light.position)],
                "intensity": {"type": "rgb", "value": _rgb(light.intensity)}}
    if isinstance(light, rt.SpotLight):
        p, d = np.asarray(light.position), np.asarray(light.direction)
        # an untextured spot is symmetric about its axis: any up; a texture needs the light's own
        up = _perpendicular(d) if light.texture is None else np.asarray(light.up)
        rec = {"type": "spot", "to_world": _f32(look_at_matrix(p, p + d, up)),
               "intensity": {"type": "rgb", "value": _rgb(light.intensity)},
               "cutoff_angle": float(_f32(light.cutoff_angle)), "beam_width": float(_f32(light.beam_width))}
        if light.texture is not None:
            rec["texture"] = _value_record(light.texture)
        return rec
    if isinstance(light, rt.ProjectorLight):
        p, d = np.asarray(light.position), np.asarray(light.direction)
        # the horizontal field of view itself: Mitsuba's fov_axis 'x' needs no aspect ratio
        return {"type": "projector", "to_world": _f32(look_at_matrix(p, p + d, np.asarray(light.up))),
                "irradiance": _value_record(light.irradiance), "scale": float(_f32(light.scale)),
                "fov": float(light.x_fov), "fov_axis": "x"}
    if isinstance(light, rt.DirectionalLight):
        return {"type": "directional", "direction": [float(x) for x in _f32(light.direction)],
                "irradiance": {"type": "rgb", "value": _rgb(light.irradiance)}}
    raise ValueError(f"light {type(light).__name__} has no Mitsuba translation")  # pragma: no cover


def _camera_record(scene: rt.Scene) -> dict:
    """The sensor: ``perspective``, ``thinlens`` or ``orthographic``, with its film's size and rfilter."""
    c = scene.camera
    extent = scene_extent(scene)
    to_world = look_at_matrix(c.lookfrom, c.lookat, c.vup)
    # Our clip planes where the camera has them; else nothing of the scene may be clipped
    # (Mitsuba needs near_clip > 0): near far below any feature, far beyond all.
    near = c.near_clip if c.near_clip > 0.0 else min(1e-4, 1e-6 * extent)
    far = c.far_clip if c.far_clip != float("inf") else c.near_clip + 4.0 * extent + 1.0
    rec = {"type": "perspective", "lookat": (c.lookfrom, c.lookat, c.vup), "width": int(c.width),
           "height": int(c.height), "near_clip": float(_f32(near)), "far_clip": float(_f32(far)),
           "rfilter": _rfilter(c.filter)}
    if c.is_orthographic:
        # Mitsuba's view is [-1, 1] x [-1/aspect, 1/aspect] in camera space, scaled by to_world
        # (transform.h's orthographic_projection): our extents are its scale's x and y.
        view_w, view_h = c.view_size
        to_world = to_world @ np.diag([0.5 * view_w, 0.5 * view_h * c.aspect, 1.0, 1.0])
        rec.update(type="orthographic")
    else:
        rec["fov"] = float(c.vfov)
        if c.is_thin_lens:
            rec.update(type="thinlens", aperture_radius=float(_f32(c.aperture_radius)),
                       focus_distance=float(_f32(c.focus_distance)))
    rec["to_world"] = _f32(to_world)
    return rec


def _sensor_params(cam: dict) -> dict:
    """The sensor's own parameters (besides to_world, film and sampler), in Mitsuba's names."""
    out = {}
    if "fov" in cam:
        out.update(fov=cam["fov"], fov_axis="y")
    for k in ("aperture_radius", "focus_distance", "near_clip", "far_clip"):
        if k in cam:
            out[k] = cam[k]
    return out


def _shape_record(i: int, label: str, s) -> dict:
    m = s.matrix
    rec = {"name": _name(i, s), "bsdf": _bsdf_record(label, s.material), "flip_normals": False}
    mat = s.material
    if isinstance(mat, rt.DiffuseLight) and mat.emits:
        rec["emitter"] = _rgb(mat.radiance)
    textured = _textured(mat)
    if isinstance(s, rt.Sphere):
        _check_linear(label, m, similarity=True)
        if textured:  # the texture coordinates follow the sphere's frame: its rotation goes along
            tw = np.eye(4)
            tw[:3, :3] = m[:3, :3] / s.scale_factor * s.world_radius()
            tw[:3, 3] = s.world_center()
            rec.update(type="sphere", to_world=_f32(tw), flip_normals=s.flip_normals)
        else:
            rec.update(type="sphere", center=[float(x) for x in _f32(s.world_center())],
                       radius=float(_f32(s.world_radius())), flip_normals=s.flip_normals)
    elif isinstance(s, rt.Quad):
        Q, u, v = s.world_corners()          # flip_normals already swaps u and v
        if textured and s.flip_normals:      # but the texture coordinates follow the quad's own u and v
            Q, u, v = s._point(s.Q), s._vector(s.u), s._vector(s.v)
            rec["flip_normals"] = True
        n = np.cross(u, v)
        tw = np.eye(4)
        tw[:3, 0], tw[:3, 1], tw[:3, 2], tw[:3, 3] = u / 2, v / 2, n / np.linalg.norm(n), Q + (u + v) / 2
        rec.update(type="rectangle", to_world=_f32(tw))
    elif isinstance(s, rt.Box):
        _check_linear(label, m, similarity=False)
        lo, hi = np.asarray(s.pmin), np.asarray(s.pmax)
        local = np.eye(4)
        local[:3, :3] = np.diag((hi - lo) / 2)
        local[:3, 3] = (hi + lo) / 2
        rec.update(type="cube", to_world=_f32(m @ local), flip_normals=s.flip_normals)
    elif isinstance(s, (rt.Triangle, rt.Mesh)):
        # Exactly the world-space triangles our tracer intersects (flip_normals baked
        # into the winding, as reference_tracer._compile does), shared vertices kept.
        # Vertex normals likewise: world space, negated when flipped.
        # Textured and flipped: the faces in their own order with Mitsuba's flip_normals,
        # since the texture coordinates (the barycentrics where there are none) follow it.
        normals, uv = None, None
        unbaked = textured and s.flip_normals
        if isinstance(s, rt.Triangle):
            verts, faces = s.world_vertices(), np.array([[0, 1, 2]])
            if unbaked:
                verts = verts[[0, 2, 1]]
        else:
            verts = s.world_vertices()
            faces = s.faces[:, [0, 2, 1]] if s.flip_normals and not unbaked else s.faces
            normals = s.world_normals()
            if unbaked and normals is not None:
                normals = -normals
            uv = s.uv if textured else None
        attributes = {}
        for t in textures_of(mat):
            if isinstance(t, rt.MeshAttribute):
                if not isinstance(s, rt.Mesh):
                    raise ValueError(f"{label}: a MeshAttribute texture ({t.name!r}) on a {type(s).__name__}; only "
                                     "a Mesh has attributes")
                t.values(s)  # the attribute exists, with 1 or 3 channels
                attributes[t.name] = np.asarray(s.attributes[t.name], dtype=np.float32)
        if attributes:
            rec["attributes"] = attributes
        rec.update(type="mesh", vertices=verts.astype(np.float32), faces=np.asarray(faces, dtype=np.uint32),
                   normals=None if normals is None else normals.astype(np.float32),
                   uv=None if uv is None else uv.astype(np.float32), flip_normals=bool(unbaked))
    else:
        raise ValueError(f"{label}: shape type {type(s).__name__} has no Mitsuba translation")
    if "attributes" not in rec and any(isinstance(t, rt.MeshAttribute) for t in textures_of(mat)):
        raise ValueError(f"{label}: a MeshAttribute texture on a {type(s).__name__}; only a Mesh has attributes")
    return rec


# --------------------------------------------------------------------------- dict
def _transform(mi, m: np.ndarray):
    return mi.ScalarTransform4f(np.asarray(m, dtype=np.float64).tolist())


def _mitsuba_values(mi, rec):
    """A record in Mitsuba's dict syntax with its plain values made Mitsuba's: a ``to_uv``
    matrix a transform, a bitmap's ``data`` array an ``mi.Bitmap`` (float32: linear)."""
    if not isinstance(rec, dict):
        return rec
    out = {}
    for key, val in rec.items():
        if key == "to_uv":
            out[key] = _transform(mi, val)
        elif key == "data" and rec.get("type") == "bitmap":
            out["bitmap"] = mi.Bitmap(np.array(val, dtype=np.float32, order="C"))  # a writable copy
        else:
            out[key] = _mitsuba_values(mi, val)
    return out


def _make_mesh(mi, rec: dict):
    """An ``mi.Mesh`` carrying its BSDF and emitter; with vertex normals where the record
    has them (smooth shading), else none (flat); with its texture coordinates where it has
    them."""
    props = mi.Properties()
    props["bsdf"] = mi.load_dict(_mitsuba_values(mi, rec["bsdf"]))
    if "emitter" in rec:
        props["emitter"] = mi.load_dict({"type": "area", "radiance": {"type": "rgb", "value": rec["emitter"]}})
    if rec.get("flip_normals"):
        props["flip_normals"] = True
    vertices, faces, normals, uv = rec["vertices"], rec["faces"], rec.get("normals"), rec.get("uv")
    mesh = mi.Mesh(rec["name"], vertex_count=len(vertices), face_count=len(faces), props=props,
                   has_vertex_normals=normals is not None, has_vertex_texcoords=uv is not None)
    params = mi.traverse(mesh)
    params["vertex_positions"] = type(params["vertex_positions"])(
        np.ascontiguousarray(vertices, dtype=np.float32).ravel())
    params["faces"] = type(params["faces"])(np.ascontiguousarray(faces, dtype=np.uint32).ravel())
    if normals is not None:  # given with the positions: the update keeps them (no recomputation)
        params["vertex_normals"] = type(params["vertex_normals"])(
            np.ascontiguousarray(normals, dtype=np.float32).ravel())
    if uv is not None:
        params["vertex_texcoords"] = type(params["vertex_texcoords"])(np.ascontiguousarray(uv, dtype=np.float32).ravel())
    params.update()
    for name, values in rec.get("attributes", {}).items():
        mesh.add_attribute(name, values.shape[1], np.ascontiguousarray(values, dtype=np.float32).ravel().tolist())
    return mesh


def to_mitsuba(scene: rt.Scene, *, variant: str | None = None) -> dict:
    """Translate ``scene`` into a dict for ``mi.load_dict``.

    Triangles and meshes become ``mi.Mesh`` objects, which belong to the active
    Mitsuba variant: the dict must be loaded under the same variant (a variant is
    selected with :func:`mitsuba_scenes.variants.import_mitsuba` if none is set, or
    ``variant`` is activated).

    Parameters
    ----------
    scene : reference_tracer.Scene
    variant : str or None, keyword-only
        Mitsuba variant to activate first; None keeps the active one.

    Returns
    -------
    dict

    Raises
    ------
    ValueError
        For anything without an exact Mitsuba equivalent (e.g. ``Metal`` with
        ``fuzz > 0``), listing every offending object.

    Examples
    --------
    >>> import mitsuba as mi
    >>> from mitsuba_scenes import get_scene, to_mitsuba
    >>> d = to_mitsuba(get_scene("cornell_box", width=16, height=16), variant="scalar_rgb")
    >>> d["sensor"]["fov_axis"], d["sensor"]["film"]["rfilter"]["type"]
    ('y', 'box')
    >>> scene = mi.load_dict(d)
    """
    low = _lower(scene)
    mi = import_mitsuba(variant)
    cam, integ = low["camera"], low["integrator"]
    d = {
        "type": "scene",
        "integrator": dict(integ),
        "sensor": {
            "type": cam["type"], **_sensor_params(cam),
            "to_world": _transform(mi, cam["to_world"]),
            "sampler": {"type": "independent", "sample_count": 4},
            "film": {"type": "hdrfilm", "width": cam["width"], "height": cam["height"],
                     "rfilter": dict(cam["rfilter"]), "pixel_format": "rgb", "component_format": "float32",
                     "sample_border": False},
        },
    }
    if low["background"] is not None:
        d["background"] = {"type": "constant", "radiance": {"type": "rgb", "value": low["background"]}}
    for i, rec in enumerate(low["lights"]):
        entry = dict(rec)
        if rec["type"] == "envmap":
            entry["bitmap"] = mi.Bitmap(np.array(entry.pop("pixels"), dtype=np.float32, order="C"))  # a writable copy
        for key in ("texture", "irradiance"):   # a textured spot's, a projector's
            if isinstance(entry.get(key), dict) and entry[key]["type"] != "rgb":
                entry[key] = _mitsuba_values(mi, entry[key])
        if "to_world" in entry:
            entry["to_world"] = _transform(mi, entry["to_world"])
        d[f"light_{i:03d}_{rec['type']}"] = entry
    for rec in low["shapes"]:
        name = rec["name"]
        if rec["type"] == "mesh":
            d[name] = _make_mesh(mi, rec)
            continue
        entry = {"type": rec["type"], "bsdf": _mitsuba_values(mi, rec["bsdf"])}
        if "center" in rec:
            entry.update(center=rec["center"], radius=rec["radius"])
        else:
            entry["to_world"] = _transform(mi, rec["to_world"])
        if rec["flip_normals"]:
            entry["flip_normals"] = True
        if "emitter" in rec:
            entry["emitter"] = {"type": "area", "radiance": {"type": "rgb", "value": rec["emitter"]}}
        d[name] = entry
    return d


# --------------------------------------------------------------------------- XML
def _num(x) -> str:
    """Exact decimal of a float32 value (parses back to the same float32 bits)."""
    return repr(float(np.float32(x)))


def _xml_escape(s: str) -> str:
    return quoteattr(str(s))


_CHILD_TAG = {"diffuse": "bsdf", "conductor": "bsdf", "roughconductor": "bsdf", "dielectric": "bsdf",
              "thindielectric": "bsdf", "roughdielectric": "bsdf", "plastic": "bsdf", "roughplastic": "bsdf",
              "twosided": "bsdf", "mask": "bsdf", "area": "emitter", "constant": "emitter", "checkerboard": "texture",
              "bitmap": "texture", "mesh_attribute": "texture"}


def _xml_props(rec: dict, indent: str) -> list:
    """XML lines for the properties of a Mitsuba-dict-syntax record (without 'type')."""
    lines = []
    for key, val in rec.items():
        if key == "type":
            continue
        if key == "to_uv":
            vals = " ".join(_num(x) for x in np.asarray(val).ravel())
            lines += [f'{indent}<transform name="to_uv">', f'{indent}    <matrix value="{vals}"/>',
                      f"{indent}</transform>"]
        elif isinstance(val, dict) and val.get("type") == "rgb":
            lines.append(f'{indent}<rgb name="{key}" value="{", ".join(_num(c) for c in val["value"])}"/>')
        elif isinstance(val, dict):
            tag = _CHILD_TAG[val["type"]]
            name = "" if tag in ("bsdf", "emitter") else f' name="{key}"'
            lines.append(f'{indent}<{tag} type="{val["type"]}"{name}>')
            lines.extend(_xml_props(val, indent + "    "))
            lines.append(f"{indent}</{tag}>")
        elif isinstance(val, bool):
            lines.append(f'{indent}<boolean name="{key}" value="{str(val).lower()}"/>')
        elif isinstance(val, (int, np.integer)):
            lines.append(f'{indent}<integer name="{key}" value="{int(val)}"/>')
        elif isinstance(val, (float, np.floating)):
            lines.append(f'{indent}<float name="{key}" value="{_num(val)}"/>')
        elif isinstance(val, str):
            lines.append(f'{indent}<string name="{key}" value={_xml_escape(val)}/>')
        else:  # pragma: no cover - the neutral form holds only the above
            raise TypeError(f"cannot write {key}={val!r} to XML")
    return lines


def _xml_rfilter(rf: dict) -> list:
    params = [f'                <float name="{k}" value="{_num(v)}"/>' for k, v in rf.items() if k != "type"]
    if not params:
        return [f'            <rfilter type="{rf["type"]}"/>']
    return [f'            <rfilter type="{rf["type"]}">', *params, "            </rfilter>"]


def _xml_matrix(m: np.ndarray, indent: str) -> list:
    vals = " ".join(_num(x) for x in np.asarray(m).ravel())
    return [f'{indent}<transform name="to_world">', f'{indent}    <matrix value="{vals}"/>',
            f"{indent}</transform>"]


def _ply_attribute_properties(name: str, channels: int) -> list:
    """The float properties under which Mitsuba's ``ply`` reads attribute ``name`` back:
    ``{p}_x [_y _z]`` for ``vertex_{p}`` / ``face_{p}``, ``{q}_r _g _b`` for a three-channel
    ``{q}_color`` (its grouping turns ``_r _g _b`` into ``{q}_color``)."""
    p = name.split("_", 1)[1]
    if channels == 3 and p.endswith("_color"):
        return [f"{p[:-6]}_{c}" for c in "rgb"]
    return [f"{p}_{c}" for c in "xyz"[:channels]]


def write_ply(path, vertices, faces, normals=None, *, uv=None, attributes=None) -> None:
    """Write a binary little-endian PLY with float32 positions (and ``normals``, as
    ``nx ny nz``, texture coordinates ``uv``, as ``u v``, and mesh ``attributes`` (a dict,
    ``vertex_*`` and ``face_*``, 1 or 3 channels), as float properties Mitsuba groups back
    into them, where given) and int32 faces.

    Without normals, Mitsuba shades it flat when loaded with ``face_normals=true`` (and
    computes smooth normals without it); with them, Mitsuba's ``ply`` shades it smooth.

    Examples
    --------
    >>> write_ply("tri.ply", [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])  # doctest: +SKIP
    """
    v = np.ascontiguousarray(vertices, dtype="<f4")
    f = np.asarray(faces, dtype=np.int64)
    if v.ndim != 2 or v.shape[1] != 3 or f.ndim != 2 or f.shape[1] != 3:
        raise ValueError(f"write_ply needs (N, 3) vertices and (M, 3) faces, got {v.shape} and {f.shape}")
    props = "property float x\nproperty float y\nproperty float z\n"
    if normals is not None:
        n = np.ascontiguousarray(normals, dtype="<f4")
        if n.shape != v.shape:
            raise ValueError(f"write_ply needs one normal per vertex, got {n.shape} for {v.shape}")
        v = np.ascontiguousarray(np.concatenate([v, n], axis=1))
        props += "property float nx\nproperty float ny\nproperty float nz\n"
    if uv is not None:
        t = np.ascontiguousarray(uv, dtype="<f4")
        if t.shape != (len(v), 2):
            raise ValueError(f"write_ply needs one (u, v) per vertex, got {t.shape} for {len(v)} vertices")
        v = np.ascontiguousarray(np.concatenate([v, t], axis=1))
        props += "property float u\nproperty float v\n"
    face_fields, face_values = [], []
    for name, values in (attributes or {}).items():
        a = np.ascontiguousarray(values, dtype="<f4")
        rows = len(v) if name.startswith("vertex_") else len(f)
        if a.ndim != 2 or a.shape[0] != rows or a.shape[1] not in (1, 3) or not name.startswith(("vertex_", "face_")):
            raise ValueError(f"write_ply: attribute {name!r} needs one row of 1 or 3 values per "
                             f"{'vertex' if name.startswith('vertex_') else 'face'}, got {a.shape}")
        fields = _ply_attribute_properties(name, a.shape[1])
        if name.startswith("vertex_"):
            v = np.ascontiguousarray(np.concatenate([v, a], axis=1))
            props += "".join(f"property float {p}\n" for p in fields)
        else:
            face_fields += fields
            face_values.append(a)
    header = (f"ply\nformat binary_little_endian 1.0\ncomment written by mitsuba_scenes\n"
              f"element vertex {len(v)}\n{props}"
              f"element face {len(f)}\nproperty list uchar int vertex_indices\n"
              + "".join(f"property float {p}\n" for p in face_fields) + "end_header\n")
    rec = np.zeros(len(f), dtype=[("n", "u1"), ("idx", "<i4", (3,))] + [(p, "<f4") for p in face_fields])
    rec["n"], rec["idx"] = 3, f
    if face_fields:
        flat = np.concatenate(face_values, axis=1)
        for k, p in enumerate(face_fields):
            rec[p] = flat[:, k]
    with open(path, "wb") as fh:
        fh.write(header.encode("ascii"))
        fh.write(v.tobytes())
        fh.write(rec.tobytes())


def to_xml(scene: rt.Scene, path, *, spp: int = 4, seed: int = 0) -> Path:
    """Write ``scene`` as a Mitsuba 3 XML file; meshes go beside it as PLY files.

    The file holds exactly what :func:`to_mitsuba` gives (every number is written as
    the exact float32 value Mitsuba stores), so ``mi.load_file(path)`` renders the same
    image as ``mi.load_dict(to_mitsuba(scene))`` for the same seed. Meshes are written
    as ``<stem>_<shape name>.ply`` in the same folder, referenced by relative path: with
    their vertex normals where they have them (smooth shading), else with
    ``face_normals=true`` (flat, as our tracer shades them).

    Parameters
    ----------
    scene : reference_tracer.Scene
    path : str or os.PathLike
        The XML file to write (its folder must exist).
    spp, seed : int, keyword-only
        Defaults of the file's ``$spp`` and ``$seed`` parameters, the sampler's
        ``sample_count`` and ``seed`` (``mitsuba -D spp=64 -D seed=7 file.xml``).

    Returns
    -------
    pathlib.Path
        ``path``.

    Examples
    --------
    >>> from mitsuba_scenes import get_scene, to_xml
    >>> to_xml(get_scene("cornell_mesh", width=32, height=32), "cornell_mesh.xml")  # doctest: +SKIP
    PosixPath('cornell_mesh.xml')
    """
    low = _lower(scene)
    path = Path(path)
    if not path.parent.is_dir():
        raise ValueError(f"to_xml: folder {path.parent} does not exist")
    cam, integ = low["camera"], low["integrator"]
    (o, t, u) = cam["lookat"]
    plys = []  # (path, vertices, faces, normals, uv, attributes): written with the XML, by _write_all
    images = []  # (path, array): OpenEXR files written beside the XML: bitmaps' and envmaps' texels

    def bsdf_with_files(bsdf, textures):
        """The BSDF record with its bitmaps (a reflectance's, a mask's opacity's: of
        ``textures``) named relative to the XML: each one's own file where that lies in the
        XML's folder (an importer of the XML reads no file outside it), else its linear
        texels written to an EXR beside the XML."""
        if not isinstance(bsdf, dict):
            return bsdf
        if bsdf.get("type") == "bitmap":
            rest = {k: v for k, v in bsdf.items() if k not in ("data", "filename", "raw")}
            own = Path(bsdf["filename"]).resolve() if "filename" in bsdf else None
            if own is not None and own.parent == path.parent.resolve():
                return rest | {"filename": own.name, "raw": bsdf["raw"]}
            if "data" in bsdf:
                data = bsdf["data"]
            else:
                data = next(t.data for t in textures if isinstance(t, rt.Bitmap)
                            and t.filename == bsdf["filename"] and t.raw == bsdf["raw"])
            name = f"{path.stem}_texture_{len(images)}.exr"
            images.append((path.parent / name, data))
            return rest | {"filename": name}
        return {k: bsdf_with_files(v, textures) for k, v in bsdf.items()}

    L = ['<?xml version="1.0" encoding="utf-8"?>',
         "<!-- Written by mitsuba_scenes.to_xml: the reference_tracer scene, translated to",
         "     Mitsuba's conventions (fov_axis y, ext_ior 1, one-sided emitters). -->",
         '<scene version="3.0.0">',
         f'    <default name="spp" value="{int(spp)}"/>',
         f'    <default name="seed" value="{int(seed)}"/>',
         f'    <integrator type="{integ["type"]}">',
         *(f'        <integer name="{k}" value="{v}"/>' for k, v in integ.items() if k not in ("type", "hide_emitters")),
         '        <boolean name="hide_emitters" value="false"/>',
         "    </integrator>",
         f'    <sensor type="{cam["type"]}">',
         *(f'        <string name="{k}" value="{v}"/>' if isinstance(v, str) else
           f'        <float name="{k}" value="{_num(v)}"/>' for k, v in _sensor_params(cam).items()),
         f"        <!-- look_at origin={tuple(o)} target={tuple(t)} up={tuple(u)} -->",
         *_xml_matrix(cam["to_world"], "        "),
         '        <sampler type="independent">',
         '            <integer name="sample_count" value="$spp"/>',
         '            <integer name="seed" value="$seed"/>',
         "        </sampler>",
         '        <film type="hdrfilm">',
         f'            <integer name="width" value="{cam["width"]}"/>',
         f'            <integer name="height" value="{cam["height"]}"/>',
         '            <string name="pixel_format" value="rgb"/>',
         '            <string name="component_format" value="float32"/>',
         '            <boolean name="sample_border" value="false"/>',
         *_xml_rfilter(cam["rfilter"]),
         "        </film>",
         "    </sensor>"]
    if low["background"] is not None:
        L += ['    <emitter type="constant">',
              f'        <rgb name="radiance" value="{", ".join(_num(c) for c in low["background"])}"/>',
              "    </emitter>"]
    for i, rec in enumerate(low["lights"]):
        rec = dict(rec)
        L.append(f'    <emitter type="{rec.pop("type")}" id="light_{i:03d}">')
        ind = "        "
        if "pixels" in rec:
            exr = f"{path.stem}_light_{i:03d}.exr"
            images.append((path.parent / exr, rec.pop("pixels")))
            L.append(f"{ind}<string name=\"filename\" value={_xml_escape(exr)}/>")
        if "to_world" in rec:
            L += _xml_matrix(rec.pop("to_world"), ind)
        for key in ("position", "direction"):
            if key in rec:
                x, y, z = rec.pop(key)
                tag = "point" if key == "position" else "vector"
                L.append(f'{ind}<{tag} name="{key}" x="{_num(x)}" y="{_num(y)}" z="{_num(z)}"/>')
        light = scene.lights[i]
        light_textures = [t for t in (getattr(light, "texture", None), getattr(light, "irradiance", None))
                          if isinstance(t, rt.Texture)]
        L += _xml_props(bsdf_with_files(rec, light_textures), ind)
        L.append("    </emitter>")
    for shape, rec in zip(scene.shapes, low["shapes"]):
        kind = "ply" if rec["type"] == "mesh" else rec["type"]
        L.append(f'    <shape type="{kind}" id="{rec["name"]}">')
        ind = "        "
        if rec["type"] == "mesh":
            ply = f"{path.stem}_{rec['name']}.ply"
            plys.append((path.parent / ply, rec["vertices"], rec["faces"], rec.get("normals"), rec.get("uv"),
                         rec.get("attributes")))
            L.append(f"{ind}<string name=\"filename\" value={_xml_escape(ply)}/>")
            if rec.get("normals") is None:
                L.append(f'{ind}<boolean name="face_normals" value="true"/>')
        elif "center" in rec:
            c = rec["center"]
            L += [f'{ind}<point name="center" x="{_num(c[0])}" y="{_num(c[1])}" z="{_num(c[2])}"/>',
                  f'{ind}<float name="radius" value="{_num(rec["radius"])}"/>']
        else:
            L += _xml_matrix(rec["to_world"], ind)
        if rec["flip_normals"]:
            L.append(f'{ind}<boolean name="flip_normals" value="true"/>')
        L += _xml_props({"bsdf": bsdf_with_files(rec["bsdf"], textures_of(shape.material))}, ind)
        if "emitter" in rec:
            L += _xml_props({"emitter": {"type": "area", "radiance": {"type": "rgb", "value": rec["emitter"]}}},
                            ind)
        L.append("    </shape>")
    L.append("</scene>")
    _write_all(path, "\n".join(L) + "\n", plys, images)
    return path


def _write_all(path: Path, text: str, plys: list, images=()) -> None:
    """The meshes' PLY files and the envmaps' and bitmaps' OpenEXR files, then the XML, each
    written atomically (never a partial file); on any error the files this call created are
    removed (nothing stray is left)."""
    for target in (path, *(p[0] for p in plys), *(p for p, _ in images)):
        _check_target(target)
    created = []
    try:
        for ply, vertices, faces, normals, uv, attributes in plys:
            existed = ply.exists()
            atomic_write(ply, lambda tmp, v=vertices, f=faces, n=normals, t=uv, a=attributes: write_ply(
                tmp, v, f, n, uv=t, attributes=a))
            if not existed:
                created.append(ply)
        for exr, data in images:
            existed = exr.exists()
            write_exr(exr, data)
            if not existed:
                created.append(exr)
        atomic_write(path, text)
    except BaseException:
        for done in created:
            with contextlib.suppress(OSError):
                done.unlink()
        raise


def _check_target(path: Path) -> None:
    """Refuse to replace anything but a regular file: a symlink, a device, a FIFO, a folder."""
    if path.is_symlink() or (path.exists() and not path.is_file()):
        what = "a symbolic link" if path.is_symlink() else "a folder" if path.is_dir() else "a special file"
        raise ValueError(f"to_xml: {path} is {what}; refusing to replace it (write to a regular file path)")
