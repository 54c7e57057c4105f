"""The run's answer, per scene: each curve's noise (per-sample relative variance from a
high-budget render of its estimator), its ratios to light sampling at equal spp and at
equal time with 95% intervals, and the verdict of ours against Mitsuba. The definitions
are in ``benchmarks/STATISTICS.md``; the report's first table shows them.

Examples
--------
>>> r, (lo, hi) = ratio_ci(2.0, 0.1, 1.0, 0.05)
>>> r, round(lo, 3), round(hi, 3)
(2.0, 1.741, 2.297)
"""
from __future__ import annotations

import math

import numpy as np
from scipy import stats

from reference_tracer.estimate import ImageEstimate

from .. import metrics as M
from .. import tails as T
from ..constants import BASELINE, RELMSE_EPS, VERDICT_STRATEGY
from ..numbers import as_float
from .by_metric import tail_variance_image

#: two-sided 95% normal quantile.
Z95 = float(stats.norm.isf(0.025))
#: batches of a Mitsuba reference whose store entry does not say (``benchmarks.references``).
DEFAULT_BATCHES = 16


def relative_noise_of(variance, ref_mean, *, n: int | None = None, m4=None, batches: int | None = None) -> dict:
    """``{"noise", "noise_se"}``: :func:`benchmarks.metrics.relative_noise` of the per-pixel per-sample
    ``variance`` against ``ref_mean``, and its standard error from a tail reference's ``n`` samples and
    fourth moment ``m4``, or from the ``batches`` of a Mitsuba reference.

    >>> v = np.full((2, 2, 3), 0.5); r = np.ones((2, 2, 3))
    >>> round(relative_noise_of(v, r, batches=16)["noise"], 4)
    0.495
    """
    var = np.asarray(variance, dtype=np.float64)
    ref = np.asarray(ref_mean, dtype=np.float64)
    noise = M.relative_noise(var, ref)
    w = 1.0 / (ref * ref + RELMSE_EPS)
    if m4 is not None and n:
        var_of_var = np.maximum(np.asarray(m4, dtype=np.float64) - var * var, 0.0) / n
    elif batches and batches > 1:
        var_of_var = 2.0 * var * var / (batches - 1)
    else:
        return {"noise": noise, "noise_se": None}
    return {"noise": noise, "noise_se": float(math.sqrt(np.sum(w * w * var_of_var)) / var.size)}


def exact(tails) -> bool:
    """Whether an estimator has no noise beyond float rounding in any pixel."""
    return not np.any(T.sample_variance(tails) > 0)


def _seconds_per_sample(seconds, spp: int, image) -> float | None:
    seconds = as_float(seconds)
    pixels = int(np.prod(np.shape(image)[:2]))
    return seconds / (spp * pixels) if math.isfinite(seconds) and seconds > 0 else None


def tail_noise(tails, ref) -> dict:
    """A curve of ours: variance, noise and seconds per sample from its tail reference.

    ``variance_lower_bound``/``noise_lower_bound``: single samples carry the variance, so
    the rarer paths that set it were not seen.
    """
    source = f"tail reference, {tails.spp} spp"
    lower = T.variance_is_lower_bound(tails)
    out = {"variance": float(T.sample_variance(tails).mean()), "variance_source": source,
           "variance_lower_bound": lower, "noise": None, "noise_se": None, "noise_lower_bound": lower,
           "noise_source": source, "exact": exact(tails),
           "seconds_per_sample": _seconds_per_sample(tails.seconds, tails.spp, tails.mean)}
    if ref is not None:
        out.update(relative_noise_of(tail_variance_image(tails), ref.mean, n=tails.spp, m4=tails.moments.m4))
    if out["exact"]:
        out.update(noise=0.0, noise_se=0.0)
    return out


