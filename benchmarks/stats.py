"""Sidak's correction for a family of independent tests, written once for every check.

A family of ``m`` independent tests, each at level ``a``, raises a false alarm with
probability ``1 - (1 - a)^m``. :func:`sidak` gives the level ``a`` of each test that keeps
the family at ``alpha`` (the chi-square tests, the gate's critical values, Mitsuba's
render-test rule); :func:`sidak_p_value` reads the same relation the other way: the
family's p-value from its smallest p-value (the gate's level p-values). Both go through
``log1p`` and ``expm1``, so tiny levels keep their precision.
Pure Python; the gate (:mod:`benchmarks.gate`) and the chi-square tests
(:mod:`benchmarks.chi2`) both use it.

Examples
--------
>>> round(sidak(0.01, 100), 7)
0.0001005
>>> round(sidak_p_value(sidak(0.01, 100), 100), 12)
0.01
"""
from __future__ import annotations

import math

__all__ = ["sidak", "sidak_p_value"]


def sidak(alpha: float, m: int) -> float:
    """Level of each of ``m`` independent tests so that the family's false-alarm rate is
    ``alpha``: ``1 - (1 - alpha) ** (1 / m)``.

    ``ValueError`` unless ``0 < alpha < 1`` and ``m >= 1``.

    Examples
    --------
    >>> sidak(0.05, 1)
    0.05
    """
    if not 0.0 < alpha < 1.0:
        raise ValueError(f"alpha must be in (0, 1), got {alpha}")
    if m < 1:
        raise ValueError(f"a family needs at least one test, got {m}")
    return float(-math.expm1(math.log1p(-alpha) / m))


def sidak_p_value(p_min: float, m: int) -> float:
    """Family-wise p-value of the smallest of ``m`` independent p-values,
    ``1 - (1 - p_min) ** m``: the inverse of :func:`sidak`. 1 for an empty family.

    Examples
    --------
    >>> round(sidak_p_value(0.01, 1), 12), round(sidak_p_value(1e-12, 1000), 15)
    (0.01, 1e-09)
    """
    if m <= 0 or p_min >= 1.0:
        return 1.0
    if p_min <= 0.0:
        return 0.0
    return float(-math.expm1(m * math.log1p(-p_min)))
