"""Structural similarity of display images (tone mapping from :mod:`benchmarks.display`)."""
from __future__ import annotations

import math
import warnings

from ..display import exposure_from_reference, to_display
from ._checks import as_image, nan_mask, same_shape

__all__ = ["ssim"]

#: side of the Gaussian SSIM window used by scikit-image with sigma=1.5 (truncate 3.5)
_SSIM_WINDOW = 2 * int(3.5 * 1.5 + 0.5) + 1  # = 11


def ssim(img, ref, *, exposure: float | None = None, nan_policy: str = "propagate") -> float:
    r"""Structural similarity of the *display* images.

    Both images scaled by ``exposure`` (default
    :func:`benchmarks.display.exposure_from_reference`), clipped to [0, 1] and sRGB-encoded
    (:func:`benchmarks.display.to_display`), then::

        skimage.metrics.structural_similarity(x, r, data_range=1.0, channel_axis=-1,
            gaussian_weights=True, sigma=1.5, use_sample_covariance=False)

    (``channel_axis=None`` for single-channel ``(H, W)`` images). 1 means identical.

    An image whose smaller side ``s`` is below the 11-pixel window gets ``win_size`` the
    largest odd number ``<= s``; below 3 the result is NaN with a ``RuntimeWarning``.
    ``nan_policy='omit'`` is not supported (a window cannot skip pixels).

    Examples
    --------
    >>> import numpy as np
    >>> ref = np.random.default_rng(0).random((16, 16, 3))
    >>> ssim(ref, ref)
    1.0
    """
    from skimage.metrics import structural_similarity  # deferred: scikit-image only when SSIM is asked for

    if nan_policy == "omit":
        raise ValueError("ssim does not support nan_policy='omit'")
    x, r = as_image(img, "img"), as_image(ref, "ref")
    same_shape(img=x, ref=r)
    if nan_mask(nan_policy, img=x, ref=r) is not None:
        return math.nan
    side = min(x.shape[0], x.shape[1])
    if side < 3:
        warnings.warn(f"ssim: image {x.shape[:2]} is smaller than 3x3; returning NaN",
                      RuntimeWarning, stacklevel=2)
        return math.nan
    k = exposure_from_reference(r) if exposure is None else float(exposure)
    xd, rd = to_display(x, scale=k, keep_nan=True), to_display(r, scale=k, keep_nan=True)
    win = None if side >= _SSIM_WINDOW else (side if side % 2 == 1 else side - 1)
    return float(structural_similarity(
        xd, rd, data_range=1.0, channel_axis=-1 if x.ndim == 3 else None,
        gaussian_weights=True, sigma=1.5, use_sample_covariance=False, win_size=win))
