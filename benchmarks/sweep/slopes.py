"""A curve's convergence slope: the fit of log RMSE on log spp, which budgets it may use, and
why a slope says nothing yet (heavy-tailed budgets where renders miss the rare paths).
"""
from __future__ import annotations

import math

import numpy as np

from .. import metrics as M
from ..constants import MIN_SLOPE_BUDGETS, RELMSE_EPS

__all__ = ["slope_stats", "slope_status", "mse_reliable_from", "reliable_points_only"]


def slope_stats(spps, mse_c, mse_p) -> dict:
    """Convergence: one point per spp, RMSE from the seed-averaged reference-noise-corrected MSE;
    no slope from fewer than :data:`MIN_SLOPE_BUDGETS` budgets (``slope_range``: the first and
    last budget fitted)."""
    ok = np.isfinite(mse_c) & (mse_c > 0)
    row = dict(slope=None, slope_ci=None, slope_stderr=None, slope_points=int(ok.sum()), slope_range=None)
    if len(set(np.asarray(spps)[ok])) >= MIN_SLOPE_BUDGETS:
        fit = M.convergence_slope(np.asarray(spps)[ok], np.sqrt(mse_c[ok]))
        row.update(slope=fit.slope, slope_stderr=fit.stderr,
                   slope_ci=[fit.ci_low, fit.ci_high] if math.isfinite(fit.ci_low) else None,
                   slope_range=[int(np.asarray(spps)[ok][0]), int(np.asarray(spps)[ok][-1])])
    okp = np.isfinite(mse_p) & (mse_p > 0)
    row["slope_uncorrected"] = None
    if len(set(np.asarray(spps)[okp])) >= MIN_SLOPE_BUDGETS:
        row["slope_uncorrected"] = M.convergence_slope(np.asarray(spps)[okp], np.sqrt(mse_p[okp])).slope
    return row


def slope_status(row: dict):
    """Why the fitted slope says nothing yet, or None.

    Where the gate cannot decide even at the curve's top budget (its image mean is too far
    from normal: ``bias_verdict`` 'undetermined'), the renders have mostly not met the rare
    paths that carry the estimator's variance, so their measured MSE sits far below its
    expectation, by a factor that shrinks as spp grows: the fitted slope is then shallower
    than the estimator's (``uniform`` on ``glossy_plates``), and its regression interval
    does not cover that. The slope is kept in the row (it is what was measured) and marked.
    """
    if row.get("bias_verdict") != "undetermined":
        kept = len(row.get("spps") or []) - len(row.get("slope_excluded_spps") or [])
        if row.get("slope_excluded_spps") and kept < MIN_SLOPE_BUDGETS:
            return (f"undetermined: heavy-tailed below {row['slope_fit_from']} spp (the measured MSE misses "
                    f"rare paths there), and {kept} rendered budget(s) at or above it, fewer than "
                    f"{MIN_SLOPE_BUDGETS}")
        if row.get("slope") is None:
            return f"no slope: fewer than {MIN_SLOPE_BUDGETS} rendered budgets"
        return None
    need = row.get("bias_spp_needed")
    return ("undetermined: heavy-tailed at these budgets (the measured MSE misses rare paths)"
            + (f"; the gate needs about {need} samples per pixel" if need else ""))


def mse_reliable_from(tails, *, seeds: int) -> int:
    """The smallest budget from which the seed-averaged MSE (and relMSE) of this estimator
    is near its expectation, from its tail reference (``benchmarks/STATISTICS.md``).

    One render's MSE at ``n`` spp over ``P`` pixels, ``(1/P) sum_p (xbar_p - mu_p)^2``, has
    expectation ``sum_p s2_p / (P n)`` and, from the samples' fourth cumulants ``k4_p``, a
    variance of at least ``sum_p k4_p / (P^2 n^3)``: relative to the squared expectation,
    ``K = sum_p k4_p / (sum_p s2_p)^2`` over ``n``, and over ``n k`` for the mean of ``k``
    seeds. Where that exceeds 1 the MSE rests on rare paths: most renders missed them and
    read low, a few met them and read high. The budget is ``ceil(K / k)``, with ``K`` the
    largest over the channels and over the weights of MSE (1) and relMSE
    (``1 / (mu^2 + eps)``).

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> m = SimpleNamespace(m2=np.ones((4, 4, 3)), kappa4=np.full((4, 4, 3), 160.0))
    >>> mse_reliable_from(SimpleNamespace(moments=m, mean=np.ones((4, 4, 3))), seeds=2)
    5
    """
    m2 = np.asarray(tails.moments.m2, dtype=np.float64)
    k4 = np.asarray(tails.moments.kappa4, dtype=np.float64)
    mu = np.asarray(tails.mean, dtype=np.float64)
    worst = 0.0
    for w in (np.ones_like(mu), 1.0 / (mu * mu + RELMSE_EPS)):
        num, den = (w * w * k4).sum(axis=(0, 1)), (w * m2).sum(axis=(0, 1)) ** 2
        with np.errstate(divide="ignore", invalid="ignore"):
            k = np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0)
        worst = max(worst, float(np.max(k)))
    return max(1, int(math.ceil(worst / max(int(seeds), 1))))


def reliable_points_only(spps, mse_c, mse_p, row: dict) -> dict:
    """The slope refitted without the budgets below ``slope_fit_from`` (the per-point rule).

    Below it, renders have mostly not met the rare paths that carry the variance, their MSE
    sits below expectation and would flatten the fit. Where the gate is undetermined at the
    top budget :func:`slope_status` marks the whole slope instead.
    """
    start = row.get("slope_fit_from")
    if not start or row.get("bias_verdict") == "undetermined":
        return {"slope_excluded_spps": []}
    keep = [i for i, s in enumerate(spps) if s >= start]
    excluded = [int(s) for s in spps if s < start]
    if not excluded:
        return {"slope_excluded_spps": []}
    out = slope_stats([spps[i] for i in keep], mse_c[keep], mse_p[keep])
    if out["slope"] is None:  # too few budgets left: no slope (slope_status says why)
        return {"slope_excluded_spps": excluded, "slope": None, "slope_ci": None, "slope_stderr": None,
                "slope_range": None}
    return dict(out, slope_excluded_spps=excluded)
