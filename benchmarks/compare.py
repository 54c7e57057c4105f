"""A/B comparison of two results stores: did a change make the tracer faster, slower, or wrong?

For every curve (scene, renderer, strategy, width, height) present in both stores:

* the two RMSE-vs-spp curves (RMSE from the reference-noise-corrected MSE, seeds averaged);
* the convergence slope of each and the slope difference B - A, and the efficiency ratio
  B / A (efficiency = 1 / (MSE x seconds) at the highest spp both curves reach), each
  with a 95% percentile-bootstrap interval: seeds are resampled with replacement within
  each spp, independently in A and B (fixed generator seed, :data:`BOOTSTRAP_RESAMPLES`);
* the gate's verdict (:func:`benchmarks.gate.compare`) of B's images at the top spp
  against A's as the reference (seed means pooled; per-sample variances from the stored
  variance images, or from the spread of the seeds' means when none are stored), at a
  run-wide false-alarm rate split over the curves (Bonferroni).

Bootstrap intervals from a handful of seeds are rough; they are reported as computed.
"""
from __future__ import annotations

import collections
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .constants import GATE_ALPHA
from .store import curve_of, read_image, read_records

__all__ = ["BOOTSTRAP_RESAMPLES", "CurveComparison", "compare_stores", "curve_points"]

BOOTSTRAP_RESAMPLES = 2000


@dataclass
class CurveComparison:
    """One curve of both stores (see the module docstring); ``None`` where not computable."""

    scene: str
    renderer: str
    strategy: str
    width: int
    height: int
    build_a: str | None
    build_b: str | None
    spps_a: list
    rmse_a: list
    spps_b: list
    rmse_b: list
    slope_a: float | None = None
    slope_b: float | None = None
    slope_diff: float | None = None
    slope_diff_ci: tuple | None = None
    top_spp: int | None = None
    efficiency_ratio: float | None = None
    efficiency_ratio_ci: tuple | None = None
    verdict: str | None = None
    p_value: float | None = None
    relative_bias: float | None = None
    reason: str = ""
    gate: object = field(default=None, repr=False)

    @property
    def label(self) -> str:
        who = self.strategy if self.renderer == "ours" else f"{self.renderer} {self.strategy}"
        return f"{self.scene} {self.width}x{self.height} {who}"

    @property
    def speed(self) -> str:
        """'faster', 'slower' or 'same' (the efficiency interval includes 1) or '-'."""
        ci = self.efficiency_ratio_ci
        if ci is None:
            return "-"
        return "faster" if ci[0] > 1 else "slower" if ci[1] < 1 else "same"

    def to_dict(self) -> dict:
        d = {k: v for k, v in self.__dict__.items() if k != "gate"}
        d["speed"] = self.speed
        return d


def _mse(r) -> float:
    """The record's reference-noise-corrected MSE (its plain MSE when the correction is missing)."""
    v = r.get("mse_corrected")
    return float(r["mse"] if v is None else v)


def curve_points(records) -> dict:
    """``{spp: [(mse, seconds), ...]}`` over the seeds of one curve's records."""
    out = collections.defaultdict(list)
    for r in records:
        if r.get("mse") is not None and r.get("seconds") is not None:
            out[int(r["spp"])].append((_mse(r), float(r["seconds"])))
    return dict(sorted(out.items()))


def _slope(points: dict, pick) -> float | None:
    """Least-squares slope of log RMSE over log spp with ``pick(list) -> list`` choosing seeds."""
    xs, ys = [], []
    for spp, pts in points.items():
        m = float(np.mean([p[0] for p in pick(pts)]))
        if m > 0:
            xs.append(math.log(spp))
            ys.append(0.5 * math.log(m))
    if len(xs) < 2:
        return None
    return float(np.polyfit(xs, ys, 1)[0])


def _efficiency(pts, pick) -> float | None:
    chosen = pick(pts)
    mse, secs = float(np.mean([p[0] for p in chosen])), float(np.mean([p[1] for p in chosen]))
    return 1.0 / (mse * secs) if mse > 0 and secs > 0 else None


def _ci(values) -> tuple | None:
    v = np.asarray([x for x in values if x is not None and math.isfinite(x)], dtype=np.float64)
    if len(v) < 0.9 * BOOTSTRAP_RESAMPLES:
        return None
    return float(np.percentile(v, 2.5)), float(np.percentile(v, 97.5))


