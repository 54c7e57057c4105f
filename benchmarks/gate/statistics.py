"""The gate's test: does a render converge to the same image as a reference?

:func:`compare` takes per-pixel means and per-sample variances (``rt.render``'s; for Mitsuba
the between-batch variance times the batch spp) with their sample counts, tests four levels
(pixel, tile, image, neighbour correlation: :mod:`~benchmarks.gate.levels`), Sidak within a
level and Bonferroni over the levels, and returns a three-valued :class:`GateResult` (its verdict,
statistics and JSON form). With
the tail diagnostics of the same estimator (``tails=``) each statistic is tested only where
its normal approximation holds. :func:`judge` applies it to two renders of one estimator
(``rtbench compare``'s verdict). The method: ``benchmarks/STATISTICS.md``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, fields

import numpy as np
from scipy import stats

from ..constants import GATE_ALPHA
from .inputs import prepare, tail_moments
from .levels import (DEFAULT_VALIDITY, Level, correlation_level, family_p, image_level, pixel_level, spp_needed,
                     tile_level)

__all__ = ["compare", "GateResult", "LEVELS", "EstimatorKnowledge", "judge", "POWER", "POWER_TILE"]

#: The probability of detection quoted by the minimum detectable bias.
POWER = 0.8
#: Tile side of the quoted tile power.
POWER_TILE = 8


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


def compare(test_mean, test_var, test_spp, ref_mean, ref_var, ref_spp, *,
            alpha: float = GATE_ALPHA, tile=(8, 16, 32), variance_floor: str = "reference",
            var_ddof: int = 0, zero_var_rtol: float = 1e-4, pixel_pool: int = 3, tails=None,
            validity: float = DEFAULT_VALIDITY, pixel_samples=None, filter_weights=None) -> GateResult:
    """Test whether a render and a reference have the same expectation.

    Parameters
    ----------
    test_mean, test_var, test_spp : array_like (H, W) or (H, W, C), and int >= 2
        Pixel means, per-sample variances and samples per pixel of the render under test.
    ref_mean, ref_var, ref_spp : the same shape, and int >= 2
        The reference's.
    alpha : float
        False-alarm rate of the comparison on unbiased renders (upper bound).
    tile : int or sequence of int
        Tile side(s) of the tile level, all in one Sidak family.
    variance_floor : {'reference', 'none'}
        ``'reference'``: the test's per-sample variance is floored at the tails' variance, else
        at the reference's (``max(v_x, v_r)``); ``'none'``: plain Welch.
    var_ddof : int
        ddof of the given variances (0: de-biased by ``n / (n - 1)``).
    zero_var_rtol, pixel_pool, validity : keyword-only
        Relative tolerance of "equal means" where both variances are zero; side of the
        neighbourhood whose mean variance floors each pixel's (1 disables); largest
        :func:`edgeworth_error` at which a statistic is still tested.
    tails : reference_tracer.SampleMoments, optional
        Per-pixel central moments of the *same estimator* at a high budget.
    pixel_samples, filter_weights : optional
        A tent- or Gaussian-filtered test render: the ``(mean, variance)`` of the samples drawn
        inside each pixel and the filter's weights (:mod:`benchmarks.gate.filtered`).

    Returns
    -------
    GateResult

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> ref = np.full((16, 16, 3), 0.5)
    >>> var = np.full_like(ref, 0.25)
    >>> test = ref + rng.standard_normal(ref.shape) * np.sqrt(0.25 / 64)
    >>> compare(test, var, 64, ref, var, 4096).verdict
    'pass'
    >>> compare(test * 0.9, var, 64, ref, var, 4096).failed_levels
    ['tile', 'image']
    """
    tiles = _check_options(alpha, tile, pixel_pool, variance_floor, validity)
    if (pixel_samples is None) != (filter_weights is None):
        raise ValueError("pixel_samples and filter_weights go together (a filtered test render)")
    d = prepare(test_mean, test_var, test_spp, ref_mean, ref_var, ref_spp, var_ddof=var_ddof,
                 zero_var_rtol=zero_var_rtol, variance_floor=variance_floor, tails=tails,
                 pixel_samples=pixel_samples, filter_weights=filter_weights)
    crit = dict(alpha_level=alpha / len(LEVELS), validity=validity)
    pix = pixel_level(d, pixel_pool, **crit)
    # pixels with no noise and equal means contribute exactly nothing to the sums
    diff = np.where(pix.testable & ~d.bad, d.diff, 0.0)
    tile_levels = [tile_level(d, diff, ts, **crit) for ts in tiles]
    img = image_level(d, diff, **crit)
    corr, rho = correlation_level(pix, tails is not None and filter_weights is None, **crit)

    # ---- combine: Sidak within a level (over the tested statistics), Bonferroni over the levels
    levels = {"pixel": [pix], "tile": tile_levels, "image": [img], "correlation": [corr]}
    family = {k: family_p(lvs) for k, lvs in levels.items()}
    level_p, n_tests = ({k: v[i] for k, v in family.items()} for i in (0, 1))
    n_cand = {k: int(sum(lv.testable.sum() for lv in lvs)) for k, lvs in levels.items()}
    p_value = min(1.0, len(LEVELS) * min(level_p.values()))
    failed = [k for k, v in level_p.items() if len(LEVELS) * v < alpha]
    verdict, reason, needed = _decide(failed, img, d.n_t, validity, rho)
    # ---- where and how large
    (wy, wx, wc), worst_tile, worst_level, worst_region = locate(d, pix, tiles, tile_levels, level_p)
    rel, rel_se, rel_c, rel_tile = relative_bias(d, worst_tile)
    mdb, mdb_tile = power(img, dict(zip(tiles, tile_levels)).get(POWER_TILE))
    return GateResult(
        verdict=verdict, reason=reason, alpha=float(alpha), p_value=float(p_value),
        level_p=level_p, failed_levels=failed, n_tests=n_tests, n_candidates=n_cand,
        pixel_p=pix.p, p_map=pix.p.min(axis=2), pixel_t=pix.z,
        max_abs_t=float(np.abs(pix.z).max()), worst_pixel=(wy, wx, wc),
        worst_tile=worst_tile, worst_region=tuple(int(v) for v in worst_region),
        worst_level=worst_level, relative_bias=rel, relative_bias_se=rel_se,
        relative_bias_channels=rel_c, worst_tile_relative_bias=rel_tile, n_nonfinite=int(d.bad.sum()),
        min_detectable_bias=mdb, min_detectable_tile_bias=mdb_tile, spp_needed=needed,
        neighbour_correlation=rho, tails=tails is not None)


def _check_options(alpha, tile, pixel_pool, variance_floor, validity) -> tuple:
    """The tile sizes as a tuple of int, after checking :func:`compare`'s options."""
    if not 0 < alpha < 1:
        raise ValueError(f"alpha must be in (0, 1); got {alpha}")
    tiles = tuple(int(t) for t in np.atleast_1d(tile))
    if not tiles or min(tiles) < 1:
        raise ValueError(f"tile sizes must be >= 1; got {tile}")
    if isinstance(pixel_pool, bool) or not isinstance(pixel_pool, (int, np.integer)) or pixel_pool < 1:
        raise ValueError(f"pixel_pool must be an integer >= 1; got {pixel_pool!r}")
    if variance_floor not in ("reference", "none"):
        raise ValueError(f"variance_floor must be 'reference' or 'none'; got {variance_floor!r}")
    if not (isinstance(validity, (int, float)) and validity > 0):
        raise ValueError(f"validity must be a number > 0; got {validity!r}")
    return tiles


