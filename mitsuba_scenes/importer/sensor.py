"""The sensor, film, filter and sampler of a Mitsuba scene as our camera and image settings."""
from __future__ import annotations

import dataclasses
import math

import numpy as np

import reference_tracer as rt
from reference_tracer.distances import farthest_distance, surface_within

from .values import check_params, located, read_film_size, read_matrix, read_scalar, rigid_scale


_SENSOR_OK = {"fov", "fov_axis", "to_world", "near_clip", "far_clip", "focus_distance", "film", "sampler",
              "x_fov", "srf", "focal_length"}


# The sensors read, and the parameters each takes (the orthographic one has no field of
# view: its to_world's scale is the view's extent).
_SENSORS = {"perspective": _SENSOR_OK, "thinlens": _SENSOR_OK | {"aperture_radius"},
            "orthographic": {"to_world", "near_clip", "far_clip", "film", "sampler", "srf"}}


# ProjectiveCamera's defaults (src/render/sensor.cpp).
_NEAR_CLIP, _FAR_CLIP = 1e-2, 1e4


# hdrfilm parameters that change no pixel value of the RGB image rendered: the output file's
# format and channels, the banner (sample_border is checked where it matters).
_FILM_OK = {"width", "height", "rfilter", "pixel_format", "component_format", "sample_border",
            "compensate", "banner", "file_format"}


def _vfov(ctx, node, fov, axis, width, height):
    t = math.tan(math.radians(fov) / 2)
    aspect = width / height
    if axis == "y":
        return fov
    if axis == "x":
        ty = t / aspect
    elif axis == "smaller":
        ty = t if height <= width else t / aspect
    elif axis == "larger":
        ty = t if height >= width else t / aspect
    elif axis == "diagonal":
        ty = t * height / math.hypot(width, height)
    else:
        ctx.bad(node, f"perspective fov_axis='{axis}'")
        return None
    return math.degrees(2 * math.atan(ty))


def _focal_length_fov(ctx, sensor):
    """The diagonal field of view of a sensor without ``fov``, as Mitsuba's ``parse_fov``
    derives it: from ``focal_length`` ("<x>mm", default 50mm) on a 36 x 24 mm film."""
    p = sensor.props
    text = "50mm"
    if "focal_length" in p.keys():
        if p.type("focal_length") != ctx.mi.Properties.Type.String:
            ctx.bad(sensor, f"perspective focal_length of type {p.type('focal_length')} (a string such as '50mm')")
            return None
        text = str(p["focal_length"])
    try:
        value = float(text[:-2] if text.endswith("mm") else text)
    except ValueError:
        value = math.nan
    if not (value > 0 and math.isfinite(value)):
        ctx.bad(sensor, f"perspective focal_length={text!r} (a positive length in mm)")
        return None
    return math.degrees(2.0 * math.atan(math.hypot(36.0, 24.0) / (2.0 * value)))


