"""Store values (JSON numbers, nulls, strings) coerced before use: ``None`` is a figure not computed."""
from __future__ import annotations

import math

import numpy as np


def finite(v):
    """``v`` as a finite float, or None (None, bools, non-numbers, NaN and inf).

    >>> finite("2.5"), finite(None), finite(float("nan")), finite(True)
    (2.5, None, None, None)
    """
    v = as_float(v)
    return v if math.isfinite(v) else None


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


def finite_mean(values) -> float:
    """The mean of the finite ones of ``values`` (each :func:`as_float`); NaN when none is.

    >>> finite_mean([1, "3", None, float("inf")])
    2.0
    """
    a = np.asarray([as_float(v) for v in values], dtype=np.float64)
    a = a[np.isfinite(a)]
    return float(a.mean()) if a.size else math.nan
