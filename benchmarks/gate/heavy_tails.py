"""When may a statistic of a heavy-tailed estimator be tested? The gate's tail rules.

From the estimator's own moments (its tail reference, :mod:`benchmarks.tails`):
:func:`edgeworth_error` bounds the error of the normal tail (one-term Edgeworth expansion),
:func:`spp_needed` says how many spp would make it small, :func:`pixel_shape` gives the pixel
level's shape. The method and its measured false-alarm rates: ``benchmarks/STATISTICS.md``.
"""
from __future__ import annotations

import math

import numpy as np
from scipy import stats
from scipy.ndimage import uniform_filter

__all__ = ["DEFAULT_VALIDITY", "edgeworth_error", "spp_needed", "tail_moments", "pixel_shape",
           "neighbourhood_floor"]

#: Largest :func:`edgeworth_error` at a level's critical value for a statistic to be tested.
DEFAULT_VALIDITY = 1.0


def neighbourhood_floor(v: np.ndarray, size: int) -> np.ndarray:
    """``max(v, mean of v over the size x size neighbourhood)`` per channel."""
    pooled = np.stack([uniform_filter(v[..., c], size=size, mode="nearest") for c in range(v.shape[2])], axis=-1)
    return np.maximum(v, pooled)


def edgeworth_error(z, g1, g2):
    """Relative error bound of the normal upper tail ``Q(z)`` for skewness ``g1`` and excess
    kurtosis ``g2`` (one-term Edgeworth expansion):
    ``phi(z) / Q(z) * (|g1| |He2(z)| / 6 + |g2| |He3(z)| / 24 + g1^2 |He5(z)| / 72)``.

    Examples
    --------
    >>> float(edgeworth_error(3.0, 0.0, 0.0))
    0.0
    >>> round(float(edgeworth_error(3.0, 0.1, 0.0)), 3)
    0.446
    """
    z = np.asarray(z, dtype=np.float64)
    he2, he3, he5 = z * z - 1.0, z ** 3 - 3.0 * z, z ** 5 - 10.0 * z ** 3 + 15.0 * z
    mills = stats.norm.pdf(z) / stats.norm.sf(z)
    g1 = np.abs(g1)
    return mills * (g1 * np.abs(he2) / 6.0 + np.abs(g2) * np.abs(he3) / 24.0 + g1 * g1 * np.abs(he5) / 72.0)


def spp_needed(z: float, g1: float, g2: float, spp: float, validity: float = DEFAULT_VALIDITY) -> int:
    """About how many spp make :func:`edgeworth_error` at ``z`` drop to ``validity``, given the
    shape ``g1``, ``g2`` at ``spp`` (falling as ``1/sqrt(n)`` and ``1/n``).

    Examples
    --------
    >>> spp_needed(3.0, 0.4, 0.0, 100) > 100
    True
    """
    if edgeworth_error(z, g1, g2) <= validity:
        return int(spp)
    lo, hi = 0.0, 64.0  # log2 of the factor
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        f = 2.0 ** mid
        if edgeworth_error(z, g1 / math.sqrt(f), g2 / f) <= validity:
            hi = mid
        else:
            lo = mid
    return int(math.ceil(spp * 2.0 ** hi))


def tail_moments(tails, shape) -> tuple:
    """``(m2, m3, kappa4)`` per sample from a ``SampleMoments``, checked against the image."""
    m2, m3, k4 = (np.asarray(v, dtype=np.float64) for v in (tails.m2, tails.m3, tails.kappa4))
    if m2.ndim == 2:
        m2, m3, k4 = m2[..., None], m3[..., None], k4[..., None]
    if m2.shape != shape:
        raise ValueError(f"tails have shape {m2.shape}, the images {shape}")
    if not (np.all(np.isfinite(m2)) and np.all(np.isfinite(m3)) and np.all(np.isfinite(k4))):
        raise ValueError("tails have non-finite moments")
    if int(tails.n) < 2:
        raise ValueError(f"tails need >= 2 samples per pixel; got {tails.n}")
    return m2, m3, k4


def pixel_shape(m2, m3, k4, *, exact, n_t) -> tuple:
    """Skewness and excess kurtosis of each pixel mean: the worse of the pixel's own per-sample
    shape and its 3x3 neighbourhood's (whose noise the pixel level borrows), over ``sqrt(n)``, ``n``."""
    m2 = np.where(exact, 0.0, m2)

    def shape(s3, s4, s2):
        with np.errstate(divide="ignore", invalid="ignore"):
            ok = s2 > 0
            safe = np.where(ok, s2, 1.0)
            return np.where(ok, np.abs(s3) / safe ** 1.5, 0.0), np.where(ok, np.abs(s4) / safe ** 2, 0.0)

    pool = lambda v: neighbourhood_floor(v, 3)  # noqa: E731
    own = shape(m3, k4, m2)
    nb = shape(pool(np.abs(m3)), pool(np.abs(k4)), pool(m2))
    return np.maximum(own[0], nb[0]) / math.sqrt(n_t), np.maximum(own[1], nb[1]) / n_t