def _decide(failed: list, img: Level, n_t: float, validity: float, rho) -> tuple:
    """``(verdict, reason, spp_needed)``: a failure needs one tested statistic; a pass needs
    the whole image tested in every channel with evidence; otherwise undetermined."""
    if failed:
        reason = f"significant difference at the {', '.join(failed)} level"
        if "correlation" in failed:
            reason += (f" (neighbouring pixels' errors correlate at {float(np.nanmax(rho)):+.3f}: pixels that "
                       f"share random numbers, or a bias that varies smoothly over the image)")
        return "fail", reason, None
    untested = img.testable & ~img.valid
    if not untested.any():
        return "pass", "no significant difference", None
    g1, g2 = np.abs(img.g1[untested]), np.abs(img.g2[untested])
    needed = max(spp_needed(img.z_crit, a, b, n_t, validity) for a, b in zip(g1, g2))
    return ("undetermined", f"heavy-tailed: the image mean is too far from normal at {int(n_t)} spp "
            f"(skewness {g1.max():.2g}, excess kurtosis {g2.max():.2g}); needs about {needed} spp", needed)


def argworst(p: np.ndarray, s: np.ndarray) -> tuple:
    """Index of the smallest ``p``, ties broken by the largest ``|s|``."""
    flat = np.lexsort((-np.abs(s).ravel(), p.ravel()))[0]
    return tuple(int(i) for i in np.unravel_index(flat, p.shape))


def _tested(lv) -> np.ndarray:
    """``lv.p`` with untested statistics at 2 (never the worst)."""
    return np.where(lv.valid, lv.p, 2.0)


def worst_tile_box(tiles, tile_levels, H: int, W: int) -> tuple:
    """Pixel box ``(row0, col0, row1, col1)`` of the tested tile of any size with the smallest p."""
    best = None
    for ts, lv in zip(tiles, tile_levels):
        pt = _tested(lv)
        iy, ix, ic = argworst(pt, lv.z)
        key = (pt[iy, ix, ic], -abs(lv.z[iy, ix, ic]))
        if best is None or key < best[0]:
            best = (key, (iy * ts, ix * ts, min(H, (iy + 1) * ts), min(W, (ix + 1) * ts)))
    return best[1]


def locate(d, pix, tiles, tile_levels, level_p: dict) -> tuple:
    """``(worst pixel, worst tile, worst level, worst region)`` (see :class:`GateResult`)."""
    H, W, _ = d.x.shape
    wy, wx, wc = argworst(_tested(pix), pix.z)
    worst_tile = worst_tile_box(tiles, tile_levels, H, W)
    worst_level = min(level_p, key=lambda k: (level_p[k], LEVELS.index(k)))
    worst_region = {"pixel": (wy, wx, wy + 1, wx + 1), "tile": worst_tile,
                    "image": (0, 0, H, W), "correlation": (0, 0, H, W)}[worst_level]
    return (wy, wx, wc), worst_tile, worst_level, worst_region


