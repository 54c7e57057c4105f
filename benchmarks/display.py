"""Tone mapping of linear radiance for SSIM and the report (docs/conventions.md): the same exposure,
from the reference, is applied to a test image and its reference, so a too-bright render is not
normalised away; :func:`to_display` is the tracer's one tone curve (scale, clip, sRGB); :func:`pyplot` is how a
plotting function gets matplotlib (Agg, files only)."""
from __future__ import annotations

import math

import numpy as np

from reference_tracer.imageio import to_display

from .constants import LUMINANCE_WEIGHTS

__all__ = ["exposure_from_reference", "reference_exposure", "to_display", "pyplot", "MIDDLE_GREY"]

#: linear display value the report maps the reference's median luminance to (photographic 18% grey).
MIDDLE_GREY = 0.18


def as_image(a, name: str) -> np.ndarray:
    """``a`` as a float64 (H, W) or (H, W, C) array; ``ValueError`` naming ``name`` otherwise."""
    arr = np.asarray(a, dtype=np.float64)
    if arr.ndim not in (2, 3):
        raise ValueError(f"{name} must have shape (H, W) or (H, W, C); got shape {arr.shape}")
    if arr.size == 0:
        raise ValueError(f"{name} is empty (shape {arr.shape})")
    return arr


def _luminance(img: np.ndarray) -> np.ndarray:
    """Rec. 709 luminance of RGB, the channel mean of other channel counts; (H, W) as is."""
    if img.ndim == 3 and img.shape[-1] == 3:
        return img @ np.asarray(LUMINANCE_WEIGHTS)
    return img.mean(axis=-1) if img.ndim == 3 else img


def exposure_from_reference(ref) -> float:
    """Linear exposure ``1 / Y_99`` (the reference's 99th-percentile luminance, NaNs ignored);
    1 for an all-black or all-NaN reference.

    >>> exposure_from_reference(np.full((4, 4, 3), 2.0))
    0.5
    """
    y = _luminance(as_image(ref, "ref"))
    y = y[np.isfinite(y)]
    q = float(np.percentile(y, 99.0)) if y.size else 0.0
    return 1.0 / q if q > 0 else 1.0


def reference_exposure(ref) -> float:
    """Display exposure in stops from the reference: the larger of the median luminance to 18%
    grey and :func:`exposure_from_reference` (alone it darkens a picture whose light covers
    more than 1% of the pixels); 0 for an all-black image, clipped to [-60, 60].

    >>> reference_exposure(np.full((4, 4, 3), 0.5)), reference_exposure(np.zeros((4, 4, 3)))
    (1.0, 0.0)
    """
    r = np.asarray(ref, dtype=np.float64)
    y = _luminance(r[..., :3] if r.ndim == 3 else r)  # an alpha channel is not light
    y = y[np.isfinite(y) & (y > 0)]
    if y.size == 0:
        return 0.0
    k = max(float(exposure_from_reference(r)), MIDDLE_GREY / float(np.median(y)))
    return float(np.clip(math.log2(k), -60.0, 60.0)) if math.isfinite(k) and k > 0 else 0.0


def pyplot():
    """``matplotlib.pyplot`` on the Agg backend (files only, no display), imported on the first call."""
    import matplotlib  # deferred: matplotlib only when plotting (0.5-1.5 s)

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # deferred: matplotlib only when plotting (0.5-1.5 s)

    return plt
