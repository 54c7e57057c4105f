"""FLIP, NVIDIA's perceptual difference of two images, on the same display images as SSIM."""
from __future__ import annotations

import functools
import math
import os

import numpy as np

from ..display import exposure_from_reference, to_display
from ._checks import as_image, nan_mask, same_shape

__all__ = ["flip", "flip_available", "FLIP_PACKAGE"]

#: the PyPI distribution that provides FLIP (``pip install flip-evaluator``).
FLIP_PACKAGE = "flip-evaluator"


@functools.lru_cache(maxsize=1)
def _module():
    """``flip_evaluator``, imported once with ``OMP_NUM_THREADS=1`` (its OpenMP runtime reads it on
    load; one thread is 15-20x faster on small images on a busy machine)."""
    before = os.environ.get("OMP_NUM_THREADS")
    os.environ["OMP_NUM_THREADS"] = "1"
    try:
        import flip_evaluator  # deferred: FLIP's package only when the metric is asked for
    except ImportError as exc:
        raise ImportError(f"FLIP needs the {FLIP_PACKAGE} package: pip install {FLIP_PACKAGE}") from exc
    finally:
        if before is None:
            os.environ.pop("OMP_NUM_THREADS", None)
        else:
            os.environ["OMP_NUM_THREADS"] = before
    return flip_evaluator


def flip_available() -> bool:
    """Whether FLIP can be computed here (the ``flip-evaluator`` package imports)."""
    try:
        _module()
    except ImportError:
        return False
    return True


def flip(img, ref, *, exposure: float | None = None, error_map: bool = False, nan_policy: str = "propagate"):
    r"""Mean LDR-FLIP error of the *display* images (0 = identical, 1 = the largest difference).

    FLIP (Andersson et al., Proc. ACM Comput. Graph. Interact. Tech. 3(2), 2020; NVIDIA's
    ``flip-evaluator``) at 67 pixels per degree, per pixel

    .. math:: \mathrm{FLIP} = \Delta E_c^{\,1 - \Delta E_f},

    :math:`\Delta E_c` the colour difference (HyAB, CSF-filtered), :math:`\Delta E_f` the
    feature difference, both in [0, 1]; the mean over pixels, in LDR mode, of the images
    tone-mapped as for :func:`benchmarks.metrics.ssim`.

    Parameters
    ----------
    img, ref : array_like
        Linear radiance, (H, W, 3) (or (H, W): grey, repeated to RGB).
    exposure, error_map, nan_policy : keyword-only
        The display scale (default: from the reference); also return the per-pixel map, (H, W)
        in [0, 1]; ``'propagate'`` or ``'raise'`` (``'omit'`` is not supported).

    Returns
    -------
    float, or (float, ndarray) with ``error_map``

    Examples
    --------
    >>> ref = np.random.default_rng(0).random((16, 16, 3))
    >>> flip(ref, ref)
    0.0
    >>> round(flip(ref, 0.5 * ref), 2) > 0.05
    True
    """
    if nan_policy == "omit":
        raise ValueError("flip does not support nan_policy='omit'")
    x, r = as_image(img, "img"), as_image(ref, "ref")
    same_shape(img=x, ref=r)
    if x.ndim == 2:
        x, r = np.repeat(x[..., None], 3, axis=-1), np.repeat(r[..., None], 3, axis=-1)
    if x.shape[-1] != 3:
        raise ValueError(f"flip needs RGB images, got {x.shape[-1]} channels")
    if nan_mask(nan_policy, img=x, ref=r) is not None:
        return (math.nan, np.full(x.shape[:2], np.nan)) if error_map else math.nan
    k = exposure_from_reference(r) if exposure is None else float(exposure)
    xd = np.ascontiguousarray(to_display(x, scale=k), dtype=np.float32)
    rd = np.ascontiguousarray(to_display(r, scale=k), dtype=np.float32)
    fmap, mean, _ = _module().evaluate(rd, xd, "LDR", inputsRGB=True, applyMagma=False, computeMeanError=True)
    value = float(mean)
    if error_map:
        return value, np.asarray(fmap, dtype=np.float64).reshape(x.shape[:2])
    return value
