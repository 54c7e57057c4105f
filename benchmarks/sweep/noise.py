"""A curve's per-sample variance, noise and cost from a high-budget render of its estimator:
our tail reference (:mod:`benchmarks.tails`) or, for Mitsuba's own estimator, its reference.
"""
from __future__ import annotations

import math

import numpy as np

from reference_tracer.estimate import ImageEstimate

from .. import metrics as M
from .. import tails as T
from ..constants import RELMSE_EPS
from .by_metric import tail_variance_image
from .coerce import as_float
from .headline import relative_noise_of

__all__ = ["DEFAULT_BATCHES", "exact", "tail_variance", "tail_noise", "mitsuba_cost"]

#: batches of a Mitsuba reference whose store entry does not say (``benchmarks.references``).
DEFAULT_BATCHES = 16


def exact(tails) -> bool:
    """Whether an estimator has no noise beyond float rounding in any pixel (relative spread < 1e-6)."""
    return not np.any(T.sample_variance(tails) > 0)


def tail_variance(tails) -> dict:
    """The estimator's per-sample variance (mean over pixels) from its tail reference, and
    whether it is only a lower bound: where one sample carries more than half of a pixel's
    sum of squared deviations, the rarer paths that set the true variance were not seen."""
    return {"variance": float(T.sample_variance(tails).mean()), "variance_source": f"tail reference, {tails.spp} spp",
            "variance_lower_bound": T.variance_is_lower_bound(tails)}


def tail_noise(tails, ref) -> dict:
    """The curve's noise figures for the headline (:mod:`benchmarks.sweep.headline`): its
    per-sample relative variance from the tail reference, and the tail render's seconds per sample."""
    out = {"noise": None, "noise_se": None, "noise_lower_bound": T.variance_is_lower_bound(tails),
           "noise_source": f"tail reference, {tails.spp} spp", "exact": exact(tails),
           "seconds_per_sample": None}
    if ref is not None:
        out.update(relative_noise_of(tail_variance_image(tails), ref.mean, n=tails.spp, m4=tails.moments.m4))
    if out["exact"]:
        out.update(noise=0.0, noise_se=0.0)
    pixels = int(np.prod(np.shape(tails.mean)[:2]))
    if tails.seconds > 0:
        out["seconds_per_sample"] = float(tails.seconds) / (tails.spp * pixels)
    return out


def mitsuba_cost(row: dict, ref: ImageEstimate) -> None:
    """Mitsuba's variance and efficiency from its own high-spp reference (the same estimator,
    ``path``), as ours come from our tail references: expected MSE = variance / spp."""
    var = float(np.mean(ref.variance, dtype=np.float64)) * ref.spp / max(ref.spp - 1.0, 1.0)
    row.update(variance=var, variance_source=f"Mitsuba reference, {ref.spp} spp", variance_lower_bound=None)
    row.update(relative_noise_of(np.asarray(ref.variance, dtype=np.float64) * ref.spp / max(ref.spp - 1.0, 1.0),
                                 ref.mean, batches=getattr(ref, "batches", None) or DEFAULT_BATCHES),
               noise_lower_bound=None, noise_source=f"Mitsuba reference, {ref.spp} spp", exact=False,
               seconds_per_sample=None)
    ref_seconds = as_float(getattr(ref, "seconds", None))
    if math.isfinite(ref_seconds) and ref_seconds > 0:
        row["seconds_per_sample"] = ref_seconds / (ref.spp * int(np.prod(np.shape(ref.mean)[:2])))
    top, secs = row["spps"][-1], as_float(row.get("seconds_at_top"))
    if var > 0 and math.isfinite(secs) and secs > 0:
        row["efficiency"] = M.efficiency(var / top, secs)
        row["efficiency_source"] = "reference variance / spp"
        # relMSE likewise from the reference's per-pixel variance (the same estimator)
        rel = row.get("by_metric", {}).get("relmse")
        if rel is not None:
            expected = float(np.mean(ref.variance * (ref.spp / max(ref.spp - 1.0, 1.0))
                                     / (ref.mean * ref.mean + RELMSE_EPS))) / top
            if expected > 0:
                rel.update(efficiency=M.efficiency(expected, secs), efficiency_source="reference variance / spp")
