"""What one gate comparison found: :class:`GateResult`, the value of :func:`benchmarks.gate.compare`.

What a verdict carries, its one-line summary and its JSON form; how it is computed is
in :mod:`benchmarks.gate.statistics`.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["LEVELS", "GateResult"]

#: The four test levels of :func:`benchmarks.gate.compare`, finest first (a tie for the
#: worst level goes to the finer one); ``correlation`` tests that neighbouring pixels'
#: errors are independent (:mod:`benchmarks.gate.correlation`).
LEVELS = ("pixel", "tile", "image", "correlation")


@dataclass
class GateResult:
    """Verdict and statistics of :func:`benchmarks.gate.compare`.

    Attributes
    ----------
    verdict : {'pass', 'fail', 'undetermined'}
        ``fail``: ``p_value < alpha``. ``undetermined``: no failure, but the whole-image
        statistic of some channel could not be tested at this budget (its normal
        approximation does not hold: heavy tails); ``reason`` says why and
        ``spp_needed`` about how many spp would decide. ``pass`` otherwise.
        ``passed`` and ``failed`` are the same as properties.
    reason : str
        One line: why this verdict.
    alpha : float
    p_value : float
        Gate p-value: Bonferroni over the four levels of the Sidak-adjusted level
        p-values, ``min(1, 4 * min(level_p.values()))``.
    level_p : dict
        ``{'pixel': p, 'tile': p, 'image': p, 'correlation': p}``, each Sidak-adjusted
        within its level (``correlation``: over the channels; 1 when untested).
    failed_levels : list of str
        Levels with ``4 * level_p < alpha`` (the levels that fail the gate).
    n_tests : dict
        Number of tests per level that were made: statistics with evidence (noise, or a
        difference between noiseless values) whose normal approximation holds.
    n_candidates : dict
        Statistics with evidence per level, tested or not; ``n_candidates - n_tests`` were
        left out as too heavy-tailed at this budget.
    pixel_p : ndarray, shape (H, W, C)
        Raw (unadjusted) two-sided per-pixel-channel p-values.
    p_map : ndarray, shape (H, W)
        ``pixel_p`` minimum over channels: the p-value image to save for failures
        (e.g. as ``-log10``).
    pixel_t : ndarray, shape (H, W, C)
        Per-pixel Welch statistic (0 where the pixel carries no evidence, +-inf for
        zero-variance differences and non-finite test pixels).
    tile_p, tile_z : ndarray, shape (ceil(H/t), ceil(W/t), C)
        Raw two-sided p-value and statistic per tile and channel for the first (finest)
        tile size ``t``.
    image_p, image_z : ndarray, shape (C,)
        Raw p-value and statistic of the whole-image test per channel.
    max_abs_t : float
        Largest finite-or-infinite |t| among pixels.
    worst_pixel : tuple (row, col, channel)
        Pixel-channel with the smallest p-value (largest |t| on ties).
    worst_tile : tuple (row0, col0, row1, col1)
        Pixel box (end-exclusive) of the tile, of any size, with the smallest p-value.
    worst_region : tuple (row0, col0, row1, col1)
        Box of the strongest evidence: the worst pixel, the worst tile or the whole
        image, whichever level has the smallest p-value.
    worst_level : str
        The level of ``worst_region``.
    relative_bias : float
        Estimated relative bias of the whole image, ``sum(x - r) / sum(r)`` (NaN if
        ``sum(r) == 0``): e.g. -0.01 for a render 1% too dark.
    relative_bias_se : float
        Standard error of ``relative_bias`` (from the same variances as the tests).
    relative_bias_channels : ndarray, shape (C,)
    worst_tile_relative_bias : float
        ``sum(x - r) / sum(r)`` inside ``worst_tile``, all channels.
    n_nonfinite : int
        Non-finite test pixel-channels (each a failure).
    min_detectable_bias : float
        Power: the relative bias of the whole image the image level would catch with
        probability 0.8 at this budget (most sensitive channel; NaN when untestable).
    min_detectable_tile_bias : float
        The same for one 8x8 tile (median over the testable tiles; NaN if none).
    spp_needed : int or None
        ``undetermined``: about how many spp would make the image level testable.
    neighbour_correlation : ndarray, shape (C,)
        Mean product of neighbouring pixels' standardised differences per channel: about
        0 (+- 1/sqrt(number of pairs)) when pixels are independent, positive when their
        errors move together (NaN where the correlation level was not tested, e.g.
        without tail diagnostics).
    tails : bool
        Whether tail diagnostics of the same estimator were used (``compare(tails=...)``).
    """

    verdict: str
    reason: str
    alpha: float
    p_value: float
    level_p: dict
    failed_levels: list
    n_tests: dict
    n_candidates: dict
    pixel_p: np.ndarray = field(repr=False)
    p_map: np.ndarray = field(repr=False)
    pixel_t: np.ndarray = field(repr=False)
    tile_p: np.ndarray = field(repr=False)
    tile_z: np.ndarray = field(repr=False)
    image_p: np.ndarray = field(repr=False)
    image_z: np.ndarray = field(repr=False)
    max_abs_t: float
    worst_pixel: tuple
    worst_tile: tuple
    worst_region: tuple
    worst_level: str
    relative_bias: float
    relative_bias_se: float
    relative_bias_channels: np.ndarray = field(repr=False)
    worst_tile_relative_bias: float
    n_nonfinite: int
    min_detectable_bias: float = float("nan")
    min_detectable_tile_bias: float = float("nan")
    spp_needed: int | None = None
    neighbour_correlation: np.ndarray = field(default_factory=lambda: np.full(3, np.nan), repr=False)
    tails: bool = False

    @property
    def passed(self) -> bool:
        return self.verdict == "pass"

    @property
    def failed(self) -> bool:
        return self.verdict == "fail"

    def summary(self) -> str:
        """One line for a CLI table or failure message."""
        verdict = self.verdict.upper()
        r0, c0, r1, c1 = self.worst_region
        lv = ", ".join(f"{k} p={v:.3g}" for k, v in self.level_p.items())
        msg = (f"{verdict} (p={self.p_value:.3g}, alpha={self.alpha:g}; {lv}); "
               f"relative bias {self.relative_bias:+.2%} +- {self.relative_bias_se:.2%} over the image")
        if self.verdict == "undetermined":
            msg += f"; {self.reason}"
        if self.failed:
            msg += (f"; strongest evidence at the {self.worst_level} level in rows {r0}-{r1 - 1}, "
                    f"cols {c0}-{c1 - 1} (worst tile relative bias "
                    f"{self.worst_tile_relative_bias:+.2%})")
        if self.n_nonfinite:
            msg += f"; {self.n_nonfinite} non-finite test pixel-channels"
        return msg

    def to_dict(self) -> dict:
        """JSON-friendly scalars (no images)."""
        return {
            "verdict": self.verdict, "reason": self.reason, "passed": bool(self.passed),
            "alpha": self.alpha, "p_value": self.p_value,
            "level_p": dict(self.level_p), "failed_levels": list(self.failed_levels),
            "n_tests": dict(self.n_tests), "n_candidates": dict(self.n_candidates), "max_abs_t": self.max_abs_t,
            "worst_pixel": list(self.worst_pixel), "worst_tile": list(self.worst_tile),
            "worst_region": list(self.worst_region), "worst_level": self.worst_level,
            "relative_bias": self.relative_bias, "relative_bias_se": self.relative_bias_se,
            "relative_bias_channels": [float(v) for v in self.relative_bias_channels],
            "worst_tile_relative_bias": self.worst_tile_relative_bias,
            "n_nonfinite": self.n_nonfinite,
            "min_detectable_bias": self.min_detectable_bias,
            "min_detectable_tile_bias": self.min_detectable_tile_bias,
            "spp_needed": self.spp_needed,
            "neighbour_correlation": [None if not np.isfinite(v) else float(v) for v in self.neighbour_correlation],
            "tails": self.tails,
        }