def mitsuba_cost(row: dict, ref: ImageEstimate) -> None:
    """Mitsuba's variance, noise and efficiency from its own high-spp reference (the same
    estimator, ``path``), as ours come from our tail references: expected MSE = variance / spp."""
    var_image = np.asarray(ref.variance, dtype=np.float64) * ref.spp / max(ref.spp - 1.0, 1.0)
    var = float(var_image.mean())
    source = f"Mitsuba reference, {ref.spp} spp"
    row.update(variance=var, variance_source=source, variance_lower_bound=None, noise_lower_bound=None,
               noise_source=source, exact=False,
               seconds_per_sample=_seconds_per_sample(getattr(ref, "seconds", None), ref.spp, ref.mean),
               **relative_noise_of(var_image, ref.mean, batches=getattr(ref, "batches", None) or DEFAULT_BATCHES))
    top, secs = row["spps"][-1], as_float(row.get("seconds_at_top"))
    if not (var > 0 and math.isfinite(secs) and secs > 0):
        return
    row.update(efficiency=M.efficiency(var / top, secs), efficiency_source="reference variance / spp")
    rel = row.get("by_metric", {}).get("relmse")
    expected = M.relative_noise(var_image, ref.mean) / top
    if rel is not None and expected > 0:
        rel.update(efficiency=M.efficiency(expected, secs), efficiency_source="reference variance / spp")


def ratio_ci(a: float, se_a: float | None, b: float, se_b: float | None):
    """``(a / b, [lo, hi])``: a ratio of two independent positive estimates with a 95% interval
    (delta method on the log scale); the interval is None when an error is unknown, the ratio
    None when ``b`` is not positive."""
    if not (b > 0) or a is None or not math.isfinite(a):
        return None, None
    r = a / b
    if a <= 0 or se_a is None or se_b is None:
        return r, None
    s = math.sqrt((se_a / a) ** 2 + (se_b / b) ** 2)
    return r, [r * math.exp(-Z95 * s), r * math.exp(Z95 * s)]


def add_noise_ratios(rows) -> None:
    """Each row's ``noise_vs_light`` and ``time_noise_vs_light`` (with ``_ci``) against our
    ``light`` row of the same scene and size."""
    base = {(r["scene"], r["width"], r["height"]): r for r in rows
            if r.get("renderer") == "ours" and r.get("strategy") == BASELINE}
    for r in rows:
        b = base.get((r["scene"], r["width"], r["height"]))
        r["noise_vs_light"] = r["noise_vs_light_ci"] = None
        r["time_noise_vs_light"] = r["time_noise_vs_light_ci"] = None
        if b is None or r.get("noise") is None or b.get("noise") is None:
            continue
        se, se_b = r.get("noise_se"), b.get("noise_se")
        r["noise_vs_light"], r["noise_vs_light_ci"] = ratio_ci(r["noise"], se, b["noise"], se_b)
        t, tb = r.get("seconds_per_sample"), b.get("seconds_per_sample")
        if t and tb:
            r["time_noise_vs_light"], r["time_noise_vs_light_ci"] = ratio_ci(
                r["noise"] * t, None if se is None else se * t, b["noise"] * tb, None if se_b is None else se_b * tb)


_CURVE_FIELDS = ("renderer", "strategy", "noise", "noise_se", "noise_lower_bound", "noise_source",
                 "seconds_per_sample", "noise_vs_light", "noise_vs_light_ci", "time_noise_vs_light",
                 "time_noise_vs_light_ci", "bias_verdict", "relative_bias", "relative_bias_ci", "exact")


def headline_rows(rows) -> list:
    """One dict per (scene, width, height) of the summary's rows: the verdict of our ``mis``
    (None without it), the bias of light sampling and each curve's noise ratios."""
    out = {}
    for r in rows:
        key = (r["scene"], r["width"], r["height"])
        h = out.setdefault(key, {"scene": r["scene"], "width": r["width"], "height": r["height"], "verdict": None,
                                 "verdict_reason": None, "min_detectable_bias": None, "verdict_spp": None,
                                 "reference": None, "light_bias": None, "light_bias_ci": None, "curves": []})
        if r.get("renderer") == "ours" and r.get("strategy") == VERDICT_STRATEGY:
            h.update(verdict=r.get("bias_verdict"), verdict_reason=r.get("bias_reason"),
                     min_detectable_bias=r.get("bias_min_detectable"), verdict_spp=r.get("bias_spp"),
                     verdict_seeds=r.get("bias_seeds"), verdict_spp_needed=r.get("bias_spp_needed"),
                     reference=r.get("reference_kind"))
        if r.get("renderer") == "ours" and r.get("strategy") == BASELINE:
            h.update(light_bias=r.get("relative_bias"), light_bias_ci=r.get("relative_bias_ci"),
                     light_verdict=r.get("bias_verdict"))
        h["curves"].append({k: r.get(k) for k in _CURVE_FIELDS})
    return list(out.values())
