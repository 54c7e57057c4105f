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
test, for comparison; ``tests/test_gate_stats.py`` measures both.

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

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
from scipy import stats

from ..constants import GATE_ALPHA
from ..stats import sidak, sidak_p_value
from .heavy_tails import (DEFAULT_VALIDITY, edgeworth_error, neighbourhood_floor, pixel_shape, spp_needed,
                          tail_moments)
from .correlation import MIN_PAIRS, neighbour_products
from .filtered import filtered_moments
from .findings import POWER_TILE, locate, power, relative_bias
from .result import LEVELS, GateResult

__all__ = ["compare"]


def _image3(a, name: str) -> np.ndarray:
    arr = np.asarray(a, dtype=np.float64)
    if arr.ndim == 2:
        arr = arr[..., None]
    if arr.ndim != 3 or arr.size == 0:
        raise ValueError(f"{name} must have shape (H, W) or (H, W, C); got {np.shape(a)}")
    return arr


def _spp(n, name: str, minimum: int) -> float:
    v = float(n)
    if not (math.isfinite(v) and v >= minimum):
        raise ValueError(f"{name} must be a number >= {minimum}; got {n!r}")
    return v


def _variance(v: np.ndarray, name: str, n: float, ddof: int) -> np.ndarray:
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{name} has non-finite entries")
    # second moment minus squared mean can come out slightly negative in float32
    scale = max(np.abs(v).max(), 1.0)
    if np.any(v < -1e-5 * scale):
        raise ValueError(f"{name} has negative entries (min {v.min():g})")
    v = np.maximum(v, 0.0)
    if ddof not in (0, 1):
        raise ValueError(f"var_ddof must be 0 or 1; got {ddof}")
    if ddof == 0:
        v = v * (n / (n - 1.0))  # second moment minus squared mean -> unbiased
    return v


def _two_sided_p(stat: np.ndarray, dof: np.ndarray) -> np.ndarray:
    """2 * P(T > |stat|) with Student t(dof); dof = inf -> normal."""
    a = np.abs(stat)
    p = np.empty_like(a)
    inf_dof = ~np.isfinite(dof)
    p[inf_dof] = 2.0 * stats.norm.sf(a[inf_dof])
    fin = ~inf_dof
    p[fin] = 2.0 * stats.t.sf(a[fin], dof[fin])
    return np.minimum(p, 1.0)


def _welch_from_sums(diff, a, b, a2, b2, n_t, n_r, tol, fa=None, fa2=None):
    """Welch statistic of a summed difference.

    ``diff``: sum of differences; ``a``, ``b``: sums of the test's / reference's variances
    of the mean; ``a2``, ``b2``: sums of their squares (for Welch-Satterthwaite dof);
    ``fa``, ``fa2``: optional floor for ``a`` (and its squares), applied to the *sum*;
    ``tol``: differences with ``|diff| <= tol`` count as equal when both variances are 0.
    Returns (stat, p, testable).
    """
    if fa is not None:
        use_floor = fa > a
        a = np.where(use_floor, fa, a)
        a2 = np.where(use_floor, fa2, a2)
    se2 = a + b
    pos = se2 > 0
    stat = np.zeros_like(diff)
    p = np.ones_like(diff)
    with np.errstate(divide="ignore", invalid="ignore"):
        stat[pos] = diff[pos] / np.sqrt(se2[pos])
        denom = a2 / (n_t - 1.0) + b2 / (n_r - 1.0)
        dof = np.where(denom > 0, se2 * se2 / np.where(denom > 0, denom, 1.0), np.inf)
    p[pos] = _two_sided_p(stat[pos], dof[pos])
    zero = ~pos
    differs = zero & (np.abs(diff) > tol)
    stat[differs] = np.copysign(np.inf, diff[differs])
    p[differs] = 0.0
    testable = pos | differs
    return stat, p, testable


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
    d = _prepare(test_mean, test_var, test_spp, ref_mean, ref_var, ref_spp, var_ddof=var_ddof,
                 zero_var_rtol=zero_var_rtol, variance_floor=variance_floor, tails=tails,
                 pixel_samples=pixel_samples, filter_weights=filter_weights)
    crit = dict(alpha_level=alpha / len(LEVELS), validity=validity)
    pix = _pixel_level(d, pixel_pool, **crit)
    # pixels with no noise and equal means contribute exactly nothing to the sums
    diff = np.where(pix.testable & ~d.bad, d.diff, 0.0)
    tile_levels = [_tile_level(d, diff, ts, **crit) for ts in tiles]
    img = _image_level(d, diff, **crit)
    corr, rho = _correlation_level(pix, tails is not None and filter_weights is None, **crit)

    # ---- combine: Sidak within a level (over the tested statistics), Bonferroni over the levels
    levels = {"pixel": [pix], "tile": tile_levels, "image": [img], "correlation": [corr]}
    level_p = {k: _family_p(lvs)[0] for k, lvs in levels.items()}
    n_tests = {k: _family_p(lvs)[1] for k, lvs in levels.items()}
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


