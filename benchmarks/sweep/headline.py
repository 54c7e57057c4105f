"""The run's answer, per scene: how much noisier each strategy is than light sampling, at
equal samples and at equal time, and whether our tracer agrees with Mitsuba.

Noise is measured against each estimator's own expectation, so a biased estimator
(``light``, which misses indirect light) shows its bias as a percentage and its noise as
noise, never one for the other:

* **noise** of a curve: its per-sample relative variance,
  ``N = mean over pixels and channels of Var_p / (ref_p^2 + eps)`` (relMSE's weights and
  epsilon), from a high-budget run of the same estimator: our tail reference (16384 spp,
  its per-pixel central moments) or Mitsuba's reference (its per-sample variance from 16
  batches). ``N / spp`` is the curve's expected relMSE at ``spp``, bias aside.
* its **standard error**: pixels are independent, so ``se(N)^2 = sum_p w_p^2 Var(s2_p) / P^2``
  with ``Var(s2_p) = (m4_p - s2_p^2) / n`` from the tail reference's fourth moment
  (``2 s2_p^2 / (K - 1)`` for K batches of Mitsuba's). Where single samples carry the
  variance (``noise_lower_bound``) the figure is a lower bound and the interval says
  nothing about what the rare paths would add.
* **seconds per sample**: the wall time of that same high-budget render (seconds long,
  so not dominated by the per-render overhead of small images) over its samples.
* **ratios** against light sampling of the same scene: at equal spp ``N_s / N_light``;
  at equal time ``(N_s t_s) / (N_light t_light)`` (noise per second of work, the
  inverse of efficiency). 95% intervals from the standard errors on the log scale
  (delta method; the timings' own spread is not in them).
* the **verdict** of our tracer against Mitsuba: the bias test of our ``mis`` curve (the
  estimator of Mitsuba's ``path``) against the Mitsuba reference at the sweep's top
  budget (pass, fail or undetermined: ``benchmarks/STATISTICS.md``), with the smallest
  relative bias it would catch.

Examples
--------
>>> r, (lo, hi) = ratio_ci(2.0, 0.1, 1.0, 0.05)
>>> r, round(lo, 3), round(hi, 3)
(2.0, 1.741, 2.297)
"""
from __future__ import annotations

import math

import numpy as np

from ..constants import BASELINE, RELMSE_EPS, VERDICT_STRATEGY

__all__ = ["Z95", "relative_noise_of", "ratio_ci", "add_noise_ratios", "headline_rows"]
#: two-sided 95% normal quantile.
Z95 = 1.959963984540054


def relative_noise_of(variance, ref_mean, *, n: int | None = None, m4=None, batches: int | None = None) -> dict:
    """``{"noise", "noise_se"}``: a curve's per-sample relative variance and its standard error.

    Parameters
    ----------
    variance : array_like
        Per-pixel per-sample variance (H, W, 3) of the estimator.
    ref_mean : array_like
        The reference image: the weights ``1 / (ref^2 + eps)``.
    n, m4 : keyword-only
        Samples per pixel and per-pixel fourth central moment of a tail reference.
    batches : int, keyword-only
        Or: the number of batches the variance came from (a Mitsuba reference).

    Examples
    --------
    >>> v = np.full((2, 2, 3), 0.5); r = np.ones((2, 2, 3))
    >>> round(relative_noise_of(v, r, batches=16)["noise"], 4)
    0.495
    """
    var = np.asarray(variance, dtype=np.float64)
    ref = np.asarray(ref_mean, dtype=np.float64)
    w = 1.0 / (ref * ref + RELMSE_EPS)
    count = var.size
    noise = float(np.sum(w * var) / count)
    if m4 is not None and n:
        var_of_var = np.maximum(np.asarray(m4, dtype=np.float64) - var * var, 0.0) / n
    elif batches and batches > 1:
        var_of_var = 2.0 * var * var / (batches - 1)
    else:
        return {"noise": noise, "noise_se": None}
    return {"noise": noise, "noise_se": float(math.sqrt(np.sum(w * w * var_of_var)) / count)}


def ratio_ci(a: float, se_a: float | None, b: float, se_b: float | None):
    """``(a / b, [lo, hi])``: a ratio of two independent positive estimates with a 95% interval
    from their standard errors (delta method on the log scale); the interval is None when an
    error is unknown, the ratio None when ``b`` is not positive."""
    if not (b > 0) or a is None or not math.isfinite(a):
        return None, None
    r = a / b
    if a <= 0 or se_a is None or se_b is None:
        return r, None
    s = math.sqrt((se_a / a) ** 2 + (se_b / b) ** 2)
    return r, [r * math.exp(-Z95 * s), r * math.exp(Z95 * s)]


def add_noise_ratios(rows) -> None:
    """Each row's ``noise_vs_light`` and ``time_noise_vs_light`` (with ``_ci``) against the
    ``light`` row of the same scene and size (see the module docstring)."""
    base = {(r["scene"], r["width"], r["height"]): r for r in rows
            if r.get("renderer") == "ours" and r.get("strategy") == BASELINE}
    for r in rows:
        b = base.get((r["scene"], r["width"], r["height"]))
        r["noise_vs_light"] = r["noise_vs_light_ci"] = None
        r["time_noise_vs_light"] = r["time_noise_vs_light_ci"] = None
        if b is None or r.get("noise") is None or b.get("noise") is None:
            continue
        r["noise_vs_light"], r["noise_vs_light_ci"] = ratio_ci(r["noise"], r.get("noise_se"), b["noise"],
                                                               b.get("noise_se"))
        t, tb = r.get("seconds_per_sample"), b.get("seconds_per_sample")
        if t and tb:
            se = None if r.get("noise_se") is None else r["noise_se"] * t
            se_b = None if b.get("noise_se") is None else b["noise_se"] * tb
            r["time_noise_vs_light"], r["time_noise_vs_light_ci"] = ratio_ci(r["noise"] * t, se, b["noise"] * tb,
                                                                             se_b)


def headline_rows(rows) -> list:
    """One dict per (scene, width, height): the verdict of ours against the reference, the
    bias of light sampling, and each curve's noise ratios (for the report's first table).

    The rows are the summary's (after :func:`add_noise_ratios`); a section without our
    ``mis`` curve has verdict None.
    """
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
        h["curves"].append({k: r.get(k) for k in (
            "renderer", "strategy", "noise", "noise_se", "noise_lower_bound", "noise_source", "seconds_per_sample",
            "noise_vs_light", "noise_vs_light_ci", "time_noise_vs_light", "time_noise_vs_light_ci", "bias_verdict",
            "relative_bias", "relative_bias_ci", "exact")})
    return list(out.values())
