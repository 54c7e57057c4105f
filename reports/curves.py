"""Curves from job records: per (renderer, strategy), a metric's median and band over seeds per spp.

Also the small numerical pieces the report needs on top of ``summary.json``: a log-log
least-squares slope (for legends when the summary has none, and for relMSE), log-log
interpolation, equal-time comparison, and the seed's uniform-versus-light comparison.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from benchmarks.constants import SEED_SCENE, SEED_SIZE, SEED_SPP
from benchmarks.metrics import convergence_slope

from .store import curve_order, num

# SEED_* are re-exported: the seed comparison's scene, size and spp (benchmarks.constants).
__all__ = ["Curve", "curves", "loglog_slope", "loglog_interp", "equal_time", "seed_comparison",
           "SEED_SCENE", "SEED_SIZE", "SEED_SPP"]


@dataclass
class Curve:
    """One line of a plot: a metric per spp, summarised over seeds.

    Attributes
    ----------
    renderer, strategy : str
    spp : ndarray
        Sorted sample counts that have at least one finite value.
    median, lo, hi : ndarray
        Median, minimum and maximum over seeds.
    seconds : ndarray
        Median render seconds per spp (NaN when unknown).
    nseeds : ndarray
        Number of seeds with a finite value per spp.
    """

    renderer: str
    strategy: str
    spp: np.ndarray
    median: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    seconds: np.ndarray
    nseeds: np.ndarray

    @property
    def key(self) -> tuple[str, str]:
        return (self.renderer, self.strategy)

    @property
    def label(self) -> str:
        return curve_label(self.renderer, self.strategy)


#: How Mitsuba's curves of a ``direct`` scene read (Veach's comparison).
DIRECT_LABELS = {"direct_bsdf": "Mitsuba direct, BSDF samples", "direct_light": "Mitsuba direct, emitter samples",
                 "direct_mis": "Mitsuba direct, MIS"}


def curve_label(renderer: str, strategy: str) -> str:
    """Human label of a curve: our strategy name, ``Mitsuba path``, or ``Mitsuba direct, MIS``."""
    if renderer == "ours":
        return str(strategy)
    if renderer == "mitsuba" and strategy in DIRECT_LABELS:
        return DIRECT_LABELS[strategy]
    return f"{'Mitsuba' if renderer == 'mitsuba' else renderer} {strategy}"


def curves(records: list[dict], metric: str) -> list[Curve]:
    """Group records by (renderer, strategy) and summarise ``metric`` over seeds per spp.

    Parameters
    ----------
    records : list of dict
        Job records of one section (same scene and size).
    metric : str
        Record field, e.g. ``"rmse"``.

    Returns
    -------
    list of Curve
        Ours in strategy order, then Mitsuba; curves with no finite value are left out.
    """
    groups: dict[tuple, dict[float, list[tuple[float, float]]]] = {}
    for r in records:
        key = (r["renderer"], r["strategy"])
        groups.setdefault(key, {}).setdefault(float(r["spp"]), []).append((num(r.get(metric)), num(r.get("seconds"))))
    out = []
    for key in sorted(groups, key=curve_order):
        spps, med, lo, hi, sec, n = [], [], [], [], [], []
        for spp in sorted(groups[key]):
            vals = np.array([v for v, _ in groups[key][spp]], dtype=float)
            secs = np.array([s for _, s in groups[key][spp]], dtype=float)
            vals = vals[np.isfinite(vals)]
            if vals.size == 0:
                continue
            spps.append(spp)
            med.append(float(np.median(vals)))
            lo.append(float(vals.min()))
            hi.append(float(vals.max()))
            secs = secs[np.isfinite(secs)]
            sec.append(float(np.median(secs)) if secs.size else math.nan)
            n.append(vals.size)
        if spps:
            out.append(Curve(key[0], key[1], *(np.asarray(x, dtype=float) for x in (spps, med, lo, hi, sec)),
                             np.asarray(n, dtype=int)))
    return out


def loglog_slope(x, y) -> float:
    """:func:`benchmarks.metrics.convergence_slope` of y over x on the positive finite pairs
    (NaN with < 2 distinct x)."""
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    ok = np.isfinite(x) & np.isfinite(y) & (x > 0) & (y > 0)
    if np.unique(x[ok]).size < 2:
        return math.nan
    return convergence_slope(x[ok], y[ok]).slope


def loglog_interp(x, y, at: float) -> float:
    """Piecewise-linear interpolation of log y over log x at ``at``; NaN outside the data's range.

    ``x`` must be increasing. Used both ways round: y(x) and, with x and y swapped, x(y)
    (then ``y`` need only be monotone between the bracketing points; the first crossing wins).
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    ok = np.isfinite(x) & np.isfinite(y) & (x > 0) & (y > 0)
    x, y = np.log(x[ok]), np.log(y[ok])
    if x.size == 0 or not at > 0:
        return math.nan
    t = math.log(at)
    if x.size == 1:
        return float(math.exp(y[0])) if math.isclose(x[0], t, rel_tol=0, abs_tol=1e-12) else math.nan
    for i in range(x.size - 1):
        a, b = x[i], x[i + 1]
        if min(a, b) - 1e-12 <= t <= max(a, b) + 1e-12:
            if a == b:
                return float(math.exp(y[i]))
            w = (t - a) / (b - a)
            return float(math.exp(y[i] + w * (y[i + 1] - y[i])))
    return math.nan


