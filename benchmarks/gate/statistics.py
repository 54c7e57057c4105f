"""The gate's statistics: does a render converge to the same image as a reference?

:func:`compare` is the test ``rtbench gate`` applies (issue 7); :func:`mitsuba_rule`
(:mod:`benchmarks.gate.mitsuba_rule`) re-implements Mitsuba 3's own render-test rule so
the two can be compared on the same data. Pure numpy/scipy.

Inputs are per-pixel *means* and *per-sample variances* (``rt.render``'s ``mean`` and
``variance``; for Mitsuba, the between-batch variance times the batch spp) with their
sample counts. Pixels are assumed independent (independent sampler, box filter), which
holds for both renderers as configured (docs/conventions.md); a ``tent`` or
``gaussian`` filter correlates neighbours.

How :func:`compare` tests
-------------------------
Null hypothesis H0: in every pixel-channel the test renderer and the reference have
the same expectation. Three levels, each a family of two-sided tests:

1. **pixel** - a Welch t-test per pixel-channel,
   ``t = (x - r) / sqrt(v_x / n_x + v_r / n_r)`` with Welch-Satterthwaite degrees of
   freedom. Catches large local errors (a missing highlight, a wrong light edge).
2. **tile** - pixels pooled into ``tile x tile`` blocks (by default at three sizes,
   8, 16 and 32): the summed difference over the block divided by the square root of the
   summed variances (Satterthwaite dof again).
   Catches a small bias spread over a region (one wall 3% too bright) that no single
   pixel can show.
3. **image** - the same over the whole image, per channel. Catches a small global bias
   (everything scaled by 0.99).
4. **correlation** - the sum of the products of neighbouring pixels' standardised
   differences per channel, one-sided (:mod:`benchmarks.gate.correlation`; with tail
   diagnostics only). Catches wrong noise that keeps every mean right (pixels that share
   random numbers), which would make the standard errors of the other levels too small.

Within a level the smallest p-value is Sidak-adjusted over the number of tests that
can reject, ``p_level = 1 - (1 - p_min)^m`` (exact for independent tests; tiles and
pixels are disjoint and so independent, and for the correlated channels of one pixel or
tile Sidak's inequality for two-sided tests keeps it conservative). The four levels are
combined by Bonferroni: ``p_value = min(1, 4 * min(level p-values))`` and the
gate passes iff ``p_value >= alpha``. Hence P(false alarm | H0) <= alpha, up to how well
each per-test p-value is calibrated - which is the hard part, below.

Heavy tails: tail diagnostics of the same estimator (``tails=``)
-----------------------------------------------------------------
With ``tails`` (a :class:`reference_tracer.SampleMoments` of the *same estimator* at a high
budget: :func:`benchmarks.tails.tail_reference`) the test's per-sample variance is
``max(v_x, tails' variance)`` and every statistic (pixel, tile, image) is tested only where
its normal approximation holds at its level's critical value, judged from its skewness and
kurtosis (sums of the pixels' third and fourth cumulants) by a one-term Edgeworth bound
(:func:`edgeworth_error`). The verdict has three values: ``fail`` when a tested statistic
rejects, ``undetermined`` when the whole-image statistic of a channel could not be
tested (with the spp that would decide), ``pass`` otherwise. The method, its assumptions
and its measured false-alarm rates: ``benchmarks/STATISTICS.md``.

Without tail diagnostics (the older rule, kept for renders that carry none)
----------------------------------------------------------------------------
Per-pixel Monte Carlo samples are often heavy-tailed (a rare path hits a bright light).
At small ``n_x`` the test's sample variance is then usually far *below* its expectation
(the rare samples did not occur) while the mean is low too; a plain Welch t then reports
huge |t| in exactly those pixels and, with thousands of pixels, the gate would fail
unbiased renders. Under H0 with the same estimator the reference's per-sample variance
``v_r`` (from ``n_r >> n_x`` samples) estimates the test's per-sample variance far better,
so by default (``variance_floor='reference'``) the test side uses
``max(v_x, v_r)``, applied to the variance of each statistic (a pixel; the sum over a
tile or the image: ``max(sum v_x, sum v_r) / n_x``). This can only enlarge the standard error, so it never adds false
alarms; it costs power only where the test renderer is genuinely less noisy than the
reference (a better sampling strategy). ``variance_floor='none'`` gives the plain Welch
test, for comparison; ``tests/benchmarks/gate/test_gate_stats.py`` measures both.

Zero variance
-------------
Where both variances are zero (black background, a directly seen light) the pixel
carries no noise: equal means (within ``zero_var_rtol`` relative, for float rounding)
are no evidence at all (p = 1, and the pixel is not counted as a test), unequal means
are a certain difference (p = 0). No division by zero happens. A per-sample variance
below ``(zero_var_rtol / 10 * |mean|)^2`` counts as zero: it is float rounding of
identical samples (``rt.render`` gives ~1e-15 on a directly seen light), and with it a
1e-6 relative difference between two renderers' emitter constants would fail the gate. Non-finite test pixels
(NaN/inf) are failures (p = 0); a non-finite reference raises ``ValueError``.
"""
from __future__ import annotations

import numpy as np

