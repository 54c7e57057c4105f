"""Mitsuba emitters as our lights: ``area``, ``constant``, ``envmap``, ``point``, ``spot``,
``directional`` and ``projector``.
"""
from __future__ import annotations

import math

import numpy as np

import reference_tracer as rt
from reference_tracer.validation import colour

from .textures import read_colour, read_reflectance
from .values import check_params, located, read_matrix, read_scalar, rigid_scale


#: Parameters every emitter may have that change Mitsuba's variance, never its image: the
#: share of light samples it gets (our selection is by power; docs/conventions.md, Light transport).
EMITTER_ANY = {"sampling_weight"}


def _point3(ctx, node, key):
    """A ``<point>`` / ``<vector>`` property as a 3-vector, or None after recording a problem."""
    p = node.props
    try:
        v = np.array(p[key], dtype=np.float64).ravel()
    except (TypeError, ValueError):
        v = None
    if v is None or v.shape != (3,) or not np.all(np.isfinite(v)):
        ctx.bad(node, f"{p.plugin_name()}.{key} must be a finite 3-vector")
        return None
    return v


def _conformal_axis(ctx, node, m):
    """The unit +z axis of ``to_world`` (a spot's or directional light's direction), or None
    after recording a problem: its linear part must be a rotation times a uniform scale
    (a stretch would change the shape of a spot's cone)."""
    rs = rigid_scale(m)
    if rs is None or not np.allclose(rs[1], rs[1][0], rtol=1e-5):
        ctx.bad(node, f"{node.props.plugin_name()} to_world is not a similarity (rotation, uniform scale, "
                      "translation)")
        return None
    z = m[:3, :3] @ np.array([0.0, 0.0, 1.0])
    return z / np.linalg.norm(z)


def _envmap(ctx, node):
    """Our EnvMap for Mitsuba's ``envmap`` node (its file read by our checked readers), or None."""
    check_params(ctx, node, {"filename", "bitmap", "scale", "to_world", "mis_compensation"} | EMITTER_ANY, "emitter")
    keys = node.props.keys()
    scale = read_scalar(ctx, node, "scale", 1.0)
    if isinstance(scale, str):
        ctx.bad(node, f"envmap scale={scale!r} (a number)")
        return None
    m = read_matrix(ctx, node)
    try:
        if "bitmap" in keys:   # a mi.Bitmap object, as load_dict takes it (and to_mitsuba gives it)
            if "filename" in keys:
                ctx.bad(node, "envmap with both bitmap and filename (Mitsuba refuses it too)")
                return None
            image = np.array(node.props["bitmap"], dtype=np.float64)
        elif "filename" in keys:
            image = ctx.resolve(str(node.props["filename"]))
        else:
            ctx.bad(node, "envmap without a filename")
            return None
        return rt.EnvMap(image, scale=float(scale), to_world=m)
    except OSError as exc:   # (a ValueError is placed by read_emitter, the reader of the node)
        ctx.bad(node, f"envmap: {exc}")
        return None


@located
def read_area_emitter(ctx, node):
    """The radiance of an ``area`` emitter (on a shape, or declared at the top level and
    referenced), checked here as our :class:`reference_tracer.DiffuseLight` checks it, so
    that a value it refuses is placed at the emitter; None after recording a problem."""
    check_params(ctx, node, {"radiance"}, "emitter")
    radiance = read_colour(ctx, node, "radiance", 1.0)
    if radiance is None:
        return None
    return rt.DiffuseLight(radiance, albedo=None).radiance


@located
def read_constant(ctx, node):
    """The radiance of a ``constant`` emitter, which becomes the scene's background, checked as
    :class:`reference_tracer.Scene` checks its background (at the emitter, not the scene); None
    after recording a problem."""
    check_params(ctx, node, {"radiance"} | EMITTER_ANY, "emitter")
    radiance = read_colour(ctx, node, "radiance", 1.0)
    if radiance is None:
        return None
    return colour("Scene.background", radiance, upper=None)


def _placed_once(ctx, node, key: str, light: str) -> bool:
    """False after recording a ``light`` given both ``key`` and ``to_world``, which Mitsuba refuses too."""
    if key in node.props.keys() and "to_world" in node.props.keys():
        ctx.bad(node, f"{light} light with both {key} and to_world (Mitsuba refuses it too)")
        return False
    return True


