"""The projector :class:`ProjectorLight`, Mitsuba 3's ``projector`` emitter: a perspective
camera run backwards, projecting a constant colour or a texture into the scene from one
point (a delta light, :mod:`reference_tracer.lights`), with Mitsuba's field-of-view axes
(:data:`FOV_AXES`) and its reading of a field of view along one of them.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass, field

import numpy as np

from .bitmap import Bitmap
from .lights import Light, light_texture, look_at, unit
from .textures import LUMINANCE, Texture
from .validation import FLOAT32_MAX, colour, finite_scalar, vector3

__all__ = ["ProjectorLight", "FOV_AXES"]

#: Mitsuba's ``fov_axis`` values (src/render/sensor.cpp, parse_fov).
FOV_AXES = ("x", "y", "diagonal", "smaller", "larger")


def _x_fov(fov: float, axis: str, aspect: float) -> float:
    """Mitsuba's parse_fov: the horizontal field of view (degrees) of ``fov`` along ``axis``."""
    if axis == "smaller":
        axis = "y" if aspect > 1 else "x"
    elif axis == "larger":
        axis = "x" if aspect > 1 else "y"
    if axis == "x":
        return fov
    half = math.tan(0.5 * math.radians(fov))
    if axis == "y":
        return math.degrees(2.0 * math.atan(half * aspect))
    width = 2.0 * half / math.sqrt(1.0 + 1.0 / (aspect * aspect))   # diagonal
    return math.degrees(2.0 * math.atan(width * 0.5))