from ..constants import GATE_ALPHA
from .findings import POWER_TILE, locate, power, relative_bias
from .heavy_tails import DEFAULT_VALIDITY, spp_needed
from .inputs import prepare
from .levels import Level, correlation_level, family_p, image_level, pixel_level, tile_level
from .result import LEVELS, GateResult

__all__ = ["compare"]


def compare(test_mean, test_var, test_spp, ref_mean, ref_var, ref_spp, *,
            alpha: float = GATE_ALPHA, tile=(8, 16, 32), variance_floor: str = "reference",
            var_ddof: int = 0, zero_var_rtol: float = 1e-4, pixel_pool: int = 3, tails=None,
            validity: float = DEFAULT_VALIDITY, pixel_samples=None, filter_weights=None) -> GateResult:
    """Test whether a render and a reference have the same expectation (see module doc).

    Parameters
    ----------
    test_mean, test_var : array_like, shape (H, W) or (H, W, C)
        Pixel means and per-sample variances of the render under test.
    test_spp : int
        Its samples per pixel (>= 2).
    ref_mean, ref_var : array_like, same shape
        Reference means and per-sample variances.
    ref_spp : int
        Reference samples per pixel (>= 2).
    alpha : float
        False-alarm rate of the comparison on unbiased renders (upper bound).
    tile : int or sequence of int
        Tile side(s) in pixels for the tile level. All tiles of all the sizes form one
        Sidak family (nested tiles are positively correlated, so this is conservative).
        Partial tiles at the borders are used as they are. The default ``(8, 16, 32)``
        matters: on the synthetic suite a 3% bias on one wall at 64 spp is caught in
        4/10 seeds with ``tile=8`` alone and 10/10 with ``(8, 16, 32)``.
    variance_floor : {'reference', 'none'}
        ``'reference'`` (default): the test's per-sample variance is floored at an
        independent estimate of it - the tail diagnostics' variance when ``tails`` is
        given (the same estimator), else the reference's, ``max(v_x, v_r)``; ``'none'``:
        plain Welch on the render's own variance.
    var_ddof : int
        ddof of the given variances; ``0`` (second moment minus squared mean, as
        ``rt.render`` returns) is de-biased by ``n / (n - 1)``; pass 1 for variances that
        are already unbiased.
    zero_var_rtol : float
        Relative tolerance for "equal means" where both variances are zero.
    pixel_pool : int
        Side of the neighbourhood whose mean variance floors each pixel's variance at
        the pixel level (both sides; 1 disables). A pixel whose rare paths (a caustic
        through glass, a tiny light in a glossy plate) did not occur among its samples
        reports a variance far below the truth, and its t explodes: measured on real
        renders, the 100-seed false-alarm test failed 3 runs of 100 with ``pixel_pool=1``,
        two of them at single such pixels.
    tails : reference_tracer.SampleMoments, optional
        Per-pixel central moments of the *same estimator* at a high budget
        (:func:`benchmarks.tails.tail_reference`). Without them every statistic is
        taken as normal, which heavy-tailed estimators break (``benchmarks/STATISTICS.md``).
    validity : float
        Largest :func:`edgeworth_error` at which a statistic is still tested.
    pixel_samples : (mean, variance) pair of array_like, optional
        A test render with a tent or Gaussian filter: the mean and per-sample variance of
        the samples drawn inside each pixel (``rt.render``'s ``pixel_samples``), from which
        the filtered pixels' statistics are computed (:mod:`benchmarks.gate.filtered`); with
        ``filter_weights``. ``test_var`` is then not used, and ``tails`` (if given) are the
        per-sample moments of the same estimator with the box filter. The reference's
        per-sample variance is that of its filtered pixels (Mitsuba's, from its batches).
        The tile and image levels take the sums' variance from the samples' (a sum of
        filtered pixels counts each interior sample with weight ~1); the correlation level
        is not tested (the filter correlates neighbours by design).
    filter_weights : benchmarks.gate.filtered.FilterWeights, optional
        The filter's weights (:func:`benchmarks.gate.filtered.filter_weights`).

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
    level_p = {k: family_p(lvs)[0] for k, lvs in levels.items()}
    n_tests = {k: family_p(lvs)[1] for k, lvs in levels.items()}
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
        tile_p=tile_levels[0].p, tile_z=tile_levels[0].z, image_p=img.p, image_z=img.z,
        max_abs_t=float(np.abs(pix.z).max()), worst_pixel=(wy, wx, wc),
        worst_tile=worst_tile, worst_region=tuple(int(v) for v in worst_region),
        worst_level=worst_level, relative_bias=rel, relative_bias_se=rel_se,
        relative_bias_channels=rel_c, worst_tile_relative_bias=rel_tile, n_nonfinite=int(d.bad.sum()),
        min_detectable_bias=mdb, min_detectable_tile_bias=mdb_tile, spp_needed=needed,
        neighbour_correlation=rho, tails=tails is not None)


# ---------------------------------------------------------------------------------------
# the steps of compare, in order

def _check_options(alpha, tile, pixel_pool, variance_floor, validity) -> tuple:
    """Validate :func:`compare`'s options; returns the tile sizes as a tuple of int."""
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
