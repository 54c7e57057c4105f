"""The levels of :func:`benchmarks.gate.compare` (pixel, tile, image, neighbour correlation):
their statistics, which of them may be tested (:func:`edgeworth_error`, the one-term Edgeworth
bound on a statistic's normal tail; :func:`spp_needed`), and a level's Sidak family p-value.

The correlation level tests the independence of pixels that every other level's standard
error assumes (a tracer whose pixels share random numbers keeps each mean right):
``S = sum z_p z_q`` over neighbouring pairs, ``E[S] = 0``, ``Var[S] = N_pairs`` under the
null hypothesis, one-sided (``benchmarks/STATISTICS.md``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import stats

from ..stats import sidak, sidak_p_value
from .inputs import Inputs, neighbourhood_floor

__all__ = ["Level", "pixel_level", "tile_level", "image_level", "correlation_level", "family_p",
           "neighbour_products", "MIN_PAIRS", "DEFAULT_VALIDITY", "edgeworth_error", "spp_needed"]

#: Largest :func:`edgeworth_error` at a level's critical value for a statistic to be tested.
DEFAULT_VALIDITY = 1.0


def edgeworth_error(z, g1, g2):
    """Relative error bound of the normal upper tail ``Q(z)`` for skewness ``g1`` and excess
    kurtosis ``g2`` (one-term Edgeworth expansion):
    ``phi(z) / Q(z) * (|g1| |He2(z)| / 6 + |g2| |He3(z)| / 24 + g1^2 |He5(z)| / 72)``.

    Examples
    --------
    >>> float(edgeworth_error(3.0, 0.0, 0.0))
    0.0
    >>> round(float(edgeworth_error(3.0, 0.1, 0.0)), 3)
    0.446
    """
    z = np.asarray(z, dtype=np.float64)
    he2, he3, he5 = z * z - 1.0, z ** 3 - 3.0 * z, z ** 5 - 10.0 * z ** 3 + 15.0 * z
    mills = stats.norm.pdf(z) / stats.norm.sf(z)
    g1 = np.abs(g1)
    return mills * (g1 * np.abs(he2) / 6.0 + np.abs(g2) * np.abs(he3) / 24.0 + g1 * g1 * np.abs(he5) / 72.0)


def spp_needed(z: float, g1: float, g2: float, spp: float, validity: float = DEFAULT_VALIDITY) -> int:
    """About how many spp make :func:`edgeworth_error` at ``z`` drop to ``validity``, given the
    shape ``g1``, ``g2`` at ``spp`` (falling as ``1/sqrt(n)`` and ``1/n``).

    Examples
    --------
    >>> spp_needed(3.0, 0.4, 0.0, 100) > 100
    True
    """
    if edgeworth_error(z, g1, g2) <= validity:
        return int(spp)
    lo, hi = 0.0, 64.0  # log2 of the factor
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        f = 2.0 ** mid
        if edgeworth_error(z, g1 / math.sqrt(f), g2 / f) <= validity:
            hi = mid
        else:
            lo = mid
    return int(math.ceil(spp * 2.0 ** hi))


def _welch_from_sums(diff, a, b, a2, b2, n_t, n_r, tol, fa=None, fa2=None):
    """``(stat, p, testable)``: Welch statistic of a summed difference ``diff`` from the sums of the
    test's and reference's variances of the mean (``a``, ``b``), of their squares (``a2``, ``b2``, for
    the Satterthwaite dof) and an optional floor of ``a`` (``fa``, ``fa2``); where both variances are 0
    a difference beyond ``tol`` is certain."""
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
    p[pos] = np.minimum(2.0 * stats.t.sf(np.abs(stat[pos]), dof[pos]), 1.0)  # dof inf: normal
    zero = ~pos
    differs = zero & (np.abs(diff) > tol)
    stat[differs] = np.copysign(np.inf, diff[differs])
    p[differs] = 0.0
    testable = pos | differs
    return stat, p, testable


@dataclass
class Level:
    """One level's statistics, arrays of one shape: ``testable`` (carries evidence), ``valid``
    (testable and normal enough at ``z_crit``), ``var`` (the statistic's variance), ``ref_sum``."""

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
    """The Welch statistics of the reduced ``diff`` with cumulants ``K3``, ``K4``: tested where
    :func:`edgeworth_error` at the level's critical value is at most ``validity``, the p-value
    inflated by ``1 + e(min(|z|, z_crit))`` (``benchmarks/STATISTICS.md``, step 3)."""
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

    The variances (not the difference) are floored by their neighbourhood mean, except where
    neither side has noise: a neighbour's noise says nothing about a directly seen light.
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
    """Welch test per ``ts x ts`` tile and channel (zero padding to whole tiles)."""
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
    """``(level, rho)``: the one-sided test of positive correlation of neighbouring pixels'
    standardised differences per channel (:func:`neighbour_products`), from the pixel
    level's floored statistics and shapes, and ``rho = S / N_pairs``; tested only with tails."""
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


#: Fewest neighbour pairs for a correlation statistic.
MIN_PAIRS = 16


def _pairs(a: np.ndarray):
    return ((a[:, :-1], a[:, 1:]), (a[:-1, :], a[1:, :]))


def neighbour_products(z, g1, g2, use) -> tuple:
    """``(S, n_pairs, K3, K4)`` per channel: the sum of the products of neighbouring standardised
    differences ``z`` (skewness ``g1``, excess kurtosis ``g2``; pixels where ``use`` is False take
    no part), its number of pairs (its variance under the null hypothesis) and cumulants
    ``K3 = sum g1_p g1_q``, ``K4 = sum ((3 + g2_p)(3 + g2_q) - 3)``.

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> z = rng.standard_normal((32, 32, 1))
    >>> zero, ok = np.zeros_like(z), np.ones_like(z, bool)
    >>> S, n, _, _ = neighbour_products(z, zero, zero, ok)
    >>> int(n[0]), bool(abs(S[0] / np.sqrt(n[0])) < 3)
    (1984, True)
    >>> shared = z + np.roll(z, 1, axis=0) + np.roll(z, 1, axis=1)  # neighbours share noise
    >>> S, n, _, _ = neighbour_products(shared / np.sqrt(3), zero, zero, ok)
    >>> bool(S[0] / np.sqrt(n[0]) > 8)
    True
    """
    use = np.asarray(use, bool)
    z = np.where(use, np.asarray(z, float), 0.0)
    g1 = np.where(use, np.asarray(g1, float), 0.0)
    m4 = np.where(use, 3.0 + np.asarray(g2, float), 0.0)
    u = use.astype(float)
    S = n = K3 = K4 = 0.0
    for (za, zb), (ga, gb), (ma, mb), (ua, ub) in zip(_pairs(z), _pairs(g1), _pairs(m4), _pairs(u)):
        both = ua * ub
        S = S + (za * zb).sum(axis=(0, 1))
        n = n + both.sum(axis=(0, 1))
        K3 = K3 + (ga * gb).sum(axis=(0, 1))
        K4 = K4 + (ma * mb - 3.0 * both).sum(axis=(0, 1))
    return S, n, K3, K4
