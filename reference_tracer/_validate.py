"""Loud validation helpers: every error names the offending field."""
from __future__ import annotations

import math

import numpy as np


def finite_scalar(name: str, value, *, lo: float | None = None, hi: float | None = None,
                  lo_open: bool = False) -> float:
    """Return ``value`` as a float, or raise ``ValueError`` naming ``name``."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(x):
        raise ValueError(f"{name} must be finite, got {x!r}")
    if lo is not None and (x < lo or (lo_open and x == lo)):
        raise ValueError(f"{name} must be {'>' if lo_open else '>='} {lo}, got {x!r}")
    if hi is not None and x > hi:
        raise ValueError(f"{name} must be <= {hi}, got {x!r}")
    return x


def vector3(name: str, value) -> tuple:
    """Return a finite 3-vector as a tuple of floats."""
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a 3-vector of numbers, got {value!r}") from None
    if a.shape != (3,):
        raise ValueError(f"{name} must be a 3-vector, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite (no NaN/Inf), got {tuple(a.tolist())}")
    return tuple(float(x) for x in a)


#: the largest value of the float32 images both renderers write: radiance above it is infinite there.
FLOAT32_MAX = float(np.finfo(np.float32).max)


def colour(name: str, value, *, upper: float | None) -> tuple:
    """Return an RGB triple; a scalar is broadcast. Components in [0, upper].

    With ``upper=None`` (radiance) the bound is :data:`FLOAT32_MAX`: a radiance the image
    cannot hold would turn every pixel it reaches infinite.
    """
    a = np.asarray(value, dtype=np.float64) if not isinstance(value, (str, bytes)) else None
    if a is None or a.ndim > 1 or (a.ndim == 1 and a.shape != (3,)):
        raise ValueError(f"{name} must be a number or an RGB triple, got {value!r}")
    a = np.broadcast_to(a, (3,))
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite (no NaN/Inf), got {tuple(a.tolist())}")
    if np.any(a < 0):
        raise ValueError(f"{name} must be >= 0, got {tuple(a.tolist())}")
    if upper is not None and np.any(a > upper):
        raise ValueError(f"{name} must lie in [0, {upper}], got {tuple(a.tolist())}")
    if upper is None and np.any(a > FLOAT32_MAX):
        raise ValueError(f"{name} must be at most {FLOAT32_MAX:.7g} (the largest value of a float32 image), "
                         f"got {tuple(a.tolist())}")
    return tuple(float(x) for x in a)


#: the largest count the C++ core takes (its ``int``: spp, threads, image size, depth).
INT_MAX = 2**31 - 1
#: the largest seed (the core's ``uint64_t``).
SEED_MAX = 2**64 - 1


def positive_int(name: str, value, *, minimum: int = 1, maximum: int = INT_MAX) -> int:
    """Return ``value`` as an int in ``[minimum, maximum]``, or raise ``ValueError`` naming ``name``.

    The default ``maximum`` is the C++ core's ``int``: a larger value would reach the
    binding and fail there with a message naming no field.

    Examples
    --------
    >>> positive_int("spp", 2**31)
    Traceback (most recent call last):
    ...
    ValueError: spp must be <= 2147483647, got 2147483648
    """
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{name} must be an integer, got {value!r}")
    if value < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {value}")
    if value > maximum:
        raise ValueError(f"{name} must be <= {maximum}, got {value}")
    return int(value)