@located
def read_emitter(ctx, node):
    """Our light for a top-level Mitsuba emitter other than ``area`` and ``constant``: an
    EnvMap, PointLight, SpotLight or DirectionalLight; None after recording a problem (a value
    our light refuses is recorded at the node by :func:`~.values.located`)."""
    name = node.props.plugin_name()
    keys = node.props.keys()
    if name == "envmap":
        return _envmap(ctx, node)
    if name == "point":
        check_params(ctx, node, {"position", "to_world", "intensity"} | EMITTER_ANY, "emitter")
        if not _placed_once(ctx, node, "position", "point"):
            return None
        position = _point3(ctx, node, "position") if "position" in keys else read_matrix(ctx, node)[:3, 3]
        intensity = read_colour(ctx, node, "intensity", 1.0)
        if position is None or intensity is None:
            return None
        return rt.PointLight(position, intensity)
    if name == "spot":
        check_params(ctx, node, {"to_world", "intensity", "cutoff_angle", "beam_width", "texture"} | EMITTER_ANY,
                     "emitter")
        m = read_matrix(ctx, node)
        axis = _conformal_axis(ctx, node, m)
        intensity = read_colour(ctx, node, "intensity", 1.0)
        cutoff = read_scalar(ctx, node, "cutoff_angle", 20.0)
        beam = read_scalar(ctx, node, "beam_width", None)
        texture = None
        if "texture" in keys:
            texture = read_reflectance(ctx, node, "texture", 1.0)
            if texture is None:
                return None
            if not isinstance(texture, rt.Texture):
                ctx.bad(node, "spot texture must be a checkerboard or bitmap (Mitsuba refuses a constant one: "
                              "the intensity is the constant)")
                return None
        if axis is None or intensity is None:
            return None
        return rt.SpotLight(m[:3, 3], axis, intensity, cutoff_angle=cutoff,
                            beam_width=None if beam is None else beam, texture=texture,
                            up=_axis_up(m))
    if name == "projector":
        return _projector(ctx, node)
    if name == "directional":
        check_params(ctx, node, {"direction", "to_world", "irradiance"} | EMITTER_ANY, "emitter")
        if not _placed_once(ctx, node, "direction", "directional"):
            return None
        if "direction" in keys:
            direction = _point3(ctx, node, "direction")
        else:
            m = read_matrix(ctx, node)
            direction = m[:3, :3] @ np.array([0.0, 0.0, 1.0])
            if not abs(np.linalg.norm(direction) - 1.0) < 1e-5:
                # Mitsuba uses to_world's +z axis as the light's direction without
                # normalising it: a scaled axis would scale its light
                ctx.bad(node, "directional to_world scales its +z axis (Mitsuba would not normalise it)")
                return None
        irradiance = read_colour(ctx, node, "irradiance", 1.0)
        if direction is None or irradiance is None:
            return None
        return rt.DirectionalLight(direction, irradiance)
    ctx.bad(node, f"emitter '{name}' (area on shapes, constant, envmap, point, spot, directional and projector "
                  "are supported)")
    return None


def _axis_up(m: np.ndarray) -> tuple:
    """The image of +y under ``to_world`` (a light's up: with its +z axis, Mitsuba's look_at
    frame gives back the rotation of a similarity)."""
    y = m[:3, :3] @ np.array([0.0, 1.0, 0.0])
    return tuple(float(v) for v in y / np.linalg.norm(y))


def _projector(ctx, node):
    """Our ProjectorLight for Mitsuba's ``projector``, or None after recording a problem.
    A uniform scale s of ``to_world`` multiplies what arrives by s (Mitsuba's 1 / (z_local^2
    cos) with z_local = z / s and the axis n of length s), folded into ``scale``."""
    check_params(ctx, node, {"to_world", "irradiance", "scale", "fov", "fov_axis", "focal_length"} | EMITTER_ANY,
           "emitter")
    keys = node.props.keys()
    m = read_matrix(ctx, node)
    axis = _conformal_axis(ctx, node, m)
    irradiance = read_reflectance(ctx, node, "irradiance", 1.0)
    scale = read_scalar(ctx, node, "scale", 1.0)
    if isinstance(scale, str):
        ctx.bad(node, f"projector scale={scale!r} (a number)")
        return None
    if "fov" in keys and "focal_length" in keys:
        ctx.bad(node, "projector with both fov and focal_length (Mitsuba refuses it too)")
        return None
    if axis is None or irradiance is None:
        return None
    if "fov" in keys:
        fov, fov_axis = read_scalar(ctx, node, "fov", None), str(read_scalar(ctx, node, "fov_axis", "x")).lower()
    else:
        text = str(read_scalar(ctx, node, "focal_length", "50mm"))
        try:
            f = float(text[:-2] if text.endswith("mm") else text)
        except ValueError:
            ctx.bad(node, f"projector focal_length={text!r} (of the form <x>mm)")
            return None
        fov, fov_axis = 2.0 * math.degrees(math.atan(math.sqrt(36.0 ** 2 + 24.0 ** 2) / (2.0 * f))), "diagonal"
    s = float(np.linalg.norm(m[:3, 2]))
    try:
        return rt.ProjectorLight(m[:3, 3], axis, irradiance, up=_axis_up(m), fov=fov, fov_axis=fov_axis,
                                 scale=float(scale) * s)
    except TypeError as exc:   # (a ValueError is placed by read_emitter, the reader of the node)
        ctx.bad(node, f"projector: {exc}")
        return None
