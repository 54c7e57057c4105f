"""When may a statistic of a heavy-tailed estimator be tested? The gate's tail rules.

Monte Carlo pixel samples are often heavy-tailed; a sum of them (a pixel mean, a tile, the
image) is then far from normal at a modest budget, and a normal or Student-t p-value at
the small levels a corrected family of tests needs is wrong by orders of magnitude. From
the estimator's own moments (its tail reference, :mod:`benchmarks.tails`) this module
bounds that error with the one-term Edgeworth expansion (:func:`edgeworth_error`), says
how many spp would make it small (:func:`spp_needed`) and gives the pixel level's shape
(:func:`pixel_shape`). ``benchmarks/STATISTICS.md`` has the method and its measured
false-alarm rates.
"""
from __future__ import annotations

import math

import numpy as np
from scipy import stats
from scipy.ndimage import uniform_filter

__all__ = ["DEFAULT_VALIDITY", "edgeworth_error", "spp_needed", "tail_moments", "pixel_shape",
           "neighbourhood_floor"]

#: Largest relative error of the normal tail probability at a level's critical value
#: (:func:`edgeworth_error`) for a statistic to be tested; tested p-values are inflated by
#: their bound, so up to 1 (a true tail up to twice the normal one) the level still holds
#: (``benchmarks/STATISTICS.md``).
DEFAULT_VALIDITY = 1.0


def neighbourhood_floor(v: np.ndarray, size: int) -> np.ndarray:
    """``max(v, mean of v over the size x size neighbourhood)`` per channel."""
    pooled = np.stack([uniform_filter(v[..., c], size=size, mode="nearest") for c in range(v.shape[2])], axis=-1)
    return np.maximum(v, pooled)


def edgeworth_error(z, g1, g2):
    """Relative error bound of the normal upper tail ``Q(z)`` for a statistic with skewness
    ``g1`` and excess kurtosis ``g2``, from the one-term Edgeworth expansion
    ``P(Z > z) = Q(z) + phi(z) (g1 He2 / 6 + g2 He3 / 24 + g1^2 He5 / 72) + ...``:
    ``phi(z) / Q(z) * (|g1| |He2(z)| / 6 + |g2| |He3(z)| / 24 + g1^2 |He5(z)| / 72)``
    (Hermite polynomials ``He2 = z^2 - 1``, ``He3 = z^3 - 3z``, ``He5 = z^5 - 10z^3 + 15z``).

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
    statistic's skewness ``g1`` and excess kurtosis ``g2`` at ``spp`` (they fall as
    ``1/sqrt(n)`` and ``1/n``).

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
    """Skewness and excess kurtosis of each pixel *mean* for the pixel level.

    The worse of the pixel's own per-sample shape and its 3x3 neighbourhood's, divided by
    ``sqrt(n)`` and ``n``: the pixel-level variance borrows the neighbours' (larger)
    noise, and without this a pixel whose own samples are dominated by rare paths would
    look normal.
    """
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


