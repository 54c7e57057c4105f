"""Statistical regression gate: does a render converge to the same image as a reference?

:func:`compare` is the gate ``rtbench gate`` uses (issue 7); :func:`mitsuba_rule`
re-implements Mitsuba 3's own render-test rule so the two can be compared on the same
data. Pure numpy/scipy.

Inputs are per-pixel *means* and *per-sample variances* (``rt.render``'s ``mean`` and
``variance``; for Mitsuba, the between-batch variance times the batch spp) with their
sample counts. Pixels are assumed independent (independent sampler, box filter), which
holds for both renderers as configured in DESIGN.md section 3.

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

Within a level the smallest p-value is Sidak-adjusted over the number of tests that
can reject, ``p_level = 1 - (1 - p_min)^m`` (exact for independent tests; tiles and
pixels are disjoint and so independent, and for the correlated channels of one pixel or
tile Sidak's inequality for two-sided tests keeps it conservative). The three levels are
combined by Bonferroni: ``p_value = min(1, 3 * min(p_pixel, p_tile, p_image))`` and the
gate passes iff ``p_value >= alpha``. Hence P(false alarm | H0) <= alpha, up to how well
each per-test p-value is calibrated - which is the hard part, below.

Robustness to estimated, heavy-tailed variances
-----------------------------------------------
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

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

__all__ = ["GateResult", "compare", "MitsubaRuleResult", "mitsuba_rule", "sidak"]

LEVELS = ("pixel", "tile", "image")


def sidak(p_min: float, m: int) -> float:
    """Sidak-adjusted p-value of the smallest of ``m`` p-values, ``1 - (1 - p_min)^m``.

    Computed as ``-expm1(m * log1p(-p_min))`` so tiny p-values keep their precision.

    >>> round(sidak(0.01, 1), 12), round(sidak(1e-12, 1000), 15)
    (0.01, 1e-09)
    """
    if m <= 0:
        return 1.0
    if p_min >= 1.0:
        return 1.0
    if p_min <= 0.0:
        return 0.0
    return float(-math.expm1(m * math.log1p(-p_min)))


# ---------------------------------------------------------------------------------------

@dataclass
class GateResult:
    """Verdict and statistics of :func:`compare`.

    Attributes
    ----------
    passed : bool
        ``p_value >= alpha``.
    alpha : float
    p_value : float
        Gate p-value: Bonferroni over the three levels of the Sidak-adjusted level
        p-values, ``min(1, 3 * min(level_p.values()))``.
    level_p : dict
        ``{'pixel': p, 'tile': p, 'image': p}``, each Sidak-adjusted within its level.
    failed_levels : list of str
        Levels with ``3 * level_p < alpha`` (the levels that fail the gate).
    n_tests : dict
        Number of tests per level that could reject (no-evidence pixels/tiles excluded).
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
    """

    passed: bool
    alpha: float
    p_value: float
    level_p: dict
    failed_levels: list
    n_tests: dict
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

    def summary(self) -> str:
        """One line for a CLI table or failure message."""
        verdict = "PASS" if self.passed else "FAIL"
        r0, c0, r1, c1 = self.worst_region
        lv = ", ".join(f"{k} p={v:.3g}" for k, v in self.level_p.items())
        msg = (f"{verdict} (p={self.p_value:.3g}, alpha={self.alpha:g}; {lv}); "
               f"relative bias {self.relative_bias:+.2%} +- {self.relative_bias_se:.2%} over the image")
        if not self.passed:
            msg += (f"; strongest evidence at the {self.worst_level} level in rows {r0}-{r1 - 1}, "
                    f"cols {c0}-{c1 - 1} (worst tile relative bias "
                    f"{self.worst_tile_relative_bias:+.2%})")
        if self.n_nonfinite:
            msg += f"; {self.n_nonfinite} non-finite test pixel-channels"
        return msg

    def to_dict(self) -> dict:
        """JSON-friendly scalars (no images)."""
        return {
            "passed": bool(self.passed), "alpha": self.alpha, "p_value": self.p_value,
            "level_p": dict(self.level_p), "failed_levels": list(self.failed_levels),
            "n_tests": dict(self.n_tests), "max_abs_t": self.max_abs_t,
            "worst_pixel": list(self.worst_pixel), "worst_tile": list(self.worst_tile),
            "worst_region": list(self.worst_region), "worst_level": self.worst_level,
            "relative_bias": self.relative_bias, "relative_bias_se": self.relative_bias_se,
            "relative_bias_channels": [float(v) for v in self.relative_bias_channels],
            "worst_tile_relative_bias": self.worst_tile_relative_bias,
            "n_nonfinite": self.n_nonfinite,
        }


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


def _neighbourhood_floor(v: np.ndarray, size: int) -> np.ndarray:
    """``max(v, mean of v over the size x size neighbourhood)`` per channel."""
    from scipy.ndimage import uniform_filter

    pooled = np.stack([uniform_filter(v[..., c], size=size, mode="nearest") for c in range(v.shape[2])], axis=-1)
    return np.maximum(v, pooled)


def compare(test_mean, test_var, test_spp, ref_mean, ref_var, ref_spp, *,
            alpha: float = 0.01, tile=(8, 16, 32), variance_floor: str = "reference",
            var_ddof: int = 0, zero_var_rtol: float = 1e-4, pixel_pool: int = 3) -> GateResult:
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
        False-alarm rate of the whole gate on unbiased renders (upper bound).
    tile : int or sequence of int
        Tile side(s) in pixels for the tile level. All tiles of all the sizes form one
        Sidak family (nested tiles are positively correlated, so this is conservative).
        Partial tiles at the borders are used as they are. The default ``(8, 16, 32)``
        matters: on the synthetic suite a 3% bias on one wall at 64 spp is caught in
        4/10 seeds with ``tile=8`` alone and 10/10 with ``(8, 16, 32)``.
    variance_floor : {'reference', 'none'}
        ``'reference'`` (default): the test's per-sample variance is floored at the
        reference's, ``max(v_x, v_r)`` - robust to the under-estimated variances of
        heavy-tailed samples at low spp; ``'none'``: plain Welch.
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
        two of them at single such pixels. Neighbours estimate the same smooth per-sample
        variance from 9x the samples; the max keeps the floor conservative.

    Returns
    -------
    GateResult

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> ref = np.full((16, 16, 3), 0.5)
    >>> var = np.full_like(ref, 0.25)
    >>> test = ref + rng.standard_normal(ref.shape) * np.sqrt(0.25 / 64)
    >>> compare(test, var, 64, ref, var, 4096).passed
    True
    >>> compare(test * 0.9, var, 64, ref, var, 4096).failed_levels
    ['tile', 'image']
    """
    if not 0 < alpha < 1:
        raise ValueError(f"alpha must be in (0, 1); got {alpha}")
    tiles = tuple(int(t) for t in np.atleast_1d(tile))
    if not tiles or min(tiles) < 1:
        raise ValueError(f"tile sizes must be >= 1; got {tile}")
    if isinstance(pixel_pool, bool) or not isinstance(pixel_pool, (int, np.integer)) or pixel_pool < 1:
        raise ValueError(f"pixel_pool must be an integer >= 1; got {pixel_pool!r}")
    if variance_floor not in ("reference", "none"):
        raise ValueError(f"variance_floor must be 'reference' or 'none'; got {variance_floor!r}")
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
    x = np.where(bad, r, x)  # neutral stand-in; these pixel-channels fail below
    # A per-sample variance at float-rounding level is zero: identical samples give a
    # second moment minus squared mean of ~1e-15 (a directly seen light), which would
    # otherwise make a 1e-6 relative difference in the constants "significant". Below
    # (zero_var_rtol / 10 * |mean|)^2 the pixel mean is pinned far inside the tolerance.
    vx = np.where(vx <= (0.1 * zero_var_rtol * x) ** 2, 0.0, vx)
    vr = np.where(vr <= (0.1 * zero_var_rtol * r) ** 2, 0.0, vr)
    H, W, C = x.shape

    a = vx / n_t                       # variance of the test's pixel mean
    b = vr / n_r                       # variance of the reference's pixel mean
    # floor for the test side: the reference's per-sample variance at the test's spp,
    # applied to the variance of each level's statistic (a pixel, a tile sum, the image sum)
    fa = vr / n_t if variance_floor == "reference" else None
    diff = x - r
    tol = zero_var_rtol * np.maximum(np.abs(x), np.abs(r))

    def sums(reduce):
        out = dict(a=reduce(a), b=reduce(b), a2=reduce(a * a), b2=reduce(b * b))
        if fa is not None:
            out.update(fa=reduce(fa), fa2=reduce(fa * fa))
        return out

    # ---- pixel level (variances floored by their neighbourhood mean: see pixel_pool)
    # Pixels with no noise on either side (a directly seen light) stay exact: their
    # neighbours' noise says nothing about them, and flooring them would turn the float
    # rounding of the emitters' constants (~3e-6 relative) into "significant" differences.
    exact = (a == 0) & (b == 0)
    pool = ((lambda v: v) if pixel_pool <= 1 else
            (lambda v: np.where(exact, v, _neighbourhood_floor(v, pixel_pool))))
    t_pix, p_pix, testable_pix = _welch_from_sums(diff, n_t=n_t, n_r=n_r, tol=tol,
                                                  **sums(pool))
    t_pix[bad] = np.inf
    p_pix[bad] = 0.0
    testable_pix |= bad
    # pixels with no noise and equal means contribute exactly nothing to the sums
    diff = np.where(testable_pix & ~bad, diff, 0.0)
    abs_scale = np.maximum(np.abs(x), np.abs(r))

    # ---- tile level: every tile size, each image padded to whole tiles with zeros
    # (padding contributes nothing to the sums); all tiles of all sizes form one family
    tile_levels = []
    for ts in tiles:
        ty, tx = -(-H // ts), -(-W // ts)

        def tile_sum(img, ts=ts, ty=ty, tx=tx):
            padded = np.zeros((ty * ts, tx * ts, C))
            padded[:H, :W] = img
            return padded.reshape(ty, ts, tx, ts, C).sum(axis=(1, 3))

        tile_levels.append(_welch_from_sums(
            tile_sum(diff), n_t=n_t, n_r=n_r, tol=zero_var_rtol * tile_sum(abs_scale),
            **sums(tile_sum)))
    z_tile, p_tile, _ = tile_levels[0]

    # ---- image level
    image_sum = lambda v: v.sum(axis=(0, 1))  # noqa: E731
    z_img, p_img, testable_img = _welch_from_sums(
        image_sum(diff), n_t=n_t, n_r=n_r, tol=zero_var_rtol * image_sum(abs_scale),
        **sums(image_sum))

    # ---- combine
    def level(p, testable):
        m = int(testable.sum())
        return (sidak(float(p[testable].min()), m) if m else 1.0), m

    lp_pix, m_pix = level(p_pix, testable_pix)
    p_all = np.concatenate([lv[1][lv[2]] for lv in tile_levels])
    m_tile = int(p_all.size)
    lp_tile = sidak(float(p_all.min()), m_tile) if m_tile else 1.0
    lp_img, m_img = level(p_img, testable_img)
    level_p = {"pixel": lp_pix, "tile": lp_tile, "image": lp_img}
    n_levels = len(level_p)
    p_value = min(1.0, n_levels * min(level_p.values()))
    failed = [k for k, v in level_p.items() if n_levels * v < alpha]

    # ---- where and how large
    def argworst(p, s):
        # smallest p, ties broken by largest |stat|
        flat = np.lexsort((-np.abs(s).ravel(), p.ravel()))[0]
        return np.unravel_index(flat, p.shape)

    wy, wx, wc = (int(i) for i in argworst(p_pix, t_pix))
    best = None
    for ts, (zt, pt, _) in zip(tiles, tile_levels):
        iy, ix, ic = (int(i) for i in argworst(pt, zt))
        key = (pt[iy, ix, ic], -abs(zt[iy, ix, ic]))
        if best is None or key < best[0]:
            best = (key, (iy * ts, ix * ts, min(H, (iy + 1) * ts), min(W, (ix + 1) * ts)))
    worst_tile = best[1]
    worst_level = min(level_p, key=lambda k: (level_p[k], LEVELS.index(k)))
    worst_region = {"pixel": (wy, wx, wy + 1, wx + 1), "tile": worst_tile,
                    "image": (0, 0, H, W)}[worst_level]
    good = ~bad
    d_all = np.where(good, x - r, 0.0)
    r_all = np.where(good, r, 0.0)
    sum_r_c = r_all.sum(axis=(0, 1))
    with np.errstate(divide="ignore", invalid="ignore"):
        rel_c = np.where(sum_r_c != 0, d_all.sum(axis=(0, 1)) / sum_r_c, np.nan)
    sr = float(r_all.sum())
    rel = float(d_all.sum() / sr) if sr != 0 else math.nan
    se_sum = a + b if fa is None else np.maximum(a, fa) + b
    rel_se = float(math.sqrt(se_sum[good].sum()) / abs(sr)) if sr != 0 else math.nan
    y0, x0, y1, x1 = worst_tile
    srt = float(r_all[y0:y1, x0:x1].sum())
    rel_tile = float(d_all[y0:y1, x0:x1].sum() / srt) if srt != 0 else math.nan

    return GateResult(
        passed=bool(p_value >= alpha), alpha=float(alpha), p_value=float(p_value),
        level_p=level_p, failed_levels=failed,
        n_tests={"pixel": m_pix, "tile": m_tile, "image": m_img},
        pixel_p=p_pix, p_map=p_pix.min(axis=2), pixel_t=t_pix,
        tile_p=p_tile, tile_z=z_tile, image_p=p_img, image_z=z_img,
        max_abs_t=float(np.abs(t_pix).max()), worst_pixel=(wy, wx, wc),
        worst_tile=worst_tile, worst_region=tuple(int(v) for v in worst_region),
        worst_level=worst_level, relative_bias=rel, relative_bias_se=rel_se,
        relative_bias_channels=rel_c,
        worst_tile_relative_bias=rel_tile, n_nonfinite=int(bad.sum()))


# ---------------------------------------------------------------------------------------
# Mitsuba 3's render-test rule, for comparison

@dataclass
class MitsubaRuleResult:
    """Result of :func:`mitsuba_rule`.

    ``passed``; ``fraction_passed`` = passing pixel-channels / (C * pixels);
    ``alpha_sidak`` the per-pixel level; ``n_failed`` failing pixel-channels;
    ``p_value`` (H, W, C) per-pixel-channel p-values; ``min_p``.
    """

    passed: bool
    fraction_passed: float
    alpha_sidak: float
    n_failed: int
    min_p: float
    p_value: np.ndarray = field(repr=False)


def mitsuba_rule(test_mean, ref_mean, ref_var, test_spp, *, alpha: float = 0.01,
                 var_floor: float = 1e-4, pass_fraction: float = 0.9975) -> MitsubaRuleResult:
    """Mitsuba 3's render-test acceptance rule, re-implemented for comparison.

    Source: ``src/render/tests/test_renders.py`` in mitsuba-renderer/mitsuba3 (functions
    ``z_test`` and ``test_render``), read for this re-implementation. Its rule:

    * the reference's per-sample variance is floored, ``v = max(ref_var, 1e-4)``;
    * ``z = |mean - ref| * sqrt(spp / v)`` where ``spp`` is the sample count of the
      render *under test* (the reference's own spp and noise do not enter; neither does
      the test render's variance);
    * ``p = 2 * (1 - Phi(z))``;
    * Sidak-corrected level over *pixels* (not pixel-channels):
      ``alpha_s = 1 - (1 - alpha)^(1 / (H * W))`` with ``alpha = 0.01``;
    * a pixel-channel passes if ``p > alpha_s``; the image passes if
      ``passing pixel-channels / C >= 0.9975 * H * W``.

    Mitsuba applies it in XYZ (it converts RGB references to XYZ first); here it runs
    in whatever colour space the arrays are in.

    Parameters
    ----------
    test_mean : array_like, (H, W) or (H, W, C)
    ref_mean, ref_var : array_like, same shape
        Reference mean and per-sample variance.
    test_spp : int
        Samples per pixel of the render under test (Mitsuba's ``sample_count``).

    Examples
    --------
    >>> ref = np.full((8, 8, 3), 1.0)
    >>> mitsuba_rule(ref * 1.001, ref, np.full_like(ref, 1.0), 64).passed
    True
    """
    x = _image3(test_mean, "test_mean")
    r = _image3(ref_mean, "ref_mean")
    v = _image3(ref_var, "ref_var")
    if not (x.shape == r.shape == v.shape):
        raise ValueError(f"image shapes differ: test_mean{x.shape}, ref_mean{r.shape}, ref_var{v.shape}")
    n = _spp(test_spp, "test_spp", 1)
    H, W, C = x.shape
    v = np.maximum(np.nan_to_num(v, nan=0.0), var_floor)
    with np.errstate(invalid="ignore"):
        z = np.abs(x - r) * np.sqrt(n / v)
    p = 2.0 * stats.norm.sf(z)
    p = np.where(np.isnan(p), 0.0, p)  # NaN test pixels fail (Mitsuba: NaN > alpha is False)
    pixel_count = H * W
    alpha_s = float(-math.expm1(math.log1p(-alpha) / pixel_count))
    success = p > alpha_s
    n_pass = int(np.count_nonzero(success))
    return MitsubaRuleResult(
        passed=bool(n_pass / C >= pass_fraction * pixel_count),
        fraction_passed=n_pass / (C * pixel_count), alpha_sidak=alpha_s,
        n_failed=int(success.size - n_pass), min_p=float(p.min()), p_value=p)
