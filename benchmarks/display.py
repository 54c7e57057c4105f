"""Tone mapping: how a linear-radiance image becomes a display image, for SSIM and the report.

One module decides the exposure and the tone curve, so that the SSIM metric
(:func:`benchmarks.metrics.ssim`) and the report's pictures show the same thing:

* :func:`exposure_from_reference`: the linear scale that maps the reference's bright end
  (99th-percentile luminance) to white; SSIM's exposure (docs/conventions.md).
* :func:`reference_exposure`: the report's exposure in stops, the brighter of that scale
  and the reference's median luminance at 18% grey.
* :func:`to_display`: scale (``exposure`` in stops, or a linear ``scale=``), clip to
  [0, 1], sRGB transfer. It *is* the tracer's :func:`reference_tracer.imageio.to_display`,
  the one implementation of the curve, imported here so the metrics and the report name
  their tone map in one place; ``keep_nan=True`` keeps NaN visible (SSIM), the default
  shows it as 0 (pictures).

The same exposure is applied to a test image and its reference, so a too-bright render is
not normalised away.
"""
from __future__ import annotations

import math

import numpy as np

from reference_tracer.imageio import to_display

from .constants import LUMINANCE_WEIGHTS

__all__ = ["exposure_from_reference", "reference_exposure", "to_display", "MIDDLE_GREY"]

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
    if img.ndim == 3:
        return img.mean(axis=-1)
    return img


def exposure_from_reference(ref, *, percentile: float = 99.0) -> float:
    r"""Exposure scale that maps the reference's bright end to display white.

    Returns :math:`k = 1 / Y_q`, where :math:`Y_q` is the ``percentile``-th percentile of
    the reference's luminance (Rec. 709 weights for RGB, the channel mean otherwise),
    ignoring NaNs. The same ``k`` is applied to the test image and the reference, so a
    too-bright render is not normalised away. An all-black (or all-NaN) reference gives
    ``k = 1``.

    Examples
    --------
    >>> exposure_from_reference(np.full((4, 4, 3), 2.0))
    0.5
    """
    r = as_image(ref, "ref")
    if not 0 < percentile <= 100:
        raise ValueError(f"percentile must be in (0, 100]; got {percentile}")
    y = _luminance(r)
    y = y[np.isfinite(y)]
    if y.size == 0:
        return 1.0
    q = float(np.percentile(y, percentile))
    return 1.0 / q if q > 0 else 1.0


def reference_exposure(ref) -> float:
    """Display exposure in stops (``to_display``'s ``exposure``) from the reference image.

    The larger of two scales: the reference's median positive luminance to 18% grey
    (:data:`MIDDLE_GREY`), and the SSIM exposure (:func:`exposure_from_reference`: the
    99th-percentile luminance to white). The second alone darkens any picture in which a
    light source covers more than 1% of the pixels (the Cornell box); the first alone
    would leave low-contrast images dim. Returns 0 for an all-black image; clipped to
    [-60, 60] stops.

    Examples
    --------
    >>> reference_exposure(np.full((4, 4, 3), 0.5))  # 99th percentile to white: 1 stop up
    1.0
    >>> reference_exposure(np.zeros((4, 4, 3)))
    0.0
    """
    r = np.asarray(ref, dtype=np.float64)
    y = _luminance(r[..., :3] if r.ndim == 3 else r)  # an alpha channel is not light
    y = y[np.isfinite(y) & (y > 0)]
    if y.size == 0:
        return 0.0
    k = max(float(exposure_from_reference(r)), MIDDLE_GREY / float(np.median(y)))
    if not (math.isfinite(k) and k > 0):
        return 0.0
    return float(np.clip(math.log2(k), -60.0, 60.0))

