"""Image-error metrics and Monte Carlo convergence statistics, each defined once, here.

One function per metric (scikit-image's metrics style), re-exported here: :mod:`~.errors`
(MSE, RMSE, relMSE, their reference-noise corrections, the relative noise of a variance image),
:mod:`~.ssim`, :mod:`~.flip`, :mod:`~.bias` (bias and variance over seeds), :mod:`~.convergence`
(slope, efficiency, time to error) and :mod:`~.specs` (the metrics a summary reports). Images are
linear radiance, ``(H, W)`` or ``(H, W, C)``; all images passed together must have the same shape
(no broadcasting). ``var`` images hold the variance of one sample (the pixel mean's at ``N`` spp
is ``var / N``). ``nan_policy`` has scipy's meaning: ``'propagate'`` (default: a NaN pixel is a bug,
kept visible), ``'omit'`` (pixel-channels where any input is NaN are left out) or ``'raise'``;
infinities propagate.

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
from .errors import mse, mse_corrected, relative_noise, relmse, relmse_corrected, rmse
from .flip import FLIP_PACKAGE, flip, flip_available
from .specs import COST_FIELDS, DEFAULT_METRIC, METRICS, SPECS, MetricSpec, cost_status, require_metric, view
from .ssim import ssim

__all__ = [
    "mse", "rmse", "relmse", "mse_corrected", "relmse_corrected", "relative_noise",
    "exposure_from_reference", "to_display", "ssim", "flip", "flip_available", "FLIP_PACKAGE",
    "BiasVariance", "bias_variance",
    "SlopeFit", "convergence_slope",
    "efficiency", "time_to_error",
    "RELMSE_EPS", "LUMINANCE_WEIGHTS",
    "MetricSpec", "SPECS", "METRICS", "DEFAULT_METRIC", "COST_FIELDS", "require_metric", "cost_status", "view",
]