@dataclass(frozen=True)
class ProjectorLight(Light):
    """A projector: Mitsuba's ``projector`` emitter, a perspective camera run backwards.

    From ``position``, looking along ``direction`` (the frame of ``direction`` and ``up``,
    Mitsuba's ``look_at``), it projects ``irradiance``, an image on its virtual image plane
    at distance 1, into the scene. A point at local (x, y, z), z > 0, maps to
    ``uv = (0.5 - 0.5 x / (z t), 0.5 - 0.5 aspect y / (z t))``, t = tan(x_fov / 2) (the
    perspective camera's mapping: u = 0 on the local +x side, v = 0 at the top); outside
    the unit square, or behind the projector, it is dark. What arrives there is
    ``pi * scale * irradiance(uv) / (z^2 cos)``, cos between the axis and the direction from
    the projector: Mitsuba's factor, so that a constant ``irradiance`` E lights a plane
    facing the projector at distance 1 with irradiance pi E. A delta light (seen by ``mis``
    and ``light`` only).

    Parameters
    ----------
    position : (3,) array_like
        The pinhole (world space, finite).
    direction : (3,) array_like
        The optical axis (normalised; non-zero).
    irradiance : float, (3,) array_like or Texture
        Mitsuba's ``irradiance``: a constant colour (>= 0; default 1) or a Checkerboard or
        Bitmap (values >= 0). A Bitmap's width / height is the image's aspect ratio (as
        Mitsuba's ``resolution()``); anything else is square.
    up : (3,) array_like, keyword-only
        The image's up (not parallel to ``direction``); default +y.
    fov : float or None, keyword-only
        Field of view in degrees, in (0, 180), along ``fov_axis``. None: Mitsuba's default,
        a 50 mm focal length (a diagonal field of view of 46.8 degrees).
    fov_axis : {'x', 'y', 'diagonal', 'smaller', 'larger'}, keyword-only
        Which extent of the image ``fov`` spans (Mitsuba's ``fov_axis``; default 'x').
    scale : float, keyword-only
        Multiplies the irradiance (Mitsuba's ``scale``), >= 0.

    Attributes
    ----------
    x_fov : float
        The horizontal field of view (degrees) after ``fov_axis``.
    aspect : float
        The image's width / height.

    Examples
    --------
    >>> p = ProjectorLight((0, 0, 0), (0, 0, 1), 2.0, fov=90)
    >>> p.arriving([[0.0, 0.0, 1.0], [0.5, 0.0, 1.0], [2.0, 0.0, 1.0]]).round(4)[:, 0].tolist()
    [6.2832, 7.0248, 0.0]
    >>> round(p.power(), 4)   # pi * scale * E * the image plane's area (2 x 2)
    25.1327
    """

    position: tuple
    direction: tuple
    irradiance: object = (1.0, 1.0, 1.0)
    up: tuple = field(default=(0.0, 1.0, 0.0), kw_only=True)
    fov: float | None = field(default=None, kw_only=True)
    fov_axis: str = field(default="x", kw_only=True)
    scale: float = field(default=1.0, kw_only=True)
    x_fov: float = field(init=False)
    aspect: float = field(init=False)
    delta = True

    def __post_init__(self):
        object.__setattr__(self, "position", vector3("ProjectorLight.position", self.position))
        object.__setattr__(self, "direction", unit("ProjectorLight.direction", self.direction))
        object.__setattr__(self, "up", vector3("ProjectorLight.up", self.up))
        look_at("ProjectorLight", self.direction, self.up)
        if isinstance(self.irradiance, Texture):
            light_texture("ProjectorLight.irradiance", self.irradiance)
        elif isinstance(self.irradiance, (str, bytes, os.PathLike, dict)):
            raise ValueError("ProjectorLight.irradiance must be a colour or a texture (Checkerboard or Bitmap; "
                             f"a file goes through Bitmap), got {self.irradiance!r:.80}")
        else:
            object.__setattr__(self, "irradiance", colour("ProjectorLight.irradiance", self.irradiance, upper=None))
        object.__setattr__(self, "scale", finite_scalar("ProjectorLight.scale", self.scale, lo=0.0, hi=FLOAT32_MAX))
        if self.fov_axis not in FOV_AXES:
            raise ValueError(f"ProjectorLight.fov_axis must be one of {FOV_AXES}, got {self.fov_axis!r}")
        t = self.irradiance
        aspect = t.width / t.height if isinstance(t, Bitmap) else 1.0
        if self.fov is None:   # Mitsuba's default focal length, 50 mm of a 36 x 24 mm film
            fov, axis = 2.0 * math.degrees(math.atan(math.sqrt(36.0 ** 2 + 24.0 ** 2) / 100.0)), "diagonal"
        else:
            fov = finite_scalar("ProjectorLight.fov", self.fov, lo=0.0, lo_open=True, hi=180.0)
            if fov >= 180.0:
                raise ValueError(f"ProjectorLight.fov must be below 180 degrees, got {fov}")
            object.__setattr__(self, "fov", fov)
            axis = self.fov_axis
        x_fov = _x_fov(fov, axis, aspect)
        if not 0.0 < x_fov < 180.0:
            raise ValueError(f"ProjectorLight: the horizontal field of view {x_fov} of fov={fov} along "
                             f"{axis!r} is not within (0, 180) degrees")
        object.__setattr__(self, "x_fov", x_fov)
        object.__setattr__(self, "aspect", float(aspect))

    @property
    def to_local(self) -> tuple:
        """World to the projector's frame (rows: x, y, z = ``direction``), Mitsuba's look_at."""
        return look_at("ProjectorLight", self.direction, self.up)

    @property
    def textured(self) -> bool:
        return isinstance(self.irradiance, Texture)

    def image_area(self) -> float:
        """The image's area on the plane z = 1: 4 tan^2(x_fov / 2) / aspect (Mitsuba's
        m_sensor_area)."""
        t = math.tan(math.radians(self.x_fov) / 2.0)
        return 4.0 * t * t / self.aspect

    def power(self) -> float:
        """The radiant power sent (luminance, W): pi * scale * mean(irradiance) * image_area
        (the intensity pi scale E / cos^3 over the frustum, dw = cos^3 dA on the plane z = 1);
        a texture's mean is :meth:`~reference_tracer.Texture.mean`."""
        mean = self.irradiance.mean() if self.textured else float(np.asarray(self.irradiance) @ np.asarray(LUMINANCE))
        return math.pi * self.scale * mean * self.image_area()

    def uv(self, points) -> tuple:
        """The image coordinates of (N, 3) points and whether the projector lights them
        (in front of it and within the unit square): ((N, 2), (N,) bool)."""
        p = np.atleast_2d(np.asarray(points, dtype=np.float64)) - np.asarray(self.position)
        loc = p @ np.asarray(self.to_local).T
        t = math.tan(math.radians(self.x_fov) / 2.0)
        with np.errstate(invalid="ignore", divide="ignore"):
            uv = np.stack([0.5 - 0.5 * loc[:, 0] / (loc[:, 2] * t),
                           0.5 - 0.5 * self.aspect * loc[:, 1] / (loc[:, 2] * t)], axis=1)
        lit = (loc[:, 2] > 0) & np.all((uv >= 0) & (uv <= 1), axis=1)
        return uv, lit

    def arriving(self, points) -> np.ndarray:
        """What arrives at each of (N, 3) points (before the receiver's cosine), (N, 3):
        pi scale E(uv) / (z^2 cos) where lit, else 0."""
        p = np.atleast_2d(np.asarray(points, dtype=np.float64))
        uv, lit = self.uv(p)
        d = p - np.asarray(self.position)
        z = d @ np.asarray(self.direction)
        cos = z / np.linalg.norm(d, axis=1)
        out = np.zeros((len(p), 3))
        if np.any(lit):
            e = self.irradiance.eval(uv[lit]) if self.textured else np.asarray(self.irradiance)[None, :]
            out[lit] = self.scale * e * (math.pi / (z[lit] ** 2 * cos[lit]))[:, None]
        return out

    def describe(self) -> dict:
        e = self.irradiance.describe() if self.textured else self.irradiance
        return {"type": "projector", "position": self.position, "direction": self.direction, "up": self.up,
                "irradiance": e, "x_fov": self.x_fov, "aspect": self.aspect, "scale": self.scale}
