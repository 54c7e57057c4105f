"""The environment map :class:`EnvMap`, Mitsuba 3's ``envmap`` emitter: an equirectangular
image of the radiance arriving from far away, from an OpenEXR or Radiance RGBE file (read
here, by extension, its header checked before decoding) or an array, checked and padded as
Mitsuba pads it, and turned into the world by a rotation. A scene has at most one
environment, as in Mitsuba: an ``EnvMap`` or a constant ``background``, not both.
"""
from __future__ import annotations

import hashlib
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .image_files import pad_to
from .imageio import read_exr, read_hdr
from .lights import Light
from .validation import FLOAT32_MAX, finite_scalar, open_regular_file

__all__ = ["EnvMap", "ENVMAP_FORMATS", "MAX_ENVMAP_PIXELS"]

#: File extensions :class:`EnvMap` reads: OpenEXR and Radiance RGBE, Mitsuba's HDR formats.
ENVMAP_FORMATS = (".exr", ".hdr", ".rgbe")
#: The most texels an environment map may have (a file's header is checked before decoding).
MAX_ENVMAP_PIXELS = 1 << 26
#: How far from orthonormal an EnvMap's ``to_world`` may be (float32 matrices of files).
_ORTHONORMAL_TOL = 1e-5


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
    # Mitsuba's envmap pads to at least 2 columns and 3 rows.
    out = np.ascontiguousarray(pad_to(rgb, 3, 2), dtype=np.float32)
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