@dataclass(frozen=True)
class _Inputs:
    """Validated inputs of :func:`compare`, as float64 ``(H, W, C)`` images.

    ``x``, ``r``: test and reference means (``x`` set to ``r`` where the test is
    non-finite, ``bad``); ``a``, ``b``: variances of the test's and the reference's pixel
    means; ``fa``: floor of ``a`` (the reference's per-sample variance at the test's spp)
    or None; ``k3``, ``k4``: third and fourth cumulants of the test's pixel means (zero
    without tail diagnostics); ``g1``, ``g2``: per-sample skewness and excess kurtosis of
    each pixel for the pixel level (the worse of the pixel's own and its neighbourhood's);
    ``diff = x - r``; ``abs_scale = max(|x|, |r|)``. ``summed``: the same variances and
    cumulants for sums over tiles and the image (for a filtered render those of the samples
    drawn in each pixel: a sum of filtered pixels weighs each interior sample ~1), or None
    where they are the pixels' own.
    """

    x: np.ndarray
    r: np.ndarray
    a: np.ndarray
    b: np.ndarray
    fa: np.ndarray | None
    k3: np.ndarray
    k4: np.ndarray
    g1: np.ndarray
    g2: np.ndarray
    bad: np.ndarray
    diff: np.ndarray
    abs_scale: np.ndarray
    n_t: float
    n_r: float
    zero_var_rtol: float
    summed: dict | None = None

    def for_sums(self, name: str) -> np.ndarray:
        """``a``, ``b``, ``fa``, ``k3`` or ``k4`` as the tile and image levels sum them."""
        return getattr(self, name) if self.summed is None else self.summed[name]

    def sums(self, reduce, *, summed: bool = False) -> dict:
        """The variance sums :func:`_welch_from_sums` takes, each reduced by ``reduce``."""
        a, b, fa = ((self.for_sums(k) for k in ("a", "b", "fa")) if summed else (self.a, self.b, self.fa))
        out = dict(a=reduce(a), b=reduce(b), a2=reduce(a * a), b2=reduce(b * b))
        if fa is not None:
            out.update(fa=reduce(fa), fa2=reduce(fa * fa))
        return out


@dataclass
class _Level:
    """One level's statistics (a pixel, a tile size or the image), arrays of one shape.

    ``testable``: carries evidence (noise, or a difference between noiseless values);
    ``valid``: testable and normal enough at ``z_crit`` to be tested; ``var``: variance of
    the statistic; ``ref_sum``: the reference summed over the statistic's pixels.
    """

    z: np.ndarray
    p: np.ndarray
    testable: np.ndarray
    valid: np.ndarray
    g1: np.ndarray
    g2: np.ndarray
    z_crit: float
    var: np.ndarray
    ref_sum: np.ndarray
    tol: np.ndarray | float = 0.0


