"""A curve's convergence slope: the fit of log RMSE on log spp, the budgets it may use, and
why a slope says nothing yet (``benchmarks/STATISTICS.md``, Convergence slopes)."""
from __future__ import annotations

import math

import numpy as np

from .. import metrics as M
from ..constants import MIN_SLOPE_BUDGETS, RELMSE_EPS


def _fit(spps, mse):
    """The slope fit of sqrt(mse) over the spp where it is positive, or None from too few budgets."""
    ok = np.isfinite(mse) & (mse > 0)
    spps = np.asarray(spps)[ok]
    return (M.convergence_slope(spps, np.sqrt(mse[ok])) if len(set(spps)) >= MIN_SLOPE_BUDGETS else None), spps


def slope_stats(spps, mse_c, mse_p) -> dict:
    """Slope of RMSE (from the seed-averaged corrected MSE, one point per spp) with its 95%
    interval and ``slope_range``, and ``slope_uncorrected`` from the plain MSE."""
    fit, used = _fit(spps, mse_c)
    row = dict(slope=None, slope_ci=None, slope_stderr=None, slope_points=len(used), slope_range=None)
    if fit is not None:
        row.update(slope=fit.slope, slope_stderr=fit.stderr,
                   slope_ci=[fit.ci_low, fit.ci_high] if math.isfinite(fit.ci_low) else None,
                   slope_range=[int(used[0]), int(used[-1])])
    plain, _ = _fit(spps, mse_p)
    row["slope_uncorrected"] = None if plain is None else plain.slope
    return row


def slope_status(row: dict):
    """Why the fitted slope says nothing yet, or None.

    Where the gate is undetermined at the top budget, the renders mostly missed the rare
    paths that carry the variance and the slope reads shallow; it is kept and marked.
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
    """The smallest budget from which the seed-averaged MSE (and relMSE) is near its
    expectation: ``ceil(K / seeds)``, ``K = sum k4 / (sum s2)^2`` from the tail reference,
    the largest over channels and the weights of MSE and relMSE (``benchmarks/STATISTICS.md``).

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
    """The slope refitted without the budgets below ``slope_fit_from``, whose MSE sits below
    expectation (unless the gate is undetermined at the top: :func:`slope_status` marks it)."""
    start = row.get("slope_fit_from")
    excluded = [int(s) for s in spps if start and s < start]
    if not excluded or row.get("bias_verdict") == "undetermined":
        return {"slope_excluded_spps": []}
    keep = [i for i, s in enumerate(spps) if s >= start]
    out = slope_stats([spps[i] for i in keep], mse_c[keep], mse_p[keep])
    if out["slope"] is None:  # too few budgets left: no slope (slope_status says why)
        return {"slope_excluded_spps": excluded, "slope": None, "slope_ci": None, "slope_stderr": None,
                "slope_range": None}
    return dict(out, slope_excluded_spps=excluded)
