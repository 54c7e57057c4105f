"""The levels of :func:`benchmarks.gate.compare`: the Welch statistics of a pixel, a tile, the
whole image, and the correlation of neighbouring pixels, each with which of its statistics
may be tested (an Edgeworth bound on their normal approximation), and a level's family
p-value (Sidak over its tested statistics).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from ..stats import sidak, sidak_p_value
from .correlation import MIN_PAIRS, neighbour_products
from .heavy_tails import edgeworth_error, neighbourhood_floor
from .inputs import Inputs

__all__ = ["Level", "pixel_level", "tile_level", "image_level", "correlation_level", "family_p"]


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


@dataclass
class Level:
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


def _level(d: Inputs, reduce, diff, K3, K4, *, alpha_level, validity, summed: bool = False) -> Level:
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
    return Level(z=z, p=p, testable=testable, valid=valid, g1=g1, g2=g2, z_crit=z_crit, var=var,
                 ref_sum=reduce(d.r), tol=tol)


def pixel_level(d: Inputs, pixel_pool: int, **crit) -> Level:
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


def tile_level(d: Inputs, diff: np.ndarray, ts: int, **crit) -> Level:
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


def image_level(d: Inputs, diff: np.ndarray, **crit) -> Level:
    """Welch test of the whole image per channel."""
    total = lambda v: v.sum(axis=(0, 1))  # noqa: E731
    return _level(d, total, total(diff), total(d.for_sums("k3")), total(d.for_sums("k4")), summed=True, **crit)


def correlation_level(pix: Level, with_tails: bool, *, alpha_level, validity) -> tuple:
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
    level = Level(z=np.where(testable, z, 0.0), p=p, testable=testable, valid=valid, g1=g1, g2=g2,
                  z_crit=z_crit, var=zeros, ref_sum=zeros)
    return level, np.where(valid, S / n1, np.nan)


def family_p(levels: list) -> tuple:
    """``(Sidak-adjusted smallest p, number of tests)`` over the tested statistics of ``levels``
    (all tile sizes form one family)."""
    p = np.concatenate([lv.p[lv.valid].ravel() for lv in levels])
    m = int(p.size)
    return (sidak_p_value(float(p.min()), m) if m else 1.0), m