def _prepare(test_mean, test_var, test_spp, ref_mean, ref_var, ref_spp, *, var_ddof, zero_var_rtol,
             variance_floor, tails, pixel_samples=None, filter_weights=None) -> _Inputs:
    """Validate and convert the images of :func:`compare` (see its parameters)."""
    if filter_weights is not None:
        return _prepare_filtered(test_mean, test_spp, ref_mean, ref_var, ref_spp, var_ddof=var_ddof,
                                 zero_var_rtol=zero_var_rtol, variance_floor=variance_floor, tails=tails,
                                 pixel_samples=pixel_samples, weights=filter_weights)
    x, vx = _image3(test_mean, "test_mean"), _image3(test_var, "test_var")
    r, vr = _image3(ref_mean, "ref_mean"), _image3(ref_var, "ref_var")
    shapes = {"test_mean": x.shape, "test_var": vx.shape, "ref_mean": r.shape, "ref_var": vr.shape}
    if len(set(shapes.values())) > 1:
        raise ValueError("image shapes differ: " + ", ".join(f"{k}{s}" for k, s in shapes.items()))
    n_t = _spp(test_spp, "test_spp", 2)
    n_r = _spp(ref_spp, "ref_spp", 2)
    if not np.all(np.isfinite(r)):
        raise ValueError("ref_mean has non-finite entries")
    vr = _variance(vr, "ref_var", n_r, var_ddof)
    bad = ~np.isfinite(x) | ~np.isfinite(vx)
    vx = _variance(np.where(bad, 0.0, vx), "test_var", n_t, var_ddof)
    x = np.where(bad, r, x)  # neutral stand-in; these pixel-channels fail at the pixel level
    zeros = np.zeros_like(x)
    k3 = k4 = g1 = g2 = zeros
    fa = vr / n_t if variance_floor == "reference" else None
    if tails is not None:
        m2, m3, k4s = tail_moments(tails, x.shape)
        if variance_floor == "reference":
            # the same estimator's variance, from many more samples: the floor that holds
            vx = np.maximum(vx, m2 * (tails.n / (tails.n - 1.0)))
            fa = None
        k3, k4 = m3 / n_t ** 2, k4s / n_t ** 3
    # A per-sample variance at float-rounding level is zero: identical samples give a
    # second moment minus squared mean of ~1e-15 (a directly seen light), which would
    # otherwise make a 1e-6 relative difference in the constants "significant". Below
    # (zero_var_rtol / 10 * |mean|)^2 the pixel mean is pinned far inside the tolerance.
    vx = np.where(vx <= (0.1 * zero_var_rtol * x) ** 2, 0.0, vx)
    vr = np.where(vr <= (0.1 * zero_var_rtol * r) ** 2, 0.0, vr)
    if tails is not None:
        g1, g2 = pixel_shape(m2, m3, k4s, exact=(vx == 0) & (vr == 0), n_t=n_t)
    return _Inputs(x=x, r=r, a=vx / n_t, b=vr / n_r, fa=fa, k3=k3, k4=k4, g1=g1, g2=g2, bad=bad,
                   diff=x - r, abs_scale=np.maximum(np.abs(x), np.abs(r)), n_t=n_t, n_r=n_r,
                   zero_var_rtol=zero_var_rtol)


