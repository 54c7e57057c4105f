"""The statistics of a tent- or Gaussian-filtered pixel, from the samples drawn inside each pixel.

A filtered pixel is a ratio of weighted sums over the samples of its neighbourhood; linearised
(the delta method) it is a mean of independent terms, and its moments per sample are

    m2_i = sum_q [F_2(q - i) v_q + (F_2 - F_1^2)(q - i) (mu_q - p_i)^2] / W_i^2
    m3_i = sum_q F_3(q - i) m3_q / W_i^3,    k4_i = sum_q F_4(q - i) k4_q / W_i^4

with ``F_k(d)`` the mean ``k``-th power of a sample's normalised weight over the pixel at offset
``d`` (:func:`filter_weights`), ``W_i = sum_q F_1(q - i)`` and the moments of the samples drawn
inside pixel ``q`` (mean ``mu_q``, variance ``v_q``, ...). See ``benchmarks/STATISTICS.md``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

__all__ = ["FilterWeights", "filter_weights", "filtered_moments"]

# Gauss-Legendre nodes per pixel and axis: ~1e-6 relative on the weights' moments despite the kinks
_NODES = 64


@dataclass(frozen=True)
class FilterWeights:
    """``F[k - 1]`` (``k`` = 1..4): ``F_k`` over the offsets, arrays of shape ``(2R+1, 2R+1)``."""

    F: tuple
    radius: int

    @property
    def variance_ratio(self) -> float:
        """``sum F_2``: the filter's variance reduction where the noise is even (1 for a box)."""
        return float(self.F[1].sum())

    def correlate(self, image: np.ndarray, k: int) -> np.ndarray:
        """``sum_q F_k(q - i) image_q`` for every pixel ``i`` (``k`` = 0: ``F_2 - F_1^2``)."""
        w = self.F[1] - self.F[0] ** 2 if k == 0 else self.F[k - 1]
        return np.stack([ndimage.correlate(image[..., c], w, mode="constant", cval=0.0)
                         for c in range(image.shape[2])], axis=-1)


def _weight_1d(kind: str, radius: float, stddev: float | None):
    if kind == "tent":
        return lambda x: np.maximum(0.0, 1.0 - np.abs(x) / radius)
    if kind == "gaussian":
        a = -0.5 / (stddev * stddev)
        return lambda x: np.maximum(0.0, np.exp(a * x * x) - math.exp(a * radius * radius))
    raise ValueError(f"filter_weights: no weights for a {kind!r} filter (box pixels are plain means)")


def filter_weights(filt) -> FilterWeights:
    """The weights' moments of a ``reference_tracer.Filter`` (tent or Gaussian).

    Examples
    --------
    >>> import reference_tracer as rt
    >>> fw = filter_weights(rt.Filter("tent"))
    >>> round(float(fw.F[0].sum()), 6), fw.radius
    (1.0, 2)
    """
    g = _weight_1d(filt.kind, float(filt.radius), filt.stddev)
    R = int(math.ceil(float(filt.radius) + 0.5))
    x, wq = np.polynomial.legendre.leggauss(_NODES)
    offsets = np.arange(-R, R + 1, dtype=np.float64)
    # samples of the pixel at offset d lie in [d - 1/2, d + 1/2]; the pixel's centre at 0
    pts = offsets[:, None] + 0.5 * x[None, :]
    vals = g(pts)
    integral = float(np.sum(vals @ (0.5 * wq)))  # the 1-D weight per unit length
    moments = []
    for k in range(1, 5):
        m1d = (vals ** k) @ (0.5 * wq) / integral ** k  # E[(g / int g)^k] per offset
        moments.append(np.outer(m1d, m1d))
    return FilterWeights(F=tuple(moments), radius=R)


def filtered_moments(weights: FilterWeights, *, mean, variance, filtered_mean, m3=None, k4=None) -> tuple:
    """``(m2, m3, k4)`` per sample of the filtered pixels from the moments of the samples drawn
    inside each pixel, all ``(H, W, C)`` (``m3``/``k4`` None give None)."""
    mean, variance, filtered_mean = (np.asarray(v, dtype=np.float64) for v in (mean, variance, filtered_mean))
    W = weights.correlate(np.ones_like(mean), 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = np.where(W > 0, 1.0 / np.where(W > 0, W, 1.0), 0.0)
    p = filtered_mean
    # sum_q (F_2 - F_1^2)(q - i) (mu_q - p_i)^2, expanded
    spread = (weights.correlate(mean * mean, 0) - 2.0 * p * weights.correlate(mean, 0)
              + p * p * weights.correlate(np.ones_like(mean), 0))
    m2 = (weights.correlate(variance, 2) + np.maximum(spread, 0.0)) * inv ** 2
    m3f = None if m3 is None else weights.correlate(np.asarray(m3, dtype=np.float64), 3) * inv ** 3
    k4f = None if k4 is None else weights.correlate(np.asarray(k4, dtype=np.float64), 4) * inv ** 4
    return m2, m3f, k4f
