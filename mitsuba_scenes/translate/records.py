"""Our scene lowered to plain records (camera, integrator, lights, shapes) that both writers, the dict
and the XML, read.
"""
from __future__ import annotations

import numpy as np

import reference_tracer as rt
from reference_tracer.material_textures import textures_of
from reference_tracer.distances import farthest_distance

from .bsdfs import bsdf_record, f32, is_textured, rgb, value_record


#: ``rr_depth`` given to Mitsuba for ``rr_depth=None`` with ``max_depth=-1`` (unlimited):
#: the largest value Mitsuba's integer property holds, so roulette never starts.
NO_RR_DEPTH = 2**31 - 1


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


def shape_name(i: int, shape) -> str:
    return f"shape_{i:03d}_{type(shape).__name__.lower()}"


def check_linear(label: str, m: np.ndarray, *, similarity: bool) -> None:
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


def _rfilter(f) -> dict:
    """Mitsuba's rfilter of our :class:`reference_tracer.Filter`."""
    if f.kind == "tent":
        return {"type": "tent", "radius": float(f.radius)}
    if f.kind == "gaussian":
        return {"type": "gaussian", "stddev": float(f.stddev)}
    return {"type": "box"}


def lower(scene: rt.Scene) -> dict:
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
        "background": rgb(scene.background) if scene.has_background else None,
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
        return {"type": "envmap", "pixels": light.pixels, "scale": float(f32(light.scale)), "to_world": f32(tw)}
    if isinstance(light, rt.PointLight):
        return {"type": "point", "position": [float(x) for x in f32(light.position)],
                "intensity": {"type": "rgb", "value": rgb(light.intensity)}}
    if isinstance(light, rt.SpotLight):
        p, d = np.asarray(light.position), np.asarray(light.direction)
        # an untextured spot is symmetric about its axis: any up; a texture needs the light's own
        up = _perpendicular(d) if light.texture is None else np.asarray(light.up)
        rec = {"type": "spot", "to_world": f32(look_at_matrix(p, p + d, up)),
               "intensity": {"type": "rgb", "value": rgb(light.intensity)},
               "cutoff_angle": float(f32(light.cutoff_angle)), "beam_width": float(f32(light.beam_width))}
        if light.texture is not None:
            rec["texture"] = value_record(light.texture)
        return rec
    if isinstance(light, rt.ProjectorLight):
        p, d = np.asarray(light.position), np.asarray(light.direction)
        # the horizontal field of view itself: Mitsuba's fov_axis 'x' needs no aspect ratio
        return {"type": "projector", "to_world": f32(look_at_matrix(p, p + d, np.asarray(light.up))),
                "irradiance": value_record(light.irradiance), "scale": float(f32(light.scale)),
                "fov": float(light.x_fov), "fov_axis": "x"}
    if isinstance(light, rt.DirectionalLight):
        return {"type": "directional", "direction": [float(x) for x in f32(light.direction)],
                "irradiance": {"type": "rgb", "value": rgb(light.irradiance)}}
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
           "height": int(c.height), "near_clip": float(f32(near)), "far_clip": float(f32(far)),
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
            rec.update(type="thinlens", aperture_radius=float(f32(c.aperture_radius)),
                       focus_distance=float(f32(c.focus_distance)))
    rec["to_world"] = f32(to_world)
    return rec


def sensor_params(cam: dict) -> dict:
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
    rec = {"name": shape_name(i, s), "bsdf": bsdf_record(label, s.material), "flip_normals": False}
    mat = s.material
    if isinstance(mat, rt.DiffuseLight) and mat.emits:
        rec["emitter"] = rgb(mat.radiance)
    textured = is_textured(mat)
    if isinstance(s, rt.Sphere):
        check_linear(label, m, similarity=True)
        if textured:  # the texture coordinates follow the sphere's frame: its rotation goes along
            tw = np.eye(4)
            tw[:3, :3] = m[:3, :3] / s.scale_factor * s.world_radius()
            tw[:3, 3] = s.world_center()
            rec.update(type="sphere", to_world=f32(tw), flip_normals=s.flip_normals)
        else:
            rec.update(type="sphere", center=[float(x) for x in f32(s.world_center())],
                       radius=float(f32(s.world_radius())), flip_normals=s.flip_normals)
    elif isinstance(s, rt.Quad):
        Q, u, v = s.world_corners()          # flip_normals already swaps u and v
        if textured and s.flip_normals:      # but the texture coordinates follow the quad's own u and v
            Q, u, v = s._point(s.Q), s._vector(s.u), s._vector(s.v)
            rec["flip_normals"] = True
        n = np.cross(u, v)
        tw = np.eye(4)
        tw[:3, 0], tw[:3, 1], tw[:3, 2], tw[:3, 3] = u / 2, v / 2, n / np.linalg.norm(n), Q + (u + v) / 2
        rec.update(type="rectangle", to_world=f32(tw))
    elif isinstance(s, rt.Box):
        check_linear(label, m, similarity=False)
        lo, hi = np.asarray(s.pmin), np.asarray(s.pmax)
        local = np.eye(4)
        local[:3, :3] = np.diag((hi - lo) / 2)
        local[:3, 3] = (hi + lo) / 2
        rec.update(type="cube", to_world=f32(m @ local), flip_normals=s.flip_normals)
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
