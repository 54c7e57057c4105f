"""Numbers read back from the store (JSON numbers, nulls, strings) coerced before use.

The sweep's records and summary keep ``None`` for a figure that could not be computed;
these coercions are what the sweep, its summary and the printed tables apply.
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["finite", "as_float", "finite_mean"]


def finite(v):
    """``v`` as a finite float, or None (None, bools, non-numbers, NaN and inf).

    The one coercion of store values (JSON numbers, nulls) before they are stored or shown.

    >>> finite("2.5"), finite(None), finite(float("nan")), finite(True)
    (2.5, None, None, None)
    """
    if v is None or isinstance(v, bool):
        return None
    try:
        v = float(v)
    except (TypeError, ValueError):
        return None
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
    """The mean of the finite ones of ``values`` (each :func:`as_float`): a figure's mean over
    seeds, skipping those that could not be computed; NaN when none is finite.

    >>> finite_mean([1, "3", None, float("inf")])
    2.0
    """
    a = np.asarray([as_float(v) for v in values], dtype=np.float64)
    a = a[np.isfinite(a)]
    return float(a.mean()) if a.size else math.nan