@located
def read_camera(ctx, sensor):
    """Our camera for the ``sensor`` node (None after recording a problem; a value our camera
    refuses is recorded at the sensor by :func:`~.values.located`)."""
    if sensor is None:
        ctx.problems.append("no sensor (a perspective, thinlens or orthographic sensor is required)")
        return None
    kind = sensor.props.plugin_name()
    if kind not in _SENSORS:
        ctx.bad(sensor, f"sensor '{kind}' (only {', '.join(repr(k) for k in _SENSORS)})")
        return None
    check_params(ctx, sensor, _SENSORS[kind], "sensor")
    OT = ctx.mi.ObjectType
    film, sampler = ctx.child(sensor, OT.Film), ctx.child(sensor, OT.Sampler)
    width = height = 768 if film is None else None
    rfilter = rt.Filter("gaussian")  # Mitsuba's default film's filter
    if film is None:
        width, height = 768, 576
    else:
        if film.props.plugin_name() != "hdrfilm":
            ctx.bad(film, f"film '{film.props.plugin_name()}' (only 'hdrfilm')")
        check_params(ctx, film, _FILM_OK, "film")
        width, height = read_film_size(ctx, film, "width", 768), read_film_size(ctx, film, "height", 576)
        rfilter = _rfilter(ctx, ctx.child(film, OT.ReconstructionFilter))
        if "sample_border" in film.props.keys() and bool(film.props["sample_border"]):
            ctx.bad(film, "hdrfilm sample_border=true")
    if ctx.film_size is not None:
        width, height = ctx.film_size
    if sampler is not None:
        read_sampler(ctx, sampler)
    if kind == "orthographic":  # (its own problems are reported even where the rfilter's are)
        camera = _orthographic(ctx, sensor, width, height, rfilter or rt.Filter())
        return camera if rfilter is not None else None
    if "x_fov" in sensor.props.keys():
        fov, axis = read_scalar(ctx, sensor, "x_fov", 39.3077), "x"
    elif "fov" in sensor.props.keys():
        fov, axis = read_scalar(ctx, sensor, "fov", 39.3077), read_scalar(ctx, sensor, "fov_axis", "x")
    else:
        fov, axis = _focal_length_fov(ctx, sensor), "diagonal"
        if fov is None:
            return None
    vfov = _vfov(ctx, sensor, float(fov), axis, width, height)
    m = read_matrix(ctx, sensor)
    lin = m[:3, :3]
    left, up, fwd = lin[:, 0], lin[:, 1], lin[:, 2]
    if not np.allclose(lin.T @ lin, np.eye(3), atol=1e-4) or not np.allclose(np.cross(up, fwd), left, atol=1e-4):
        ctx.bad(sensor, "sensor to_world is not a rigid look_at frame (scale, shear or a mirrored image)")
        return None
    if vfov is None:
        return None
    origin = m[:3, 3]
    if rfilter is None:
        return None
    # Mitsuba's perspective and thinlens sensors start rays on their near plane and end them
    # at the far one: ours the same (from_mitsuba then drops the planes that clip nothing).
    clip = _clip_planes(ctx, sensor)
    if clip is None:
        return None
    lens = dict(near_clip=clip[0], far_clip=clip[1])
    if kind == "thinlens":
        if "aperture_radius" not in sensor.props.keys():
            ctx.bad(sensor, "thinlens without aperture_radius (Mitsuba requires it)")
            return None
        radius = read_scalar(ctx, sensor, "aperture_radius", 0.0)
        focus = read_scalar(ctx, sensor, "focus_distance", clip[1])
        if isinstance(radius, str) or isinstance(focus, str) or not radius >= 0 or not focus > 0:
            ctx.bad(sensor, f"thinlens aperture_radius {radius!r} / focus_distance {focus!r} (need >= 0 and > 0)")
            return None
        # Mitsuba widens a zero aperture to float epsilon: a pinhole to within 1e-7.
        if radius > 0:
            lens.update(aperture_radius=float(radius), focus_distance=float(focus))
    return rt.Camera(lookfrom=origin, lookat=origin + fwd, vup=up, vfov=vfov, width=width, height=height,
                     filter=rfilter, **lens)


def _clip_planes(ctx, sensor):
    """(near_clip, far_clip) of a projective camera, Mitsuba's defaults where not given; None if bad."""
    near = read_scalar(ctx, sensor, "near_clip", _NEAR_CLIP)
    far = read_scalar(ctx, sensor, "far_clip", _FAR_CLIP)
    if isinstance(near, str) or isinstance(far, str) or not 0 < near < far or not math.isfinite(far):
        ctx.bad(sensor, f"sensor near_clip {near!r} / far_clip {far!r} (need 0 < near_clip < far_clip, finite)")
        return None
    return float(near), float(far)


def _orthographic(ctx, sensor, width, height, rfilter):
    """Mitsuba's orthographic sensor: to_world = look_at . scale(sx, sy, sz) (any rotation).

    In camera space the view is [-1, 1] x [-1/aspect, 1/aspect] (orthographic_projection in
    transform.h, aspect = width / height), scaled by to_world: a view 2 sx wide and
    2 sy / aspect high. A ray starts at camera z = near_clip, that is near_clip * sz along the
    view direction in world space, and reaches far_clip - near_clip beyond it.
    """
    clip = _clip_planes(ctx, sensor)
    m = read_matrix(ctx, sensor)
    rs = rigid_scale(m)
    if rs is None or clip is None:
        if rs is None:
            ctx.bad(sensor, "orthographic to_world is not a rotation and scale along the camera's axes (shear or "
                            "a mirrored image)")
        return None
    R, (sx, sy, sz) = rs
    up, fwd = R[:, 1], R[:, 2]
    origin = m[:3, 3]
    near, far = clip
    aspect = width / height
    view_w, view_h = 2.0 * sx, 2.0 * sy / aspect
    # square pixels (equal x and y scales, to float precision) leave view_width to the aspect
    square = abs(sx - sy) <= 1e-6 * max(sx, sy)
    return rt.Camera(lookfrom=origin, lookat=origin + fwd, vup=up, width=width, height=height, filter=rfilter,
                     projection="orthographic", view_height=view_h, view_width=None if square else view_w,
                     near_clip=near * sz, far_clip=near * sz + (far - near))