def equal_time(rmse_curves: list[Curve]) -> tuple[float, dict[tuple, float]]:
    """The common time budget of a set of RMSE curves and each curve's RMSE at that time.

    The budget is the smallest of the curves' longest median render times, so that every
    curve whose time range covers it gets a log-log interpolated RMSE.

    Returns
    -------
    (seconds, {curve key: rmse}) ; (NaN, {}) when no curve has timings.
    """
    timed = [c for c in rmse_curves if np.isfinite(c.seconds).any() and np.nanmax(c.seconds) > 0]
    if not timed:
        return math.nan, {}
    budget = min(float(np.nanmax(c.seconds)) for c in timed)
    at = {}
    for c in timed:
        order = np.argsort(c.seconds)
        v = loglog_interp(c.seconds[order], c.median[order], budget)
        if np.isfinite(v):
            at[c.key] = v
    return budget, at


def seed_comparison(records: list[dict]) -> dict | None:
    """Reproduce the seed's comparison: uniform vs light on cornell_box at 400x400.

    Parameters
    ----------
    records : list of dict
        All job records of the store.

    Returns
    -------
    dict or None
        ``None`` when the store has no ``ours`` uniform and light records for
        ``cornell_box`` at 400x400. Otherwise: ``uniform`` and ``light`` (Curves of relMSE),
        ``label`` ("relMSE": the error compared, less the reference's noise where recorded),
        ``target_rmse`` (uniform's median relMSE at 50 spp, log-log interpolated when 50 was
        not run, NaN outside its range), ``target_exact`` (50 spp was run),
        ``light_spp`` (spp at which light's median relMSE reaches the target, log-log
        interpolated between measured spp), ``method`` (``"interpolated"``, ``"at most"``
        when light is below the target at its smallest budget: ``light_spp`` is that budget,
        or ``"not reached"``), ``saving`` (50 / light_spp) and ``light_slope``.
    """
    sel = [r for r in records if r.get("scene") == SEED_SCENE and r.get("renderer") == "ours"
           and r.get("strategy") in ("uniform", "light")
           and num(r.get("width")) == SEED_SIZE and num(r.get("height")) == SEED_SIZE]
    # relMSE, the report's metric, less the reference's own noise where the records carry it
    field = "relmse_corrected" if any(r.get("relmse_corrected") is not None for r in sel) else "relmse"
    cs = {c.strategy: c for c in curves(sel, field)}
    if "uniform" not in cs or "light" not in cs:
        return None
    uni, light = cs["uniform"], cs["light"]
    exact = bool(np.any(uni.spp == SEED_SPP))
    target = float(uni.median[uni.spp == SEED_SPP][0]) if exact else loglog_interp(uni.spp, uni.median, SEED_SPP)
    out = {"uniform": uni, "light": light, "target_rmse": target, "target_exact": exact, "label": "relMSE",
           "light_spp": math.nan, "method": "no target", "saving": math.nan,
           "light_slope": loglog_slope(light.spp, light.median)}
    if not np.isfinite(target):
        return out
    # light's RMSE falls with spp: find the first bracket [spp_i, spp_i+1] whose RMSEs straddle the target.
    s, m = light.spp, light.median
    for i in range(s.size - 1):
        if (m[i] - target) * (m[i + 1] - target) <= 0 and m[i] != m[i + 1]:
            la, lb = math.log(m[i]), math.log(m[i + 1])
            w = (math.log(target) - la) / (lb - la)
            out["light_spp"] = float(math.exp(math.log(s[i]) + w * (math.log(s[i + 1]) - math.log(s[i]))))
            out["method"] = "interpolated"
            break
    else:
        if s.size and math.isclose(m[0], target, rel_tol=1e-12):
            out["light_spp"], out["method"] = float(s[0]), "interpolated"
        elif s.size and m[0] <= target:
            # already below the target at its smallest budget: no extrapolation (light's curve
            # flattens at its bias, so its fitted slope says nothing of smaller budgets)
            out["light_spp"], out["method"] = float(s[0]), "at most"
        else:
            out["method"] = "not reached"
    if np.isfinite(out["light_spp"]) and out["light_spp"] > 0:
        out["saving"] = SEED_SPP / out["light_spp"]
    return out