def _prepare_filtered(test_mean, test_spp, ref_mean, ref_var, ref_spp, *, var_ddof, zero_var_rtol,
                      variance_floor, tails, pixel_samples, weights) -> _Inputs:
    """:func:`_prepare` for a filtered test render: the filtered pixels' moments from the
    samples drawn inside each pixel (:func:`benchmarks.gate.filtered.filtered_moments`), the
    samples' own for the sums."""
    try:
        box_mean, box_var = pixel_samples
    except (TypeError, ValueError):
        raise ValueError("pixel_samples must be a (mean, variance) pair of images") from None
    d = _prepare(test_mean, box_var, test_spp, ref_mean, ref_var, ref_spp, var_ddof=var_ddof,
                 zero_var_rtol=zero_var_rtol, variance_floor="none", tails=None)
    mu = _image3(box_mean, "pixel_samples mean")
    if mu.shape != d.x.shape or not np.all(np.isfinite(mu)):
        raise ValueError(f"pixel_samples mean must be finite with the images' shape {d.x.shape}")
    n_t = d.n_t
    v_box = d.a * n_t  # the samples' per-sample variance, de-biased and zero below rounding
    m3 = k4 = None
    if tails is not None:
        m2t, m3, k4 = tail_moments(tails, d.x.shape)
        if variance_floor == "reference":
            v_box = np.maximum(v_box, m2t * (tails.n / (tails.n - 1.0)))
    m2f, m3f, k4f = filtered_moments(weights, mean=mu, variance=v_box, filtered_mean=d.x, m3=m3, k4=k4)
    a = np.where(d.bad, 0.0, m2f) / n_t
    a_sum = np.where(d.bad, 0.0, v_box) / n_t
    with np.errstate(divide="ignore", invalid="ignore"):
        # the reference shares the filter: its sums' variance relates to its pixels' as ours
        inflate = np.where(a > 0, a_sum / np.where(a > 0, a, 1.0), 1.0)
    fa = d.b * d.n_r / n_t if variance_floor == "reference" and tails is None else None
    summed = dict(a=a_sum, b=d.b * inflate, fa=None if fa is None else fa * inflate, k3=d.k3, k4=d.k4)
    shape = {}
    if tails is not None:
        summed.update(k3=m3 / n_t ** 2, k4=k4 / n_t ** 3)
        g1, g2 = pixel_shape(m2f, m3f, k4f, exact=(a == 0) & (d.b == 0), n_t=n_t)
        shape = dict(k3=m3f / n_t ** 2, k4=k4f / n_t ** 3, g1=g1, g2=g2)
    return dataclasses.replace(d, a=a, fa=fa, summed=summed, **shape)


def _level(d: _Inputs, reduce, diff, K3, K4, *, alpha_level, validity, summed: bool = False) -> _Level:
    """The Welch statistics of ``diff`` (already reduced: a pixel's, a tile's or the
    image's summed difference) with the variances reduced by ``reduce``, and which of them
    may be tested.

    ``K3``, ``K4``: the statistics' third and fourth cumulants. A statistic is tested where
    :func:`edgeworth_error` at the level's critical value (Sidak over its candidates) is at
    most ``validity``, and its p-value is then inflated by that bound,
    ``p (1 + e(min(|z|, z_crit)))``: the error of the normal tail is paid for in the
    p-value rather than ignored, so the level holds for skewed statistics too.
    """
    sums = d.sums(reduce, summed=summed)
    tol = d.zero_var_rtol * reduce(d.abs_scale)
    z, p, testable = _welch_from_sums(diff, n_t=d.n_t, n_r=d.n_r, tol=tol, **sums)
    a = sums["a"] if d.fa is None else np.maximum(sums["a"], sums["fa"])
    var = a + sums["b"]
    with np.errstate(divide="ignore", invalid="ignore"):
        pos = var > 0
        g1 = np.where(pos, K3 / np.where(pos, var, 1.0) ** 1.5, 0.0)
        g2 = np.where(pos, K4 / np.where(pos, var, 1.0) ** 2, 0.0)
    z_crit = float(stats.norm.isf(sidak(alpha_level, max(int(testable.sum()), 1)) / 2.0))
    valid = testable & (~pos | (edgeworth_error(z_crit, g1, g2) <= validity))
    at = np.minimum(np.where(np.isfinite(z), np.abs(z), z_crit), z_crit)
    p = np.where(pos, np.minimum(1.0, p * (1.0 + edgeworth_error(at, g1, g2))), p)
    return _Level(z=z, p=p, testable=testable, valid=valid, g1=g1, g2=g2, z_crit=z_crit, var=var,
                  ref_sum=reduce(d.r), tol=tol)


