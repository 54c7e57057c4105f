"""The gate's correlation level: are the errors of neighbouring pixels independent?

Every other level of :func:`benchmarks.gate.compare` tests a *mean* (a pixel, a tile, the
image). A tracer can keep every mean right and still be wrong in its noise: pixels that
share random numbers (the self-test's ``correlated_pixel_streams``) are each unbiased,
but their errors move together. Every standard error of the other levels assumes
independent pixels, so such a render is judged with standard errors that are too small,
and no test of means flags it.

This level tests the assumption directly. With ``z_p = (x_p - r_p) / sqrt(v_p)`` the
standardised difference of pixel ``p`` (``v_p``: the variance of the difference of the
two pixel means, the test side floored by the tail reference of the same estimator), the
statistic per channel is the sum over horizontally and vertically neighbouring pairs

    S = sum_(p,q) z_p z_q,   E[S] = 0,   Var[S] = N_pairs

under the null hypothesis (same expectations, independent pixels): the products are
uncorrelated with one another, even where two pairs share a pixel, because
``E[z_p z_q z_q z_s] = E[z_p] E[z_q^2] E[z_s] = 0``. Positive correlation between
neighbours makes ``S`` large; the test is one-sided. The reported *neighbour correlation*
is ``S / N_pairs``: about 0 for a sound render (its standard deviation is
``1 / sqrt(N_pairs)``, 0.022 per channel at 32x32), +0.18 for ``correlated_pixel_streams``
on ``cornell_box`` at 1024 spp.

Heavy tails: ``S`` is a sum of products whose third and fourth cumulants follow from the
pixels' (``K3[S] = sum g1_p g1_q`` and ``K4[S] ~ sum ((3 + g2_p)(3 + g2_q) - 3)``, with
``g1_p``, ``g2_p`` the skewness and excess kurtosis of ``z_p``). Where unsampled rare
paths leave many pixels low together (a false "positive correlation"), the pixels'
skewness is large, and :func:`benchmarks.gate.heavy_tails.edgeworth_error` keeps the
statistic untested, as at the other levels. A bias that varies smoothly across the image
also raises ``S`` (neighbouring pixels share its sign): a failure names both causes.
"""
from __future__ import annotations

import numpy as np

__all__ = ["neighbour_products", "MIN_PAIRS"]

#: Fewest neighbour pairs for a correlation statistic.
MIN_PAIRS = 16


def _pairs(a: np.ndarray):
    """The (left, right) and (top, bottom) neighbour views of an (H, W, C) image."""
    return ((a[:, :-1], a[:, 1:]), (a[:-1, :], a[1:, :]))


def neighbour_products(z, g1, g2, use) -> tuple:
    """Sum of the products of neighbouring standardised differences, per channel.

    Parameters
    ----------
    z, g1, g2 : ndarray, shape (H, W, C)
        Standardised differences (mean 0 and variance at most 1 under the null
        hypothesis) and their skewness and excess kurtosis.
    use : ndarray of bool, same shape
        Pixels that carry noise (others take no part in any pair).

    Returns
    -------
    S, n_pairs, K3, K4 : ndarray, shape (C,)
        The statistic, its number of pairs (its variance under the null hypothesis), and
        its third and fourth cumulants.

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
