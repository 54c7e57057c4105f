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

__all__ = ["ImageEstimate"]


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
