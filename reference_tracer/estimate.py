"""``ImageEstimate``: a Monte Carlo image with its statistics, whoever rendered it.

Our renders (:class:`reference_tracer.RenderResult`), Mitsuba's
(:class:`mitsuba_scenes.MitsubaRender`) and cached references
(:class:`benchmarks.references.Reference`) all carry the same four things: the per-pixel
mean, the per-pixel *per-sample* variance, the samples per pixel behind them and where
they came from. They share this base so that metrics, the gate and the store can take any
of them alike.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["ImageEstimate", "SampleMoments"]


@dataclass(kw_only=True)
class ImageEstimate:
    """A per-pixel Monte Carlo estimate.

    Attributes
    ----------
    mean : (H, W, 3) ndarray
        Per-pixel mean radiance (linear).
    variance : (H, W, 3) ndarray
        Per-pixel *per-sample* variance; ``variance / spp`` is the variance of ``mean``.
    spp : int
        Samples per pixel behind ``mean``.
    seconds : float
        Wall time spent rendering it (0 when unknown or not rendered).
    source : str
        Who made it, in one line: ``"ours"``, ``"mitsuba"``, ``"closed form"``, ...

    Examples
    --------
    >>> import numpy as np
    >>> e = ImageEstimate(mean=np.ones((2, 3, 3)), variance=np.full((2, 3, 3), 4.0), spp=16)
    >>> (e.height, e.width), e.noise
    ((2, 3), 0.25)
    """

    mean: np.ndarray = field(repr=False)
    variance: np.ndarray = field(repr=False)
    spp: int
    seconds: float = 0.0
    source: str = ""

    @property
    def width(self) -> int:
        return int(self.mean.shape[1])

    @property
    def height(self) -> int:
        return int(self.mean.shape[0])

    @property
    def noise(self) -> float:
        """Mean variance of the pixel means, ``mean(variance) / spp``."""
        return float(np.mean(self.variance, dtype=np.float64) / self.spp)


@dataclass(kw_only=True)
class SampleMoments:
    """Per-pixel central moments of the samples behind an estimate: its tail diagnostics.

    Heavy-tailed pixels (a rare path carries most of the value) make tests that assume a
    normal pixel mean invalid at low spp; the third and fourth cumulants tell how far from
    normal a mean of ``n`` such samples is (its skewness is ``skewness / sqrt(n)``, its
    excess kurtosis ``excess_kurtosis / n``), and ``max`` how much one sample weighs.

    Attributes
    ----------
    n : int
        Samples per pixel.
    m2, m3, m4 : (H, W, 3) float64
        Central moments ``mean((x - mean)^k)`` (divided by ``n``, not ``n - 1``).
    max : (H, W, 3) float64
        The largest sample of each pixel-channel.

    Examples
    --------
    >>> import numpy as np
    >>> x = np.array([0.0, 0.0, 0.0, 4.0])  # one pixel-channel, four samples
    >>> m = SampleMoments.from_shifted_sums(4, d=[x.sum(), (x**2).sum(), (x**3).sum(), (x**4).sum()],
    ...                                     max=x.max())
    >>> float(m.m2), float(m.m3), round(float(m.skewness), 6)
    (3.0, 6.0, 1.154701)
    """

    n: int
    m2: np.ndarray = field(repr=False)
    m3: np.ndarray = field(repr=False)
    m4: np.ndarray = field(repr=False)
    max: np.ndarray = field(repr=False)

    @classmethod
    def from_shifted_sums(cls, n: int, *, d, max) -> "SampleMoments":
        """From power sums ``d[k-1] = sum((x - shift)^k)``, k = 1..4, about any per-pixel
        shift (the core uses each pixel's first sample; central moments do not depend on it)."""
        n = int(n)
        d1, d2, d3, d4 = (np.asarray(v, dtype=np.float64) / n for v in d)
        m2 = np.maximum(d2 - d1 * d1, 0.0)
        m3 = d3 - 3.0 * d1 * d2 + 2.0 * d1 ** 3
        m4 = np.maximum(d4 - 4.0 * d1 * d3 + 6.0 * d1 * d1 * d2 - 3.0 * d1 ** 4, 0.0)
        return cls(n=n, m2=m2, m3=m3, m4=m4, max=np.asarray(max, dtype=np.float64))

    @property
    def kappa4(self) -> np.ndarray:
        """Fourth cumulant per sample, ``m4 - 3 m2^2`` (0 for a normal distribution)."""
        return self.m4 - 3.0 * self.m2 * self.m2

    @property
    def skewness(self) -> np.ndarray:
        """Per-sample skewness ``m3 / m2^1.5`` (0 where ``m2 == 0``)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(self.m2 > 0, self.m3 / np.where(self.m2 > 0, self.m2, 1.0) ** 1.5, 0.0)

    @property
    def excess_kurtosis(self) -> np.ndarray:
        """Per-sample excess kurtosis ``m4 / m2^2 - 3`` (0 where ``m2 == 0``)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(self.m2 > 0, self.m4 / np.where(self.m2 > 0, self.m2, 1.0) ** 2 - 3.0, 0.0)