def relative_bias(d, worst_tile: tuple) -> tuple:
    """``(relative bias, its standard error, per channel, inside worst_tile)``; finite pixels only.

    The standard error assumes independent pixels and bounds the correlation of a pixel's three
    channels from above (Cauchy-Schwarz): it is exact for a grey image and conservative otherwise."""
    good = ~d.bad
    d_all = np.where(good, d.x - d.r, 0.0)
    r_all = np.where(good, d.r, 0.0)
    sum_r_c = r_all.sum(axis=(0, 1))
    with np.errstate(divide="ignore", invalid="ignore"):
        rel_c = np.where(sum_r_c != 0, d_all.sum(axis=(0, 1)) / sum_r_c, np.nan)
    sr = float(r_all.sum())
    rel = float(d_all.sum() / sr) if sr != 0 else math.nan
    var = np.where(good, d.a + d.b if d.fa is None else np.maximum(d.a, d.fa) + d.b, 0.0)
    # a pixel's channels come from the same paths, so their errors correlate (fully in a grey
    # scene): the variance of their sum is at most (sum of the channels' deviations)^2
    pixel_var = np.sqrt(var).sum(axis=2) ** 2
    rel_se = float(math.sqrt(pixel_var.sum()) / abs(sr)) if sr != 0 else math.nan
    y0, x0, y1, x1 = worst_tile
    srt = float(r_all[y0:y1, x0:x1].sum())
    rel_tile = float(d_all[y0:y1, x0:x1].sum() / srt) if srt != 0 else math.nan
    return rel, rel_se, rel_c, rel_tile


def power(img, tile8) -> tuple:
    """Minimum detectable relative bias with probability :data:`POWER`, ``(z_crit + z_power)
    sqrt(var) / |sum r|``, of the image (most sensitive channel) and of a :data:`POWER_TILE` tile
    (median); a noiseless statistic detects any bias beyond its tolerance; NaN if untested."""
    z_pow = float(stats.norm.isf(1.0 - POWER))

    def mdb(lv):
        if lv is None:
            return np.array([])
        ref = np.abs(lv.ref_sum)
        ok = lv.valid & (lv.var > 0) & (ref != 0)
        exact = (lv.var == 0) & (ref != 0) & np.broadcast_to(np.asarray(lv.tol) > 0, ref.shape)
        noisy = (lv.z_crit + z_pow) * np.sqrt(lv.var[ok]) / ref[ok]
        return np.concatenate([noisy.ravel(), (np.broadcast_to(lv.tol, ref.shape)[exact] / ref[exact]).ravel()])

    g, t = mdb(img), mdb(tile8)
    return (float(g.min()) if g.size else math.nan), (float(np.median(t)) if t.size else math.nan)


@dataclass
class EstimatorKnowledge:
    """What is known of B's estimator at a high budget: ``moments`` (our tail reference's
    :class:`reference_tracer.SampleMoments`) or ``variance`` (an external renderer's per-sample
    variance), and a ``note`` saying which, or why neither."""

    note: str
    moments: object = None
    variance: np.ndarray | None = None


def _with_knowledge(known: EstimatorKnowledge, ref, test) -> tuple:
    """``(ref, test, moments)`` with B's known variance floored into both sides (under the null
    hypothesis A's estimator is B's; a floor only widens the test)."""
    if known.moments is not None:
        m2, _, _ = tail_moments(known.moments, np.shape(test[0]))
        floor = m2 * (known.moments.n / (known.moments.n - 1.0))
        moments = known.moments
    elif known.variance is not None:
        floor, moments = np.asarray(known.variance, dtype=np.float64), None
    else:
        return ref, test, None
    test = (test[0], np.maximum(test[1], floor), test[2])
    ref = (ref[0], np.maximum(ref[1], floor), ref[2])
    return ref, test, moments


def judge(ref, test, *, known: EstimatorKnowledge, alpha: float):
    """The gate's verdict of B's image against A's, as :func:`benchmarks.compare.compare_stores` gives it.

    Parameters
    ----------
    ref, test : tuple
        ``(mean, per-sample variance, spp)`` of A (the baseline) and of B.
    known : EstimatorKnowledge, keyword-only
        B's estimator at a high budget.
    alpha : float, keyword-only
        Level of this one comparison.

    Returns
    -------
    benchmarks.gate.GateResult

    Examples
    --------
    >>> a = (np.full((8, 8, 3), 0.5), np.full((8, 8, 3), 0.25), 64)
    >>> judge(a, a, known=EstimatorKnowledge("none"), alpha=0.01).verdict
    'pass'
    """
    ref, test, moments = _with_knowledge(known, ref, test)
    return compare(test[0], test[1], test[2], ref[0], ref[1], ref[2], alpha=alpha, tails=moments)
