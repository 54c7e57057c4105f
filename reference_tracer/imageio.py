"""Image output: linear EXR (OpenEXR) and display PNG (sRGB transfer, Pillow)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["write_exr", "read_exr", "write_png", "to_display"]


def _check_image(name: str, array) -> np.ndarray:
    a = np.asarray(array)
    if a.ndim == 2:
        a = a[..., None]
    if a.ndim != 3 or a.shape[2] not in (1, 3, 4) or a.shape[0] == 0 or a.shape[1] == 0:
        raise ValueError(f"{name}: expected an (H, W), (H, W, 1), (H, W, 3) or (H, W, 4) array, got {a.shape}")
    if not np.issubdtype(a.dtype, np.number):
        raise ValueError(f"{name}: expected a numeric array, got dtype {a.dtype}")
    return a


def write_exr(path, array) -> Path:
    """Write a linear float32 image as OpenEXR (channels R, G, B[, A] or Y).

    Examples
    --------
    >>> write_exr("/tmp/out.exr", np.zeros((4, 4, 3)))  # doctest: +SKIP
    """
    import OpenEXR

    a = _check_image("write_exr", array).astype(np.float32)
    names = {1: "Y", 3: "RGB", 4: "RGBA"}[a.shape[2]]
    channels = {names: a if a.shape[2] > 1 else a[..., 0]}
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with OpenEXR.File(header, channels) as f:
        f.write(str(path))
    return path


def read_exr(path) -> np.ndarray:
    """Read an EXR written by :func:`write_exr` (or Mitsuba) as an (H, W, C) float32 array."""
    import OpenEXR

    with OpenEXR.File(str(path), separate_channels=False) as f:
        channels = f.channels()
        for key in ("RGB", "RGBA", "Y"):
            if key in channels:
                px = np.asarray(channels[key].pixels, dtype=np.float32)
                return px if px.ndim == 3 else px[..., None]
        key = next(iter(channels))
        px = np.asarray(channels[key].pixels, dtype=np.float32)
        return px if px.ndim == 3 else px[..., None]


#: largest exposure (in stops, either sign) of :func:`to_display`: 2**1000 is still a finite double.
MAX_EXPOSURE_STOPS = 1000.0


def check_exposure(exposure) -> float:
    """An exposure in stops as a float, or ``ValueError``: it must be finite and within
    +-:data:`MAX_EXPOSURE_STOPS` (2**1024 overflows a double).

    Examples
    --------
    >>> check_exposure(2000)
    Traceback (most recent call last):
    ...
    ValueError: exposure (stops) must be <= 1000.0, got 2000.0
    """
    from ._validate import finite_scalar

    return finite_scalar("exposure (stops)", exposure, lo=-MAX_EXPOSURE_STOPS, hi=MAX_EXPOSURE_STOPS)


def to_display(array, exposure: float = 0.0, *, scale: float | None = None,
               keep_nan: bool = False) -> np.ndarray:
    """Linear radiance -> display values in [0, 1]: scale by 2**exposure, clip, sRGB transfer.

    Uses colour-science's sRGB inverse EOTF (the piecewise sRGB curve, not gamma 2.2).
    This is the one tone curve of the project: ``benchmarks.display`` (the SSIM metric and
    the report) builds on it.

    Parameters
    ----------
    array : array_like
        Linear radiance, any shape.
    exposure : float
        Exposure in stops: the image is scaled by ``2**exposure``.
    scale : float, optional
        A linear scale factor used instead of ``2**exposure`` (no round trip through log2,
        so a scale computed from a reference is applied exactly).
    keep_nan : bool
        False (default): non-finite values display as 0. True: NaN stays NaN (so a metric
        can see it) and infinities clip like any out-of-range value (+inf -> 1, -inf -> 0).

    Examples
    --------
    >>> to_display(np.array([0.0, 0.25, 4.0, np.nan]), 1.0).round(4).tolist()
    [0.0, 0.7354, 1.0, 0.0]
    >>> to_display(np.array([0.5, np.nan, np.inf]), scale=0.5, keep_nan=True).round(4).tolist()
    [0.5371, nan, 1.0]
    """
    import colour

    if scale is None:
        k = 2.0 ** check_exposure(exposure)
    else:
        k = float(scale)
    a = np.asarray(array, dtype=np.float64)
    if not keep_nan:
        a = np.nan_to_num(a, nan=0.0, posinf=0.0, neginf=0.0)
    a = np.clip(a * k, 0.0, 1.0)
    return np.clip(colour.models.eotf_inverse_sRGB(a), 0.0, 1.0)


def write_png(path, array, exposure: float = 0.0) -> Path:
    """Write linear radiance as an 8-bit sRGB PNG after scaling by ``2**exposure``.

    Examples
    --------
    >>> write_png("/tmp/out.png", np.full((4, 4, 3), 0.5), exposure=0.0)  # doctest: +SKIP
    """
    from PIL import Image

    a = _check_image("write_png", array)
    d = to_display(a[..., :3] if a.shape[2] >= 3 else np.repeat(a, 3, axis=2), exposure)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(np.round(d * 255.0).astype(np.uint8), mode="RGB").save(path)
    return path
