"""Lights that are not shapes: the base :class:`Light`, and the delta lights of one point or
one direction.

:class:`PointLight`, :class:`SpotLight` and :class:`DirectionalLight` are Mitsuba 3's
``point``, ``spot`` and ``directional`` emitters; its ``envmap`` is
:class:`~reference_tracer.EnvMap` (:mod:`reference_tracer.envmap`) and its ``projector``
:class:`~reference_tracer.ProjectorLight` (:mod:`reference_tracer.projector`). They go into
:class:`reference_tracer.Scene`'s ``lights``. A scene has at most one environment, as in
Mitsuba: an ``EnvMap`` or a constant ``background``, not both.

Delta lights (point, spot, directional, projector) sit at one point or send light along one direction:
no direction sampled from a surface can meet them, so only light sampling sees them. The
``mis`` and ``light`` strategies (and the ``direct`` integrator's emitter samples) do;
``uniform``, ``cosine`` and ``mixture`` cannot, and :func:`reference_tracer.render` refuses to
render a scene with delta lights with them.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .textures import Texture
from .validation import colour, finite_scalar, vector3

__all__ = ["Light", "PointLight", "SpotLight", "DirectionalLight", "unit", "light_texture", "look_at"]


class Light:
    """Base class of the lights that are not shapes (:class:`~reference_tracer.EnvMap`,
    :class:`PointLight`, :class:`SpotLight`, :class:`DirectionalLight`,
    :class:`~reference_tracer.ProjectorLight`).

    Examples
    --------
    >>> from reference_tracer import EnvMap
    >>> PointLight((0, 1, 0)).delta, EnvMap([[1.0, 1.0]]).delta
    (True, False)
    """

    #: Whether the light has no extent (no direction sampled from a surface meets it).
    delta = False

    def describe(self) -> dict:  # pragma: no cover - every subclass has its own
        raise NotImplementedError


def unit(name: str, v) -> tuple:
    a = np.asarray(vector3(name, v))
    n = float(np.linalg.norm(a))
    if not n > 0:
        raise ValueError(f"{name} must be a non-zero vector")
    return tuple(float(x) for x in a / n)


@dataclass(frozen=True)
class PointLight(Light):
    """A point light: Mitsuba's ``point`` emitter.

    Radiant ``intensity`` (W/sr, RGB) in every direction from ``position``: a surface at
    distance d receives ``intensity / d^2`` (times its cosine). A delta light (see the
    module's notes: seen by ``mis`` and ``light`` only).

    Parameters
    ----------
    position : (3,) array_like
        Where it sits (world space, finite).
    intensity : float or (3,) array_like
        Radiant intensity (W/sr), >= 0 and finite; Mitsuba's default 1.

    Examples
    --------
    >>> PointLight((0, 2, 0), 10).intensity
    (10.0, 10.0, 10.0)
    """

    position: tuple
    intensity: tuple = (1.0, 1.0, 1.0)
    delta = True

    def __post_init__(self):
        object.__setattr__(self, "position", vector3("PointLight.position", self.position))
        object.__setattr__(self, "intensity", colour("PointLight.intensity", self.intensity, upper=None))

    def describe(self) -> dict:
        return {"type": "point", "position": self.position, "intensity": self.intensity}


def light_texture(name: str, value) -> Texture:
    """A light's texture: a :class:`~reference_tracer.Checkerboard` or
    :class:`~reference_tracer.Bitmap` of values >= 0; ValueError otherwise."""
    if not isinstance(value, Texture):
        raise ValueError(f"{name} must be a texture (Checkerboard or Bitmap), got {type(value).__name__}: "
                         f"{value!r:.80}")
    lo, _ = value.value_range()
    if not lo >= 0.0:
        raise ValueError(f"{name} must be >= 0 everywhere (emitted light), its smallest value is {lo:.6g}")
    return value


def look_at(name: str, direction, up) -> tuple:
    """Mitsuba's look_at frame of a light shining along ``direction`` with ``up``: the rows
    (left, new_up, dir), left = normalize(up x dir), new_up = dir x left (world to local)."""
    d = np.asarray(direction, dtype=np.float64)
    u = np.asarray(vector3(f"{name}.up", up))
    left = np.cross(u, d)
    n = float(np.linalg.norm(left))
    if not n > 1e-9 * max(float(np.linalg.norm(u)), 1e-300):
        raise ValueError(f"{name}.up must not be parallel to the direction (the texture's orientation "
                         f"needs a frame), got up={tuple(u)} and direction={tuple(d)}")
    left = left / n
    return tuple(tuple(float(x) for x in row) for row in (left, np.cross(d, left), d))


@dataclass(frozen=True)
class SpotLight(Light):
    """A spot light: Mitsuba's ``spot`` emitter, with its optional projected texture.

    From ``position``, radiant ``intensity`` along ``direction``, with Mitsuba's falloff:
    full within ``beam_width`` degrees of the axis, falling linearly in the angle to 0 at
    ``cutoff_angle``, dark beyond. A delta light (seen by ``mis`` and ``light`` only).

    With a ``texture``, the intensity toward local direction (x, y, z) (in the frame of
    ``direction`` and ``up``, Mitsuba's ``look_at``: x = normalize(up x direction)) is also
    multiplied by the texture at ``uv = 0.5 + 0.5 (x, y) / (z tan(cutoff_angle))``: the
    unit square spans the square circumscribing the cone at the cutoff.

    Parameters
    ----------
    position : (3,) array_like
    direction : (3,) array_like
        The axis it shines along (normalised; non-zero).
    intensity : float or (3,) array_like
        Radiant intensity on the axis (W/sr), >= 0; Mitsuba's default 1.
    cutoff_angle : float, keyword-only
        Degrees, in (0, 180]; Mitsuba's default 20.
    beam_width : float or None, keyword-only
        Degrees, in [0, cutoff_angle]; None: three quarters of ``cutoff_angle`` (Mitsuba's default).
    texture : Checkerboard, Bitmap or None, keyword-only
        Mitsuba's ``texture``: a spatially varying texture (a constant is the ``intensity``'s
        job, and Mitsuba refuses one), values >= 0.
    up : (3,) array_like, keyword-only
        The frame's up (with a ``texture`` only; not parallel to ``direction``). Mitsuba's
        default spot (no ``to_world``) shines along +z with up +y.

    Examples
    --------
    >>> SpotLight((0, 3, 0), (0, -2, 0), 5, cutoff_angle=30).beam_width
    22.5
    >>> from reference_tracer import Checkerboard
    >>> s = SpotLight((0, 0, 0), (0, 0, 1), texture=Checkerboard(1.0, 0.0), cutoff_angle=45)
    >>> s.arriving([[0.0, 0.0, 1.0], [0.4, -0.4, 1.0]]).round(6).tolist()  # uv (0.5, 0.5), (0.7, 0.3)
    [[1.0, 1.0, 1.0], [0.0, 0.0, 0.0]]
    """

    position: tuple
    direction: tuple
    intensity: tuple = (1.0, 1.0, 1.0)
    cutoff_angle: float = field(default=20.0, kw_only=True)
    beam_width: float | None = field(default=None, kw_only=True)
    texture: Texture | None = field(default=None, kw_only=True)
    up: tuple = field(default=(0.0, 1.0, 0.0), kw_only=True)
    delta = True

    def __post_init__(self):
        object.__setattr__(self, "position", vector3("SpotLight.position", self.position))
        object.__setattr__(self, "direction", unit("SpotLight.direction", self.direction))
        object.__setattr__(self, "intensity", colour("SpotLight.intensity", self.intensity, upper=None))
        cutoff = finite_scalar("SpotLight.cutoff_angle", self.cutoff_angle, lo=0.0, lo_open=True, hi=180.0)
        beam = 0.75 * cutoff if self.beam_width is None else finite_scalar(
            "SpotLight.beam_width", self.beam_width, lo=0.0, hi=cutoff)
        object.__setattr__(self, "cutoff_angle", cutoff)
        object.__setattr__(self, "beam_width", beam)
        object.__setattr__(self, "up", vector3("SpotLight.up", self.up))
        if self.texture is not None:
            light_texture("SpotLight.texture", self.texture)
            look_at("SpotLight", self.direction, self.up)

    @property
    def to_local(self) -> tuple:
        """World to the light's frame (rows: x, y, z = ``direction``), Mitsuba's look_at."""
        return look_at("SpotLight", self.direction, self.up)

    def falloff(self, cos_theta):
        """Mitsuba's falloff at the cosine of the angle to the axis.

        Parameters
        ----------
        cos_theta : float or array_like
            Cosine of the angle between the axis and the direction from the light.

        Returns
        -------
        ndarray
            1 within ``beam_width``, linear in the angle down to 0 at ``cutoff_angle``, 0 beyond.

        Examples
        --------
        >>> SpotLight((0, 0, 0), (0, 0, 1), cutoff_angle=40, beam_width=20).falloff([1.0, 0.0]).tolist()
        [1.0, 0.0]
        """
        c = np.asarray(cos_theta, dtype=np.float64)
        cutoff, beam = math.radians(self.cutoff_angle), math.radians(self.beam_width)
        with np.errstate(invalid="ignore", divide="ignore"):
            ramp = (cutoff - np.arccos(np.clip(c, -1.0, 1.0))) / (cutoff - beam)
        return np.where(c > math.cos(cutoff), np.where(c >= math.cos(beam), 1.0, ramp), 0.0)

    def arriving(self, points) -> np.ndarray:
        """What arrives at each of (N, 3) points from the light (W/m^2/sr times sr, before
        the receiver's cosine): ``intensity * falloff * texture / dist^2``, (N, 3)."""
        p = np.atleast_2d(np.asarray(points, dtype=np.float64)) - np.asarray(self.position)
        dist2 = np.sum(p * p, axis=1)
        d = p / np.sqrt(dist2)[:, None]
        f = self.falloff(d @ np.asarray(self.direction))
        out = np.asarray(self.intensity)[None, :] * (f / dist2)[:, None]
        if self.texture is not None:
            lit = f > 0
            loc = d[lit] @ np.asarray(self.to_local).T
            t = math.tan(math.radians(self.cutoff_angle))
            uv = 0.5 + 0.5 * loc[:, :2] / (loc[:, 2:] * t)
            out[lit] = out[lit] * self.texture.eval(uv)
        return out

    def describe(self) -> dict:
        out = {"type": "spot", "position": self.position, "direction": self.direction,
               "intensity": self.intensity, "cutoff_angle": self.cutoff_angle, "beam_width": self.beam_width}
        if self.texture is not None:   # untextured spots keep the description (and scene hash) they had
            out.update(texture=self.texture.describe(), up=self.up)
        return out


@dataclass(frozen=True)
class DirectionalLight(Light):
    """A directional light: Mitsuba's ``directional`` emitter.

    Light travelling along ``direction`` (normalised) from infinitely far away, of
    ``irradiance`` (W/m^2, RGB) on a surface facing it. A delta light (seen by ``mis`` and
    ``light`` only).

    Parameters
    ----------
    direction : (3,) array_like
        The direction its light travels (normalised; non-zero), Mitsuba's ``direction``.
    irradiance : float or (3,) array_like
        Irradiance on a surface facing the light (W/m^2), >= 0 and finite; Mitsuba's default 1.

    Examples
    --------
    >>> DirectionalLight((0, 0, -2), 3).direction
    (0.0, 0.0, -1.0)
    """

    direction: tuple
    irradiance: tuple = (1.0, 1.0, 1.0)
    delta = True

    def __post_init__(self):
        object.__setattr__(self, "direction", unit("DirectionalLight.direction", self.direction))
        object.__setattr__(self, "irradiance", colour("DirectionalLight.irradiance", self.irradiance, upper=None))

    def describe(self) -> dict:
        return {"type": "directional", "direction": self.direction, "irradiance": self.irradiance}