def _pixel_level(d: _Inputs, pixel_pool: int, **crit) -> _Level:
    """Welch test per pixel-channel; non-finite test pixels fail.

    Variances are floored by their neighbourhood mean (see ``pixel_pool``); the difference
    is the pixel's own (pooling it too, as an earlier version did, turned a pixel 10
    standard errors too dark into one 1 too dark: the floor's max only lifts). Pixels with
    no noise on either side (a directly seen light) stay exact: their neighbours' noise
    says nothing about them, and flooring them would turn the float rounding of the
    emitters' constants (~3e-6 relative) into "significant" differences.
    """
    exact = (d.a == 0) & (d.b == 0)
    pool = ((lambda v: v) if pixel_pool <= 1 else
            (lambda v: np.where(exact, v, neighbourhood_floor(v, pixel_pool))))
    var = pool(d.a if d.fa is None else np.maximum(d.a, d.fa)) + pool(d.b)
    lv = _level(d, pool, d.diff, d.g1 * var ** 1.5, d.g2 * var * var, **crit)
    lv.z[d.bad] = np.inf
    lv.p[d.bad] = 0.0
    lv.testable |= d.bad
    lv.valid |= d.bad
    return lv


def _tile_level(d: _Inputs, diff: np.ndarray, ts: int, **crit) -> _Level:
    """Welch test per ``ts x ts`` tile and channel.

    Images are padded to whole tiles with zeros (padding contributes nothing to the sums).
    """
    H, W, C = d.x.shape
    ty, tx = -(-H // ts), -(-W // ts)

    def tile_sum(img):
        padded = np.zeros((ty * ts, tx * ts, C))
        padded[:H, :W] = img
        return padded.reshape(ty, ts, tx, ts, C).sum(axis=(1, 3))

    return _level(d, tile_sum, tile_sum(diff), tile_sum(d.for_sums("k3")), tile_sum(d.for_sums("k4")), summed=True,
                  **crit)


def _image_level(d: _Inputs, diff: np.ndarray, **crit) -> _Level:
    """Welch test of the whole image per channel."""
    total = lambda v: v.sum(axis=(0, 1))  # noqa: E731
    return _level(d, total, total(diff), total(d.for_sums("k3")), total(d.for_sums("k4")), summed=True, **crit)


def _correlation_level(pix: _Level, with_tails: bool, *, alpha_level, validity) -> tuple:
    """``(level, rho)``: the one-sided test of positive correlation between neighbouring
    pixels' differences per channel (:mod:`benchmarks.gate.correlation`) and the estimated
    neighbour correlation ``S / N_pairs``.

    It takes the pixel level's statistics: their variances are floored by the pixel's
    neighbourhood and their shape is the worse of the pixel's and its neighbourhood's, so a
    pixel whose rare paths neither the render nor the tail reference saw (its difference
    hundreds of its standard errors) does not pass for correlated noise. Tested only with
    tail diagnostics: without them a heavy-tailed estimator's own variance is too small and
    its skewness unknown.
    """
    use = pix.testable & np.isfinite(pix.z) & (pix.var > 0)
    S, n, K3, K4 = neighbour_products(pix.z, pix.g1, pix.g2, use)
    testable = (n >= MIN_PAIRS) & with_tails
    n1 = np.where(n > 0, n, 1.0)
    z, g1, g2 = S / np.sqrt(n1), K3 / n1 ** 1.5, K4 / n1 ** 2
    z_crit = float(stats.norm.isf(sidak(alpha_level, max(int(testable.sum()), 1))))
    valid = testable & (edgeworth_error(z_crit, g1, g2) <= validity)
    at = np.clip(z, 0.0, z_crit)
    p = np.where(testable, np.minimum(1.0, stats.norm.sf(z) * (1.0 + edgeworth_error(at, g1, g2))), 1.0)
    zeros = np.zeros_like(z)
    level = _Level(z=np.where(testable, z, 0.0), p=p, testable=testable, valid=valid, g1=g1, g2=g2,
                   z_crit=z_crit, var=zeros, ref_sum=zeros)
    return level, np.where(valid, S / n1, np.nan)


def _family_p(levels: list) -> tuple:
    """``(Sidak-adjusted smallest p, number of tests)`` over the tested statistics of ``levels``
    (all tile sizes form one family)."""
    p = np.concatenate([lv.p[lv.valid].ravel() for lv in levels])
    m = int(p.size)
    return (sidak_p_value(float(p.min()), m) if m else 1.0), m


def _decide(failed: list, img: _Level, n_t: float, validity: float, rho) -> tuple:
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
