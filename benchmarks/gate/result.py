"""What one gate comparison found: :class:`GateResult`, the value of :func:`benchmarks.gate.compare`."""
from __future__ import annotations

from dataclasses import dataclass, field, fields

import numpy as np

__all__ = ["LEVELS", "GateResult"]

#: The four test levels of :func:`benchmarks.gate.compare`, finest first (a tie for the worst goes to the finer).
LEVELS = ("pixel", "tile", "image", "correlation")


@dataclass
class GateResult:
    """Verdict and statistics of :func:`benchmarks.gate.compare`.

    Attributes
    ----------
    verdict, reason : str
        ``'fail'`` (``p_value < alpha``), ``'undetermined'`` (no failure, but the whole-image
        statistic of some channel could not be tested; ``spp_needed`` would decide) or
        ``'pass'``; ``reason``, one line why.
    p_value, level_p, failed_levels : float, dict, list
        ``min(1, 4 * min(level_p.values()))``; per level the Sidak-adjusted p-value (1 when
        untested); the levels with ``4 * level_p < alpha``.
    n_tests, n_candidates : dict
        Per level, the statistics tested and those with evidence (tested or too heavy-tailed).
    pixel_p, pixel_t : ndarray, shape (H, W, C)
        Raw two-sided p-value and Welch statistic per pixel-channel (``p_map``: the minimum
        p over channels, (H, W)).
    worst_pixel, worst_tile, worst_region, worst_level
        Pixel-channel with the smallest p; pixel box (end-exclusive) of the worst tested
        tile of any size; box of the strongest evidence and its level.
    relative_bias, relative_bias_se, relative_bias_channels, worst_tile_relative_bias : float
        ``sum(x - r) / sum(r)`` over the image (with its standard error), per channel and
        inside ``worst_tile`` (NaN where ``sum(r) == 0``).
    n_nonfinite : int
        Non-finite test pixel-channels (each a failure).
    min_detectable_bias, min_detectable_tile_bias : float
        Power: the relative bias the image level (most sensitive channel) or an 8x8 tile
        (median) would catch with probability 0.8; NaN when untestable.
    neighbour_correlation : ndarray, shape (C,)
        Mean product of neighbouring pixels' standardised differences (about 0 for
        independent pixels; NaN where the correlation level was not tested).
    tails : bool
        Whether tail diagnostics of the same estimator were used.
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

    def to_dict(self) -> dict:
        """JSON-friendly scalars (no images)."""
        out = {f.name: getattr(self, f.name) for f in fields(self) if f.repr}
        out = {k: list(v) if isinstance(v, tuple) else dict(v) if isinstance(v, dict) else v for k, v in out.items()}
        return {**out, "passed": self.passed,
                "relative_bias_channels": [float(v) for v in self.relative_bias_channels],
                "neighbour_correlation": [float(v) if np.isfinite(v) else None for v in self.neighbour_correlation]}
