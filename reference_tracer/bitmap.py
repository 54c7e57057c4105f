"""Mitsuba's ``bitmap`` texture, :class:`Bitmap`: an image, from a file
(:func:`reference_tracer.image_files.read_image`) or an array, looked up with bilinear
interpolation or the nearest texel, repeated, mirrored or clamped beyond the unit square;
8-bit images are sRGB encoded and decoded to linear values texel by texel (unless ``raw``),
EXR images are linear.
"""
from __future__ import annotations

import hashlib
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .image_files import MAX_TEXTURE_PIXELS, pad_to, read_image
from .textures import LUMINANCE, Texture, check_to_uv, texture_uv

__all__ = ["Bitmap", "FILTER_TYPES", "WRAP_MODES"]

#: Mitsuba's ``filter_type`` values of a bitmap, in the core's order.
FILTER_TYPES = ("bilinear", "nearest")
#: Mitsuba's ``wrap_mode`` values of a bitmap, in the core's order.
WRAP_MODES = ("repeat", "mirror", "clamp")


@dataclass(frozen=True, eq=False)
class Bitmap(Texture):
    """Mitsuba's ``bitmap``: an image looked up at the texture coordinates.

    Texel ``(i, j)`` (column i, row j, row 0 the image's top) covers
    ``[i / W, (i + 1) / W] x [j / H, (j + 1) / H]`` of the unit square: ``v`` grows down
    the image, as Mitsuba reads it (an OBJ's ``vt`` is flipped on loading, so its
    ``v = 0`` is the image's bottom).

    Parameters
    ----------
    image : str, os.PathLike or array_like
        An image file (:func:`~reference_tracer.image_files.read_image`: PNG, JPEG, BMP or
        EXR; 8-bit images are sRGB and decoded to linear values unless ``raw``), or an
        (H, W), (H, W, 1) or (H, W, 3) array of linear values. An image smaller than 2x2 is
        padded to it by repeating its last row and column, as Mitsuba does.
    filter : {'bilinear', 'nearest'}, keyword-only
        Mitsuba's ``filter_type``: bilinear interpolation between the four texels around
        the point (texel centres at half-integers), or the texel under it.
    wrap : {'repeat', 'mirror', 'clamp'}, keyword-only
        Mitsuba's ``wrap_mode`` beyond the unit square.
    raw : bool, keyword-only
        Mitsuba's ``raw``: an 8-bit file's values are taken as they are (``value / 255``),
        not decoded from sRGB.
    to_uv : array_like or None, keyword-only
        As :class:`~reference_tracer.Checkerboard`'s.

    Attributes
    ----------
    data : numpy.ndarray
        The (H, W, C) float32 linear values looked up (C = 1 or 3), read-only.
    filename : str or None
        The file read, or None for an array.

    Examples
    --------
    >>> b = Bitmap(np.array([[0.0, 1.0], [1.0, 0.0]]), filter="nearest")
    >>> b.eval([[0.25, 0.25], [0.75, 0.25]])[:, 0].tolist()
    [0.0, 1.0]
    >>> float(Bitmap(np.array([[0.0, 1.0], [1.0, 0.0]])).eval([[0.5, 0.5]])[0, 0])
    0.5
    """

    image: object
    filter: str = field(default="bilinear", kw_only=True)
    wrap: str = field(default="repeat", kw_only=True)
    raw: bool = field(default=False, kw_only=True)
    to_uv: tuple | None = field(default=None, kw_only=True)
    data: np.ndarray = field(init=False, repr=False)
    filename: str | None = field(init=False, default=None)

    def __post_init__(self):
        if self.filter not in FILTER_TYPES:
            raise ValueError(f"Bitmap.filter must be one of {FILTER_TYPES}, got {self.filter!r}")
        if self.wrap not in WRAP_MODES:
            raise ValueError(f"Bitmap.wrap must be one of {WRAP_MODES}, got {self.wrap!r}")
        if not isinstance(self.raw, (bool, np.bool_)):
            raise ValueError(f"Bitmap.raw must be True or False, got {self.raw!r}")
        object.__setattr__(self, "raw", bool(self.raw))
        object.__setattr__(self, "to_uv", check_to_uv("Bitmap", self.to_uv))
        source = self.image
        if isinstance(source, (str, os.PathLike)):
            object.__setattr__(self, "filename", str(Path(source).resolve()))
            data = read_image(source, raw=self.raw)
        else:
            data = _image_array(source)
        # Mitsuba's bitmap texture needs 2x2 texels at least.
        data = np.ascontiguousarray(pad_to(data, 2, 2), dtype=np.float32)
        data.setflags(write=False)
        object.__setattr__(self, "data", data)
        object.__setattr__(self, "image", self.filename if self.filename is not None else data)

    @property
    def width(self) -> int:
        return int(self.data.shape[1])

    @property
    def height(self) -> int:
        return int(self.data.shape[0])

    @property
    def channels(self) -> int:
        return int(self.data.shape[2])

    def mean(self) -> float:
        """Mitsuba's ``mean()`` of a bitmap: the mean over texels of their luminance
        (Mitsuba's weights of linear sRGB), or of their value for a grey image."""
        d = self.data.astype(np.float64)
        if d.shape[2] == 3:
            return float(np.mean(d @ np.asarray(LUMINANCE)))
        return float(np.mean(d))

    def value_range(self) -> tuple:
        return float(self.data.min()), float(self.data.max())

    def scalar(self) -> "Bitmap":
        """Mitsuba's ``eval_1`` of a bitmap: a grey image's value, a colour image's luminance
        (Mitsuba's weights of linear sRGB; of the interpolated colour there, of each texel
        here: the same up to rounding, the interpolation being linear).

        Examples
        --------
        >>> b = Bitmap(np.array([[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]]), filter="nearest")
        >>> b.eval_1([[0.25, 0.5], [0.75, 0.5]]).round(6).tolist()
        [0.212671, 0.71516]
        """
        if self.channels == 1:
            return self
        lum = self.data.astype(np.float64) @ np.asarray(LUMINANCE)
        return Bitmap(lum, filter=self.filter, wrap=self.wrap, to_uv=self.to_uv)

    def _wrap(self, i: np.ndarray, res: int) -> np.ndarray:
        if self.wrap == "clamp":
            return np.clip(i, 0, res - 1)
        m = np.mod(i, res)
        if self.wrap == "mirror":
            period = np.floor_divide(i, res)
            m = np.where(period % 2 == 0, m, res - 1 - m)
        return m

    def eval(self, uv) -> np.ndarray:
        p = texture_uv(self.to_uv, uv)
        h, w, _ = self.data.shape
        d = self.data.astype(np.float64)
        out = np.zeros((len(p), 3))
        finite = np.all(np.isfinite(p), axis=1)
        p = np.where(finite[:, None], p, 0.0)
        if self.filter == "nearest":
            ix = self._wrap(np.floor(p[:, 0] * w).astype(np.int64), w)
            iy = self._wrap(np.floor(p[:, 1] * h).astype(np.int64), h)
            val = d[iy, ix]
        else:
            x, y = p[:, 0] * w - 0.5, p[:, 1] * h - 0.5
            x0, y0 = np.floor(x), np.floor(y)
            fx, fy = x - x0, y - y0
            x0, y0 = x0.astype(np.int64), y0.astype(np.int64)
            val = 0.0
            for bx, by, wt in ((0, 0, (1 - fx) * (1 - fy)), (1, 0, fx * (1 - fy)), (0, 1, (1 - fx) * fy),
                               (1, 1, fx * fy)):
                val = val + d[self._wrap(y0 + by, h), self._wrap(x0 + bx, w)] * wt[:, None]
        out[:] = np.broadcast_to(val, (len(p), 3)) if val.shape[1] == 1 else val
        out[~finite] = 0.0
        return out

    def describe(self) -> dict:
        return {"type": "Bitmap", "data_sha256": hashlib.sha256(self.data.tobytes()).hexdigest(),
                "shape": list(self.data.shape), "filter": self.filter, "wrap": self.wrap, "raw": self.raw,
                "to_uv": self.to_uv}


def _image_array(value) -> np.ndarray:
    """An array image as (H, W, C) float32, C = 1 or 3, finite."""
    try:
        a = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"Bitmap.image must be a file name or an (H, W[, C]) array of numbers, got {value!r}") \
            from None
    if a.ndim == 2:
        a = a[..., None]
    if a.ndim != 3 or a.shape[2] not in (1, 3) or a.shape[0] == 0 or a.shape[1] == 0:
        raise ValueError(f"Bitmap.image must have shape (H, W), (H, W, 1) or (H, W, 3), got {a.shape}")
    if a.shape[0] * a.shape[1] > MAX_TEXTURE_PIXELS:
        raise ValueError(f"Bitmap.image has {a.shape[0] * a.shape[1]} pixels, more than {MAX_TEXTURE_PIXELS}")
    if not np.all(np.isfinite(a)):
        raise ValueError("Bitmap.image must be finite (no NaN/Inf)")
    if np.any(np.abs(a) > np.finfo(np.float32).max):
        raise ValueError("Bitmap.image values must fit in float32")
    return a.astype(np.float32)
