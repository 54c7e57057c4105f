"""Lights that are not shapes: an environment map and the delta lights.

:class:`EnvMap` is Mitsuba's ``envmap`` (an equirectangular image of the radiance arriving
from far away), :class:`PointLight`, :class:`SpotLight` and :class:`DirectionalLight` its
``point``, ``spot`` and ``directional`` emitters, and :class:`ProjectorLight` its
``projector``. They go into :class:`reference_tracer.Scene`'s
``lights``. A scene has at most one environment, as in Mitsuba: an ``EnvMap`` or a constant
``background``, not both.

Delta lights (point, spot, directional, projector) sit at one point or send light along one direction:
no direction sampled from a surface can meet them, so only light sampling sees them. The
``mis`` and ``light`` strategies (and the ``direct`` integrator's emitter samples) do;
``uniform``, ``cosine`` and ``mixture`` cannot, and :func:`reference_tracer.render` refuses to
render a scene with delta lights with them.
"""
from __future__ import annotations

import hashlib
import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .imageio import read_exr, read_hdr
from .textures import LUMINANCE, Bitmap, Texture
from .validation import FLOAT32_MAX, colour, finite_scalar, open_regular_file, vector3

__all__ = ["Light", "EnvMap", "PointLight", "SpotLight", "DirectionalLight", "ProjectorLight", "FOV_AXES",
           "ENVMAP_FORMATS", "MAX_ENVMAP_PIXELS"]

#: File extensions :class:`EnvMap` reads: OpenEXR and Radiance RGBE, Mitsuba's HDR formats.
ENVMAP_FORMATS = (".exr", ".hdr", ".rgbe")
#: The most texels an environment map may have (a file's header is checked before decoding).
MAX_ENVMAP_PIXELS = 1 << 26
#: How far from orthonormal an EnvMap's ``to_world`` may be (float32 matrices of files).
_ORTHONORMAL_TOL = 1e-5


class Light:
    """Base class of the lights that are not shapes (:class:`EnvMap`, :class:`PointLight`,
    :class:`SpotLight`, :class:`DirectionalLight`).

    Examples
    --------
    >>> PointLight((0, 1, 0)).delta, EnvMap([[1.0, 1.0]]).delta
    (True, False)
    """

    #: Whether the light has no extent (no direction sampled from a surface meets it).
    delta = False

    def describe(self) -> dict:  # pragma: no cover - every subclass has its own
        raise NotImplementedError


