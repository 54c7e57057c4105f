"""``by_metric`` of a summary row: slope, efficiency and time to target under every metric but RMSE (the
row's own), so a report switches ``--metric`` without re-rendering (docs/conventions.md, Metrics). An
error at one spp is a mean over the seeds: sqrt of the corrected MSE, relMSE less the reference's own
noise, 1 - SSIM, FLIP."""
from __future__ import annotations

import math

import numpy as np

from .. import metrics as M
from ..constants import MIN_SLOPE_BUDGETS
from ..metrics.specs import METRICS, SPECS
from ..numbers import as_float, finite_mean, ratio
from .jobs import mitsuba_pairs


def relative_noise(ref) -> float:
    """The reference's own contribution to relMSE: mean(Var_ref / N_ref / (ref^2 + eps))."""
    if ref is None:
        return 0.0
    return M.relative_noise(np.asarray(ref.variance, dtype=np.float64) / max(int(ref.spp), 1), ref.mean)


def curve_errors(by_spp: dict, metric: str, *, rel_noise: float = 0.0) -> np.ndarray:
    """The metric's error per spp (sorted), mean over the seeds of ``by_spp[spp]`` (records).

    >>> curve_errors({1: [{"ssim": 0.5}, {"ssim": 0.7}], 4: [{"ssim": 0.9}]}, "ssim").round(3).tolist()
    [0.4, 0.1]
    """
    out = []
    for s in sorted(by_spp):
        v = finite_mean(r.get(SPECS[metric].field) for r in by_spp[s])
        if metric == "rmse":
            v = math.sqrt(v) if v > 0 else math.nan
        elif metric == "relmse":
            v = v - rel_noise
        elif metric == "ssim":
            v = 1.0 - v
        out.append(v if math.isfinite(v) and v > 0 else math.nan)
    return np.asarray(out, dtype=np.float64)


def tail_variance_image(tails):
    """The per-pixel per-sample variance of a tail reference (unbiased: m2 x n / (n - 1))."""
    m = tails.moments
    return np.asarray(m.m2, dtype=np.float64) * (m.n / max(m.n - 1.0, 1.0))


def metric_figures(metric: str, spps, errors, secs, *, target_rmse=None, unbiased: bool = False,
                   variance_image=None, ref=None, fit_from: int | None = None) -> dict:
    """Slope, efficiency and time to target of one curve under ``metric`` (errors from :func:`curve_errors`).

    ``variance_image``: the estimator's per-pixel per-sample variance at a high budget, for
    relMSE's efficiency when ``unbiased``; ``fit_from``: the slope is fitted to the budgets
    from this one on (the summary's ``slope_fit_from``).
    """
    spec = SPECS[metric]
    spps = np.asarray(spps, dtype=np.float64)
    secs = np.asarray(secs, dtype=np.float64)
    ok = np.isfinite(errors) & (errors > 0)
    target = as_float(target_rmse) if spec.target is None else spec.target
    fig = {"metric": metric, "label": spec.label, "unbiased_slope": spec.unbiased_slope, "slope": None,
           "slope_ci": None, "slope_steep": False, "error_at_top": None, "efficiency": None, "efficiency_source": None,
           "time_to_target": None, "target": target if math.isfinite(target) else None, "slope_range": None}
    fit = ok & (spps >= fit_from) if fit_from else ok
    if len(set(spps[fit])) >= MIN_SLOPE_BUDGETS:
        s = M.convergence_slope(spps[fit], errors[fit])
        fig["slope"] = s.slope
        fig["slope_ci"] = [s.ci_low, s.ci_high] if math.isfinite(s.ci_low) else None
        fig["slope_range"] = [int(spps[fit][0]), int(spps[fit][-1])]
        # steeper than Monte Carlo allows, beyond its interval: the low budgets read low (rare paths unseen)
        high = (fig["slope_ci"] or [s.slope] * 2)[1]
        fig["slope_steep"] = spec.unbiased_slope is not None and high < spec.unbiased_slope
    top = int(spps[-1]) if spps.size else 0
    fig["error_at_top"] = e_top = float(errors[-1]) if errors.size and ok[-1] else None
    expected = None
    if metric == "relmse" and unbiased and variance_image is not None and ref is not None and top >= 1:
        expected = M.relative_noise(variance_image, ref.mean) / top
    t_top = float(secs[-1]) if secs.size else math.nan
    if math.isfinite(t_top) and t_top > 0:
        if expected is not None and expected > 0:
            fig["efficiency"], fig["efficiency_source"] = M.efficiency(expected, t_top), "tail-reference variance / spp"
        elif e_top is not None:
            fig["efficiency"], fig["efficiency_source"] = M.efficiency(e_top, t_top), f"measured {spec.label}"
    okt = ok & np.isfinite(secs) & (secs > 0)
    if fig["target"] is not None and okt.any():
        t = M.time_to_error(secs[okt], errors[okt], fig["target"])
        fig["time_to_target"] = t if math.isfinite(t) else None
    return fig


def curve_metrics(by_spp: dict, secs, *, ref=None, target_rmse=None, unbiased: bool = False,
                  variance_image=None, fit_from: int | None = None) -> dict:
    """``by_metric`` of one curve: :func:`metric_figures` for every metric but RMSE."""
    noise = relative_noise(ref)
    return {m: metric_figures(m, sorted(by_spp), curve_errors(by_spp, m, rel_noise=noise), secs,
                              target_rmse=target_rmse, unbiased=unbiased, variance_image=variance_image, ref=ref,
                              fit_from=fit_from)
            for m in METRICS if m != "rmse"}


def add_metric_ratios(rows) -> None:
    """``by_metric[m]["efficiency_vs_mitsuba"]``: each curve's efficiency over Mitsuba's, same scene and size."""
    for r, m in mitsuba_pairs(rows):
        for name, fig in (r.get("by_metric") or {}).items():
            other = ((m or {}).get("by_metric") or {}).get(name) or {}
            fig["efficiency_vs_mitsuba"] = ratio(fig.get("efficiency"), other.get("efficiency"))
