"""Sidak's correction for a family of independent tests, written once for every check: ``m`` tests
at level ``a`` raise a false alarm with probability ``1 - (1 - a)^m`` (through ``log1p``/``expm1``
for tiny levels)."""
from __future__ import annotations

import math

__all__ = ["sidak", "sidak_p_value"]


def sidak(alpha: float, m: int) -> float:
    """Level of each of ``m`` independent tests that keeps the family at ``alpha``:
    ``1 - (1 - alpha) ** (1 / m)``.

    Examples
    --------
    >>> sidak(0.05, 1), round(sidak(0.01, 100), 7), round(sidak_p_value(sidak(0.01, 100), 100), 12)
    (0.05, 0.0001005, 0.01)
    """
    if not 0.0 < alpha < 1.0:
        raise ValueError(f"alpha must be in (0, 1), got {alpha}")
    if m < 1:
        raise ValueError(f"a family needs at least one test, got {m}")
    return float(-math.expm1(math.log1p(-alpha) / m))


def sidak_p_value(p_min: float, m: int) -> float:
    """Family-wise p-value of the smallest of ``m`` independent p-values, ``1 - (1 - p_min) ** m``
    (1 for an empty family).

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
