"""The statistical decisions of the hard cases: z-tests of images (:func:`image_ztest`) and of
a sample mean against a closed form (:func:`z_check`; the cases accept |z| <= 5)."""
from __future__ import annotations

import math

import numpy as np
from scipy import stats

from reference_tracer.estimate import ImageEstimate

__all__ = ["image_ztest", "constant_ztest", "z_check"]

#: the local test counts pixel values beyond this two-sided level
PIXEL_ALPHA = 1e-3
#: relative floor of a difference's standard deviation: float32 rounding
REL_FLOOR = 1e-6


def image_ztest(mean_a, var_a, n_a, mean_b, var_b=None, n_b=None, *, alpha: float = 1e-4,
                local: bool = True) -> dict:
    """Do two images (or an image and an exact one, ``var_b`` None) have the same expectation?

    Two tests at ``alpha / 2`` each: per channel, the global Z = sum(a - b) / sqrt(sum of the
    variances) (a bias spread over the image), and unless ``local=False`` (heavy tails) the
    count of pixel values with |z| > z(PIXEL_ALPHA) against its binomial quantile. Each
    variance has a floor of (REL_FLOOR * max(|a|, |b|))^2. Returns
    ``passed``, ``z_global``, ``z_global_limit``, ``outliers``, ``outlier_limit`` and more:

    >>> a = np.ones((4, 4, 3))
    >>> image_ztest(a, np.ones_like(a), 16, a)["passed"], image_ztest(a + 1, np.ones_like(a), 16, a)["passed"]
    (True, False)
    """
    a, b = (np.asarray(x, dtype=np.float64) for x in (mean_a, mean_b))
    s2 = np.asarray(var_a, dtype=np.float64) / n_a
    if var_b is not None:
        s2 = s2 + np.asarray(var_b, dtype=np.float64) / n_b
    s2 = s2 + (REL_FLOOR * np.maximum(np.abs(a), np.abs(b))) ** 2
    d = a - b
    a3 = d.reshape(-1, d.shape[-1]) if d.ndim == 3 else d.reshape(-1, 1)
    v3 = s2.reshape(a3.shape)
    with np.errstate(divide="ignore", invalid="ignore"):
        sd = np.sqrt(v3.sum(axis=0))
        zg = np.where(sd > 0, a3.sum(axis=0) / sd, np.where(a3.sum(axis=0) == 0, 0.0, np.inf))
        z = np.where(v3 > 0, a3 / np.sqrt(v3), np.where(a3 == 0, 0.0, np.inf))
    zg_limit = float(stats.norm.isf(alpha / 2 / a3.shape[1] / 2))
    z_pix = float(stats.norm.isf(PIXEL_ALPHA / 2))
    n = a3.size
    outliers = int((np.abs(z) > z_pix).sum())
    limit = int(stats.binom.isf(alpha / 2, n, PIXEL_ALPHA))
    passed = bool(np.all(np.abs(zg) <= zg_limit) and (outliers <= limit or not local))
    return {"passed": passed, "local": local, "z_global": [float(x) for x in zg], "z_global_limit": zg_limit,
            "outliers": outliers, "outlier_limit": limit, "pixel_z": z_pix, "tests": int(n), "alpha": alpha,
            "max_abs_z": float(np.max(np.abs(z))) if n else 0.0}


def constant_ztest(result: ImageEstimate, value: float, *, alpha: float = 1e-4, local: bool = True) -> dict:
    """:func:`image_ztest` of a render (any :class:`~reference_tracer.estimate.ImageEstimate`)
    against an exact constant image ``value``."""
    return image_ztest(result.mean, result.variance, result.spp, np.full(result.mean.shape, value),
                       alpha=alpha, local=local)


def z_check(samples, exact) -> dict:
    """z of the mean of ``samples`` against ``exact``; the standard error has a floor of
    1e-12 |exact| (float64 rounding), so a constant estimator compares exactly.

    >>> z_check([2.0, 2.0, 2.0], 2.0)["z"]
    0.0
    """
    x = np.asarray(samples, dtype=np.float64)
    m, sd = float(x.mean()), float(x.std(ddof=1)) if len(x) > 1 else 0.0
    se = sd / math.sqrt(len(x))
    scale = max(se, 1e-12 * abs(exact))
    z = (m - exact) / scale if scale > 0 else (0.0 if m == exact else math.inf)
    return {"mean": m, "exact": float(exact), "z": float(z), "n": int(len(x)), "se": se}
