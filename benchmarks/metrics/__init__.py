"""Image-error metrics and Monte Carlo convergence statistics, each defined once, here.

One job: numbers that say how far a render is from its reference and how its error falls
with samples. Pure numpy/scipy (plus scikit-image for SSIM; tone mapping is
:mod:`benchmarks.display`'s). Every function takes linear-radiance images as arrays of
shape ``(H, W)`` or ``(H, W, C)`` unless stated and returns plain floats or small
dataclasses, so the harness can write them straight into ``results.jsonl`` /
``summary.json``.

Modules: :mod:`~benchmarks.metrics.errors` (MSE, RMSE, relMSE, reference noise),
:mod:`~benchmarks.metrics.ssim`, :mod:`~benchmarks.metrics.flip` (NVIDIA's FLIP, on the
same display images as SSIM), :mod:`~benchmarks.metrics.bias` (bias and variance over
seeds), :mod:`~benchmarks.metrics.convergence` (slope, efficiency, time to error),
:mod:`~benchmarks.metrics.specs` (the metrics a summary reports, ``--metric``, and a summary
row read under one of them). Every public name is re-exported here: ``from benchmarks
import metrics as M; M.rmse(...)``.

Conventions
-----------
Per-sample variance
    ``var`` images hold the variance of *one sample* of a pixel (as ``rt.render``'s
    ``result.variance``); the variance of the pixel *mean* at ``N`` spp is ``var / N``.
NaN policy
    Functions that reduce over pixels take ``nan_policy`` with scipy's meaning:

    * ``'propagate'`` (default): any NaN in an input makes the result NaN. A NaN pixel
      in a render is a bug, and a NaN metric keeps it visible in the results store.
    * ``'omit'``: pixel-channels where *any* input is NaN are left out of the mean.
    * ``'raise'``: a NaN in any input raises ``ValueError``.

    Infinities are not NaN: they propagate through the arithmetic (an infinite pixel gives
    an infinite MSE).
Shapes
    All images passed together must have exactly the same shape; a mismatch raises
    ``ValueError`` naming the shapes (no broadcasting, which would hide a transposed or
    cropped image).

Examples
--------
>>> from benchmarks import metrics as M
>>> M.mse([[1.0, 2.0]], [[1.0, 4.0]])
2.0
"""
from __future__ import annotations

from ..constants import LUMINANCE_WEIGHTS, RELMSE_EPS
from ..display import exposure_from_reference, to_display
from .bias import BiasVariance, bias_variance
from .convergence import SlopeFit, convergence_slope, efficiency, time_to_error
from .errors import mse, mse_corrected, reference_noise, relmse, relmse_corrected, rmse
from .flip import FLIP_PACKAGE, flip, flip_available
from .specs import COST_FIELDS, DEFAULT_METRIC, METRICS, SPECS, MetricSpec, cost_status, require_metric, view
from .ssim import ssim

__all__ = [
    "mse", "rmse", "relmse", "mse_corrected", "relmse_corrected", "reference_noise",
    "exposure_from_reference", "to_display", "ssim", "flip", "flip_available", "FLIP_PACKAGE",
    "BiasVariance", "bias_variance",
    "SlopeFit", "convergence_slope",
    "efficiency", "time_to_error",
    "RELMSE_EPS", "LUMINANCE_WEIGHTS",
    "MetricSpec", "SPECS", "METRICS", "DEFAULT_METRIC", "COST_FIELDS", "require_metric", "cost_status", "view",
]
