"""Do two renders of one scene agree? The two figures of the published-scene checks.

Per pixel-channel ``z = (x - y) / sqrt(var_x / n_x + var_y / n_y + (1e-5 y)^2)`` (the last
term only where there is noise), per channel ``Z = sum(x - y) / sqrt(Var(sum x) + Var(sum y))``.
The renders agree when every ``|Z| <= 4``, at most 1% of the pixel values have ``|z| > 4`` and
no value differs where neither render has noise: a coarse screen, not the gate. A filtered
render's variances come from its samples (:mod:`benchmarks.gate.filtered`); one that keeps no
samples (Mitsuba's) takes its sum's variance as its pixels' over the filter's variance reduction.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .filtered import filter_weights, filtered_moments

__all__ = ["Agreement", "agreement", "Z_LIMIT", "SHARE_LIMIT"]

#: The largest |whole-image z| and share of |pixel z| > Z_LIMIT of agreeing renders.
Z_LIMIT = 4.0
SHARE_LIMIT = 0.01
#: Relative float32 rounding added to a noisy pixel's standard error.
RELATIVE_ROUNDING = 1e-5


@dataclass(frozen=True)
class Agreement:
    """``global_z`` per channel; ``share`` of pixel values with ``|z| > 4``; the ``z`` map;
    ``spreadless``: values that differ beyond rounding where neither render has spread."""

    global_z: tuple
    share: float
    z: np.ndarray
    spreadless: int = 0

    @property
    def agrees(self) -> bool:
        return (max(abs(g) for g in self.global_z) <= Z_LIMIT and self.share <= SHARE_LIMIT
                and self.spreadless == 0)

    def describe(self) -> str:
        zs = ", ".join(f"{g:+.2f}" for g in self.global_z)
        out = f"global z {zs}; {100 * self.share:.2f}% of pixel values |z| > {Z_LIMIT:g}"
        return out + (f"; {self.spreadless} pixel value(s) differ where neither render has spread"
                      if self.spreadless else "")


def agreement(ours, theirs, *, pixel_filter=None) -> Agreement:
    """The figures of :class:`Agreement` for two estimates (``mean``, per-sample ``variance``,
    ``spp``) of one image; with a tent or Gaussian ``pixel_filter`` ``ours`` carries ``pixel_samples``.

    Examples
    --------
    >>> import numpy as np
    >>> from reference_tracer import ImageEstimate
    >>> a = ImageEstimate(mean=np.full((4, 4, 3), 1.0), variance=np.full((4, 4, 3), 4.0), spp=16)
    >>> agreement(a, a).agrees
    True
    """
    x, y = (np.asarray(e.mean, dtype=np.float64) for e in (ours, theirs))
    vx, vy = (np.asarray(e.variance, dtype=np.float64) for e in (ours, theirs))
    nx, ny = float(ours.spp), float(theirs.spp)
    sum_x, sum_y = vx / nx, vy / ny
    if pixel_filter is not None and not pixel_filter.is_box:
        samples = getattr(ours, "pixel_samples", None)
        if samples is None:
            raise ValueError("agreement: a filtered render of ours needs its pixel_samples")
        fw = filter_weights(pixel_filter)
        m2, _, _ = filtered_moments(fw, mean=samples.mean, variance=samples.variance, filtered_mean=x)
        vx = m2
        sum_x = np.asarray(samples.variance, dtype=np.float64) / nx
        sum_y = vy / ny / fw.variance_ratio
    se2 = vx / nx + vy / ny
    se = np.sqrt(np.where(se2 > 0, se2 + (RELATIVE_ROUNDING * np.abs(y)) ** 2, 0.0))
    d = x - y
    z = np.where(se > 0, d / np.where(se > 0, se, 1.0), 0.0)
    total = np.sqrt(sum_x.sum(axis=(0, 1)) + sum_y.sum(axis=(0, 1)))
    glob = tuple(float(d[..., c].sum() / total[c]) if total[c] > 0 else 0.0 for c in range(d.shape[2]))
    tol = RELATIVE_ROUNDING * np.maximum(1.0, np.maximum(np.abs(x), np.abs(y)))
    spreadless = int(((se == 0) & (np.abs(d) > tol)).sum())
    return Agreement(global_z=glob, share=float((np.abs(z) > Z_LIMIT).mean()), z=z, spreadless=spreadless)