def _bootstrap(cmp: CurveComparison, pa: dict, pb: dict, rng) -> None:
    """Slopes, efficiency ratio and their bootstrap intervals into ``cmp``."""
    ident = lambda pts: pts  # noqa: E731

    def resample(pts):
        return [pts[i] for i in rng.integers(0, len(pts), len(pts))]

    cmp.slope_a, cmp.slope_b = _slope(pa, ident), _slope(pb, ident)
    if cmp.slope_a is not None and cmp.slope_b is not None:
        cmp.slope_diff = cmp.slope_b - cmp.slope_a
        diffs = []
        for _ in range(BOOTSTRAP_RESAMPLES):
            a, b = _slope(pa, resample), _slope(pb, resample)
            diffs.append(None if a is None or b is None else b - a)
        cmp.slope_diff_ci = _ci(diffs)
    common = sorted(set(pa) & set(pb))
    if not common:
        return
    top = cmp.top_spp = common[-1]
    ea, eb = _efficiency(pa[top], ident), _efficiency(pb[top], ident)
    if ea and eb:
        cmp.efficiency_ratio = eb / ea
        ratios = []
        for _ in range(BOOTSTRAP_RESAMPLES):
            a, b = _efficiency(pa[top], resample), _efficiency(pb[top], resample)
            ratios.append(b / a if a and b else None)
        cmp.efficiency_ratio_ci = _ci(ratios)


def pooled_image(store, records, spp: int):
    """``(mean, per-sample variance, total spp)`` of a curve's stored images at ``spp``, or None.

    Seeds' means are averaged; the per-sample variance is the mean of the stored variance
    images, else ``spp`` x the between-seed variance of the means (2+ seeds).
    """
    recs = [r for r in records if int(r["spp"]) == spp and (r.get("stats_image") or r.get("image"))]
    if not recs:
        return None
    means = np.stack([read_image(store, r.get("stats_image") or r["image"], rgb=True) for r in recs])
    var_paths = [r.get("stats_variance_image") for r in recs]
    if all(var_paths):
        var = np.mean([read_image(store, p, rgb=True) for p in var_paths], axis=0)
    elif len(recs) >= 2:
        var = means.var(axis=0, ddof=1) * spp
    else:
        return None
    return means.mean(axis=0), var, spp * len(recs)


def compare_stores(store_a, store_b, *, alpha: float = GATE_ALPHA, seed: int = 0) -> list:
    """Compare every curve present in both stores (see the module docstring).

    Parameters
    ----------
    store_a, store_b : str or Path
        Results stores (``benchmarks/STORE.md``); A is the baseline.
    alpha : float
        False-alarm rate of the gate over all curves (each at ``alpha / curves``).
    seed : int
        Seed of the bootstrap's generator.

    Returns
    -------
    list of CurveComparison
    """
    from .gate import compare

    a, b = Path(store_a), Path(store_b)
    by_a, by_b = collections.defaultdict(list), collections.defaultdict(list)
    for r in read_records(a):
        by_a[curve_of(r)].append(r)
    for r in read_records(b):
        by_b[curve_of(r)].append(r)
    curves = [k for k in by_a if k in by_b]
    if not curves:
        raise ValueError(f"{a} and {b} have no curve (scene, renderer, strategy, size) in common")
    rng = np.random.default_rng(seed)
    case_alpha = alpha / len(curves)
    out = []
    for key in curves:
        ra, rb = by_a[key], by_b[key]
        pa, pb = curve_points(ra), curve_points(rb)
        cmp = CurveComparison(*key, build_a=ra[-1].get("build"), build_b=rb[-1].get("build"),
                              spps_a=list(pa), rmse_a=[math.sqrt(max(np.mean([p[0] for p in v]), 0)) for v in pa.values()],
                              spps_b=list(pb), rmse_b=[math.sqrt(max(np.mean([p[0] for p in v]), 0)) for v in pb.values()])
        _bootstrap(cmp, pa, pb, rng)
        top = max(set(pa) & set(pb), default=None)
        ref, test = (pooled_image(a, ra, top), pooled_image(b, rb, top)) if top else (None, None)
        if ref is None or test is None:
            cmp.reason = "no images with a variance at the top spp in both stores: no gate verdict"
        else:
            res = compare(test[0], test[1], test[2], ref[0], ref[1], ref[2], alpha=case_alpha)
            cmp.gate, cmp.verdict, cmp.p_value = res, res.verdict, float(res.p_value)
            cmp.relative_bias, cmp.reason = float(res.relative_bias), res.reason
        out.append(cmp)
    return out