def _rotation(name: str, to_world) -> np.ndarray:
    """The 3x3 rotation (or rotation with a reflection) of ``to_world`` (3x3, or 4x4 affine:
    its translation plays no part for directions), orthonormalised; ValueError otherwise."""
    try:
        m = np.asarray(to_world, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a 3x3 or 4x4 matrix of numbers, got {to_world!r}") from None
    if m.shape == (4, 4):
        if not np.all(np.isfinite(m)):
            raise ValueError(f"{name} must be finite")
        if np.any(m[3, :3] != 0) or m[3, 3] != 1:
            raise ValueError(f"{name} must be affine (last row 0 0 0 1), got {m[3].tolist()}")
        m = m[:3, :3]
    if m.shape != (3, 3):
        raise ValueError(f"{name} must be a 3x3 or 4x4 matrix, got shape {m.shape}")
    if not np.all(np.isfinite(m)):
        raise ValueError(f"{name} must be finite")
    if not np.allclose(m.T @ m, np.eye(3), atol=_ORTHONORMAL_TOL):
        raise ValueError(f"{name} must be a rotation (orthonormal): an environment is a sphere of directions, "
                         "which a scale or shear would not keep (Mitsuba's own lookup would break too)")
    u, _, vt = np.linalg.svd(m)
    return u @ vt


def _regular_file(path: Path) -> None:
    """Refuse anything but a regular file (a FIFO or a device would hang or never end)."""
    try:
        open_regular_file(path, "an image file").close()
    except OSError as exc:
        raise ValueError(f"EnvMap: cannot open {path}: {exc.strerror or exc}") from None
    except ValueError as exc:
        raise ValueError(f"EnvMap: {exc}") from None


def _read_image(path: Path) -> np.ndarray:
    ext = path.suffix.lower()
    if ext not in ENVMAP_FORMATS:
        raise ValueError(f"EnvMap: {path}: only {', '.join(ENVMAP_FORMATS)} files are read (HDR formats), "
                         f"got {ext or 'no extension'!r}")
    _regular_file(path)
    try:
        if ext == ".exr":
            return read_exr(path, max_pixels=MAX_ENVMAP_PIXELS)
        return read_hdr(path, max_pixels=MAX_ENVMAP_PIXELS)
    except ValueError:
        raise
    except Exception as exc:  # OpenEXR reports a damaged file as RuntimeError
        raise ValueError(f"EnvMap: {path} cannot be read: {exc}") from None


def _pixels(image) -> np.ndarray:
    """(H, W, 3) float32 RGB of an image array: grey (H, W) or (H, W, 1) repeated, alpha
    dropped (as Mitsuba converts a bitmap to RGB), padded as Mitsuba pads an envmap."""
    a = np.asarray(image)
    if a.dtype == object or not (np.issubdtype(a.dtype, np.floating) or np.issubdtype(a.dtype, np.integer)):
        raise ValueError(f"EnvMap image must be an array of numbers, got dtype {a.dtype}")
    if a.ndim == 2:
        a = a[..., None]
    if a.ndim != 3 or a.shape[2] not in (1, 3, 4) or a.shape[0] < 1 or a.shape[1] < 1:
        raise ValueError(f"EnvMap image must be (H, W), (H, W, 1), (H, W, 3) or (H, W, 4), got shape {a.shape}")
    if a.shape[0] * a.shape[1] > MAX_ENVMAP_PIXELS:
        raise ValueError(f"EnvMap image has {a.shape[0] * a.shape[1]} texels, more than {MAX_ENVMAP_PIXELS}")
    a = a.astype(np.float64)
    if not np.all(np.isfinite(a)):
        raise ValueError("EnvMap image must be finite (no NaN or Inf texels)")
    if np.any(a < 0):
        raise ValueError(f"EnvMap image must be >= 0 (radiance), its smallest value is {a.min():.6g}")
    if np.any(a > FLOAT32_MAX):
        raise ValueError("EnvMap image values must be at most the largest float32")
    rgb = np.repeat(a, 3, axis=2) if a.shape[2] == 1 else a[..., :3]
    # Mitsuba's Bitmap::pad_to((2, 3)): at least 2 columns and 3 rows, the last column and
    # row repeated.
    h, w = rgb.shape[:2]
    if w < 2:
        rgb = np.concatenate([rgb, np.repeat(rgb[:, -1:], 2 - w, axis=1)], axis=1)
    if h < 3:
        rgb = np.concatenate([rgb, np.repeat(rgb[-1:], 3 - h, axis=0)], axis=0)
    out = np.ascontiguousarray(rgb, dtype=np.float32)
    out.flags.writeable = False
    return out


@dataclass(frozen=True, eq=False)
class EnvMap(Light):
    """An environment map: Mitsuba's ``envmap`` emitter.

    The radiance arriving from far away in each direction, read from an equirectangular
    (latitude-longitude) image, as Mitsuba 3 reads it: its top row looks up (+y) and its
    bottom row down (-y); its columns go around the vertical axis, the left edge (u = 0)
    looking along -z and u = 1/4 along +x (in the map's frame, which ``to_world`` turns
    into the world's). The value between texel centres is interpolated bilinearly
    (periodic around the vertical axis) and multiplied by ``scale``. Light sampling draws
    directions with a density proportional to the texels' luminance (per cell of four
    texels, uniform in solid angle within it), which multiple importance sampling (``mis``)
    weighs against the material's own directions.

    Parameters
    ----------
    image : str, os.PathLike or array_like
        An OpenEXR (``.exr``) or Radiance RGBE (``.hdr``, ``.rgbe``) file, or an array of
        linear radiance: (H, W, 3) RGB, (H, W) or (H, W, 1) grey, (H, W, 4) with alpha
        (ignored, as Mitsuba does). Values finite and >= 0. Stored as float32 (Mitsuba's
        precision), padded as Mitsuba pads it to at least 2 columns and 3 rows (the last
        column and row repeated). A file's header is checked before it is decoded: at most
        :data:`MAX_ENVMAP_PIXELS` texels.
    scale : float, keyword-only
        Multiplies every value (Mitsuba's ``scale``), >= 0.
    to_world : (3, 3) or (4, 4) array_like, keyword-only
        The map's rotation into the world (Mitsuba's ``to_world``; a translation plays no
        part). Must be orthonormal (to 1e-5; stored orthonormalised). None: the identity.

    Attributes
    ----------
    pixels : (H, W, 3) float32 ndarray
        The image as rendered (padded, read-only).
    source : pathlib.Path or None
        The file it was read from.

    Examples
    --------
    >>> import numpy as np
    >>> env = EnvMap(np.ones((4, 8, 3)), scale=2.0)
    >>> env.pixels.shape, env.scale
    ((4, 8, 3), 2.0)
    >>> EnvMap(np.ones((1, 1))).pixels.shape   # padded as Mitsuba pads it
    (3, 2, 3)
    """

    image: object = field(repr=False)
    scale: float = field(default=1.0, kw_only=True)
    to_world: object = field(default=None, kw_only=True)
    pixels: np.ndarray = field(init=False, repr=False)
    source: Path | None = field(init=False, default=None)

    def __post_init__(self):
        if isinstance(self.image, (str, os.PathLike)):
            path = Path(self.image)
            object.__setattr__(self, "source", path)
            pixels = _pixels(_read_image(path))
        else:
            pixels = _pixels(self.image)
        object.__setattr__(self, "pixels", pixels)
        object.__setattr__(self, "scale", finite_scalar("EnvMap.scale", self.scale, lo=0.0, hi=FLOAT32_MAX))
        rot = np.eye(3) if self.to_world is None else _rotation("EnvMap.to_world", self.to_world)
        object.__setattr__(self, "to_world", tuple(tuple(float(x) for x in row) for row in rot))

    @property
    def width(self) -> int:
        return int(self.pixels.shape[1])

    @property
    def height(self) -> int:
        return int(self.pixels.shape[0])

    def digest(self) -> str:
        """SHA-256 of the texels (as rendered): the image's part of the scene's hash."""
        return hashlib.sha256(self.pixels.tobytes() + repr(self.pixels.shape).encode()).hexdigest()

    def describe(self) -> dict:
        return {"type": "envmap", "pixels": self.digest(), "size": [self.width, self.height],
                "scale": self.scale, "to_world": [list(r) for r in self.to_world]}

    def __eq__(self, other):
        return isinstance(other, EnvMap) and self.describe() == other.describe()

    def __hash__(self):
        return hash(self.digest())


def _unit(name: str, v) -> tuple:
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


def _light_texture(name: str, value) -> Texture:
    """A light's texture: a :class:`~reference_tracer.Checkerboard` or
    :class:`~reference_tracer.Bitmap` of values >= 0; ValueError otherwise."""
    if not isinstance(value, Texture):
        raise ValueError(f"{name} must be a texture (Checkerboard or Bitmap), got {type(value).__name__}: "
                         f"{value!r:.80}")
    lo, _ = value.value_range()
    if not lo >= 0.0:
        raise ValueError(f"{name} must be >= 0 everywhere (emitted light), its smallest value is {lo:.6g}")
    return value


def _look_at(name: str, direction, up) -> tuple:
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
        object.__setattr__(self, "direction", _unit("SpotLight.direction", self.direction))
        object.__setattr__(self, "intensity", colour("SpotLight.intensity", self.intensity, upper=None))
        cutoff = finite_scalar("SpotLight.cutoff_angle", self.cutoff_angle, lo=0.0, lo_open=True, hi=180.0)
        beam = 0.75 * cutoff if self.beam_width is None else finite_scalar(
            "SpotLight.beam_width", self.beam_width, lo=0.0, hi=cutoff)
        object.__setattr__(self, "cutoff_angle", cutoff)
        object.__setattr__(self, "beam_width", beam)
        object.__setattr__(self, "up", vector3("SpotLight.up", self.up))
        if self.texture is not None:
            _light_texture("SpotLight.texture", self.texture)
            _look_at("SpotLight", self.direction, self.up)

    @property
    def to_local(self) -> tuple:
        """World to the light's frame (rows: x, y, z = ``direction``), Mitsuba's look_at."""
        return _look_at("SpotLight", self.direction, self.up)

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
        object.__setattr__(self, "direction", _unit("DirectionalLight.direction", self.direction))
        object.__setattr__(self, "irradiance", colour("DirectionalLight.irradiance", self.irradiance, upper=None))

    def describe(self) -> dict:
        return {"type": "directional", "direction": self.direction, "irradiance": self.irradiance}


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
        object.__setattr__(self, "direction", _unit("ProjectorLight.direction", self.direction))
        object.__setattr__(self, "up", vector3("ProjectorLight.up", self.up))
        _look_at("ProjectorLight", self.direction, self.up)
        if isinstance(self.irradiance, Texture):
            _light_texture("ProjectorLight.irradiance", self.irradiance)
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
        return _look_at("ProjectorLight", self.direction, self.up)

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