# Mitsuba's randomised samplers: each places a pixel's samples differently (strata, jittered
# grids, scrambled low-discrepancy points) but every sample is uniform over the pixel, so
# the expected image is the independent sampler's; only the noise differs. Our tracer
# samples independently. A sampler whose jitter is off puts samples at cell centres: a
# different (biased) image, refused.
_RANDOMISED_SAMPLERS = {
    "independent": set(),
    "stratified": {"jitter"},
    "multijitter": {"jitter"},
    "orthogonal": {"jitter", "strength"},
    "ldsampler": set(),
    "sobol": set(),
    "pmj02": set(),
}


def read_sampler(ctx, node):
    """Check a sampler: one of Mitsuba's randomised samplers, read as ``independent``."""
    name = node.props.plugin_name()
    if name not in _RANDOMISED_SAMPLERS:
        ctx.bad(node, f"sampler '{name}' (only Mitsuba's randomised samplers: "
                      f"{', '.join(sorted(_RANDOMISED_SAMPLERS))})")
        return
    check_params(ctx, node, _RANDOMISED_SAMPLERS[name] | {"sample_count", "seed"}, "sampler")
    if "jitter" in node.props.keys() and not bool(node.props["jitter"]):
        ctx.bad(node, f"sampler '{name}' with jitter=false (samples at cell centres: not the independent "
                      "sampler's expected image)")


@located
def _rfilter(ctx, node):
    """Our :class:`reference_tracer.Filter` of a film's rfilter (Mitsuba's default: gaussian), or None."""
    if node is None:
        return rt.Filter("gaussian")
    name = node.props.plugin_name()
    if name == "box":
        check_params(ctx, node, set(), "rfilter")
        return rt.Filter("box")
    if name == "tent":
        check_params(ctx, node, {"radius"}, "rfilter")
        return rt.Filter("tent", radius=float(read_scalar(ctx, node, "radius", 1.0)))
    if name == "gaussian":
        check_params(ctx, node, {"stddev"}, "rfilter")
        return rt.Filter("gaussian", stddev=float(read_scalar(ctx, node, "stddev", 0.5)))
    ctx.bad(node, f"rfilter '{name}' (box, tent and gaussian are supported)")
    return None


#: relative room left for Mitsuba's float32 ray arithmetic when a clip plane is judged idle.
_CLIP_ROOM = 1e-3


def without_idle_clip_planes(camera, shapes):
    """A pinhole ``camera`` without those of its clip planes that clip nothing of ``shapes``.

    Mitsuba's perspective sensor always has clip planes (0.01 and 10^4 unless the file says
    otherwise), while a pinhole without them is the core's fast path (``Camera::plain``: rays
    from the eye, unbounded). A camera ray starts on the near plane, at most
    ``near_clip * sqrt(1 + tx^2 + ty^2)`` from the eye (the corners of the view on that plane;
    tx, ty the tangents of the half fields of view): where no surface comes that near, the
    plane hides nothing. A hit beyond the far plane lies more than ``far_clip`` from the eye:
    where every surface is nearer, the plane cuts nothing. A plane that clips nothing is
    dropped (the same image, and the content hash of a camera without it); one that may clip
    is kept. A thin lens and an orthographic camera keep theirs: neither is the plain pinhole.
    """
    if camera.is_thin_lens or camera.is_orthographic:
        return camera
    eye = np.asarray(camera.lookfrom)
    ty = math.tan(math.radians(camera.vfov) / 2.0)
    tx = ty * camera.aspect
    corner = camera.near_clip * math.sqrt(1.0 + tx * tx + ty * ty)
    near = camera.near_clip if surface_within(shapes, eye, corner * (1.0 + _CLIP_ROOM)) else 0.0
    far = camera.far_clip if farthest_distance(shapes, eye) * (1.0 + _CLIP_ROOM) >= camera.far_clip else math.inf
    return dataclasses.replace(camera, near_clip=near, far_clip=far)


def checked_film_size(size) -> tuple:
    """``(width, height)`` as two whole numbers >= 1, else ``ValueError``."""
    try:
        w, h = size
    except (TypeError, ValueError):
        raise ValueError(f"film_size must be (width, height), got {size!r}") from None
    for v in (w, h):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not 1 <= v <= 2**31 - 1:
            raise ValueError(f"film_size must be two whole numbers >= 1, got {size!r}")
    return int(w), int(h)
