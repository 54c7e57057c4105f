"""Input checks shared by the metrics: image shapes, NaN policy, sample counts."""
from __future__ import annotations

import math

import numpy as np

from ..display import as_image

NAN_POLICIES = ("propagate", "omit", "raise")


def same_shape(**arrays: np.ndarray) -> None:
    """Raise ``ValueError`` naming the shapes unless all arrays have exactly the same shape."""
    shapes = {k: v.shape for k, v in arrays.items()}
    if len(set(shapes.values())) > 1:
        desc = ", ".join(f"{k}{s}" for k, s in shapes.items())
        raise ValueError(f"image shapes differ: {desc}")


def check_policy(nan_policy: str) -> None:
    if nan_policy not in NAN_POLICIES:
        raise ValueError(f"nan_policy must be one of {NAN_POLICIES}; got {nan_policy!r}")


def nan_mask(nan_policy: str, **arrays: np.ndarray):
    """The entries to use: ``None`` (all), ``"nan"`` (result is NaN) or a boolean mask."""
    check_policy(nan_policy)
    bad = np.zeros(next(iter(arrays.values())).shape, dtype=bool)
    for a in arrays.values():
        bad |= np.isnan(a)
    if not bad.any():
        return None
    if nan_policy == "raise":
        names = [k for k, a in arrays.items() if np.isnan(a).any()]
        raise ValueError(f"NaN in {', '.join(names)} ({int(bad.sum())} entries) with nan_policy='raise'")
    if nan_policy == "propagate":
        return "nan"
    return ~bad


def masked_mean(values: np.ndarray, mask) -> float:
    """Mean of ``values`` over a :func:`nan_mask` result."""
    if mask is None:
        return float(np.mean(values))
    if isinstance(mask, str) or not mask.any():
        return math.nan
    return float(np.mean(values[mask]))


def positive_spp(spp, name: str = "spp") -> float:
    """``spp`` as a float; ``ValueError`` unless positive and finite."""
    n = float(spp)
    if not (n > 0 and math.isfinite(n)):
        raise ValueError(f"{name} must be a positive finite number; got {spp!r}")
    return n


def reference_noise(ref: np.ndarray, ref_var, ref_spp) -> np.ndarray:
    """``ref_var / ref_spp``, the variance of the reference's pixel means, checked against ``ref``."""
    v = as_image(ref_var, "ref_var")
    same_shape(ref=ref, ref_var=v)
    if np.any(v < 0):
        raise ValueError("ref_var has negative entries")
    return v / positive_spp(ref_spp, "ref_spp")
