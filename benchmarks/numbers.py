"""Numbers read from a store or measured, coerced before use, written once for the sweep, the speed benchmarks
and the report: ``None`` (and NaN) is a figure not computed, a bool or a string is no number, and a ratio has
a positive denominator."""
from __future__ import annotations

import math
import statistics

import numpy as np

__all__ = ["as_float", "finite", "is_finite", "finite_values", "finite_mean", "median", "ratio"]


def as_float(v) -> float:
    """``v`` as a float for arithmetic: NaN for None, bools and non-numbers (inf stays inf).

    >>> as_float("2.5"), as_float(None), as_float(True), as_float(float("inf"))
    (2.5, nan, nan, inf)
    """
    if v is None or isinstance(v, bool):
        return math.nan
    try:
        return float(v)
    except (TypeError, ValueError):
        return math.nan


def finite(v):
    """``v`` as a finite float, or None (None, bools, non-numbers, NaN and inf).

    >>> finite("2.5"), finite(None), finite(float("nan")), finite(True)
    (2.5, None, None, None)
    """
    v = as_float(v)
    return v if math.isfinite(v) else None


def is_finite(v) -> bool:
    """Whether :func:`as_float` of ``v`` is finite.

    >>> is_finite(2), is_finite("x"), is_finite(None), is_finite(float("inf"))
    (True, False, False, False)
    """
    return math.isfinite(as_float(v))


def finite_values(xs) -> list:
    """The finite ones of ``xs``, each :func:`as_float` (None, bools, non-numbers, NaN and infinities left out).

    >>> finite_values([1, None, float("nan"), "2.5", True, "x", float("-inf")])
    [1.0, 2.5]
    """
    return [v for v in map(as_float, xs) if math.isfinite(v)]


def finite_mean(values) -> float:
    """The mean of the finite ones of ``values`` (each :func:`as_float`); NaN when none is.

    >>> finite_mean([1, "3", None, float("inf")])
    2.0
    """
    a = np.asarray([as_float(v) for v in values], dtype=np.float64)
    a = a[np.isfinite(a)]
    return float(a.mean()) if a.size else math.nan


def median(xs) -> float:
    """Median of the finite values of ``xs`` (None skipped); NaN when none is left.

    >>> median([3.0, None, 1.0, float("nan"), 2.0]), median([None])
    (2.0, nan)
    """
    xs = finite_values(xs)
    return statistics.median(xs) if xs else float("nan")


def ratio(a, b):
    """``a / b`` over a positive denominator, both finite (each :func:`as_float`); None otherwise.

    >>> ratio(3, 2), ratio(1.0, 0.0), ratio(1.0, -2.0), ratio(None, 2.0), ratio(1.0, float("inf"))
    (1.5, None, None, None, None)
    """
    a, b = as_float(a), as_float(b)
    return a / b if math.isfinite(a) and math.isfinite(b) and b > 0 else None
