"""A/B comparison of two results stores: did a change make the tracer faster, slower, or wrong?

For every curve (scene, renderer, strategy, width, height) present in both stores:

* the two RMSE-vs-spp curves (RMSE from the reference-noise-corrected MSE, seeds averaged);
* the convergence slope of each and the slope difference B - A, and the efficiency ratio
  B / A (efficiency = 1 / (MSE x seconds) at the highest spp both curves reach), each
  with a 95% percentile-bootstrap interval: seeds are resampled with replacement within
  each spp, independently in A and B (fixed generator seed, :data:`BOOTSTRAP_RESAMPLES`);
* the gate's verdict (:func:`benchmarks.gate.judge`, the test :func:`benchmarks.gate.compare`) of B's images at the top spp
  against A's as the reference (seed means pooled; per-sample variances from the stored
  variance images, or from the spread of the seeds' means when none are stored), at a
  run-wide false-alarm rate split over the curves (Bonferroni).

Heavy tails. A handful of stored renders says little about a heavy-tailed estimator's
variance (its rare paths are missing from both its mean and its variance), so the verdict
borrows what is known of B's estimator from a high budget (``estimator=``,
:func:`estimator_knowledge`), as ``rtbench gate`` does:

* ours, when B's records come from *this* build and the scene is the one B rendered (same
  content hash): the tail reference (:func:`benchmarks.tails.tail_reference`) of that
  strategy, whose variance floors both sides (under "nothing changed" A's estimator is
  B's) and whose skewness and kurtosis decide where the normal approximation holds, so a
  budget too small to decide reads "undetermined", not "fail";
* an external renderer given as ``--renderer`` with the same command (the same build
  ``ext-<hash>``): the per-pixel variance of 16 batches of the command at the tail budget;
* anything else (another build of ours, Mitsuba's ``path``): no such knowledge; the
  curve's ``tails`` field says why, and its verdict rests on the stored images alone.

Bootstrap intervals from a handful of seeds are rough; they are reported as computed.
"""
from __future__ import annotations

import collections
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import reference_tracer as rt
from mitsuba_scenes.scene_files import scene_file
from mitsuba_scenes.suite import SUITE

from .constants import GATE_ALPHA
from .external import render_external_batches
from .gate.statistics import EstimatorKnowledge, judge
from .gate.store_reference import pooled_image
from .metrics import convergence_slope
from .scenes import scene_at
from .store import curve_of, read_records
from .tails import tail_reference

__all__ = ["BOOTSTRAP_RESAMPLES", "CurveComparison", "compare_stores", "curve_points", "estimator_knowledge"]

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
    tails: str = ""
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
    """:func:`~benchmarks.metrics.convergence_slope` of RMSE over spp, with ``pick(list) -> list``
    choosing seeds; None with fewer than two budgets of positive MSE."""
    spps, rmses = [], []
    for spp, pts in points.items():
        m = float(np.mean([p[0] for p in pick(pts)]))
        if m > 0:
            spps.append(spp)
            rmses.append(math.sqrt(m))
    if len(spps) < 2:
        return None
    return convergence_slope(spps, rmses).slope


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


def estimator_knowledge(*, tail_spp: int, threads=None, cache=None, externals=(), log=None):
    """The ``estimator=`` callable of :func:`compare_stores` for this process's build.

    Parameters
    ----------
    tail_spp : int, keyword-only
        Budget of the tail references (0: none, every curve rests on its stored images).
    threads, cache, log : keyword-only
        As for :func:`benchmarks.tails.tail_reference`.
    externals : sequence of benchmarks.external.ExternalRenderer, keyword-only
        External renderers whose commands may be run for B's curves of the same build.

    Returns
    -------
    callable
        ``knowledge(key, records_b) -> EstimatorKnowledge`` with ``key`` the curve
        (:func:`benchmarks.store.curve_of`).
    """
    by_build = {e.build: e for e in externals}
    here = rt.build_id()

    def knowledge(key, records_b) -> EstimatorKnowledge:
        name, renderer, strategy, width, height = key
        last = records_b[-1]
        if not tail_spp:
            return EstimatorKnowledge("none: --tail-spp 0")
        if renderer == "ours" and last.get("build") != here:
            return EstimatorKnowledge(f"none: B is build {last.get('build')}, this is build {here} (run compare "
                                      f"with B's build to use its tail reference)")
        if renderer != "ours" and last.get("build") not in by_build:
            return EstimatorKnowledge("none: Mitsuba's path integrator" if renderer == "mitsuba" else
                                      f"none: {renderer}'s command was not given as --renderer")
        scene, why = _scene_of(name, width, height, last)
        if scene is None:
            return EstimatorKnowledge(f"none: {why}")
        if renderer == "ours":
            ref = tail_reference(scene, strategy=strategy, spp=tail_spp, threads=threads, cache=cache, log=log)
            return EstimatorKnowledge(f"tail reference of ours {strategy} at {tail_spp} spp", moments=ref.moments)
        ext = by_build[last.get("build")]
        if log:
            log(f"{name}: rendering {ext.name} at {tail_spp} spp in 16 batches for its per-pixel variance")
        try:
            _, var, _ = render_external_batches(ext, scene, spp=tail_spp, seed=0x7A11)
        except (RuntimeError, ValueError) as exc:   # the command failed: say so, judge the images alone
            return EstimatorKnowledge(f"none: {exc}")
        return EstimatorKnowledge(f"{ext.name} in 16 batches at {tail_spp} spp", variance=var)

    return knowledge


def _scene_of(name, width, height, record) -> tuple:
    """``(scene, "")`` as B rendered it (content hash checked), or ``(None, why)``.

    Only scenes this process knows are built: the suite's, and scene files the user named
    on the command line (``--scene PATH``). A store is untrusted input: the scene file its
    records name (``scene_source``) is never loaded from there, since a Python scene file
    is code and the store may come from anybody.
    """
    if name not in SUITE and scene_file(name) is None:
        source = record.get("scene_source")
        named = f" (B rendered it from {str(source)[:200]!r})" if source else ""
        return None, (f"scene {str(name)[:120]!r} is not a suite scene{named}; give its file with --scene PATH "
                      "to use its tail reference")
    try:
        scene = scene_at(name, width, height)
    except (KeyError, ValueError) as exc:
        return None, f"scene {name!r} cannot be built here ({exc})"
    want = record.get("scene_hash")
    if want and scene.content_hash()[:16] != want:
        return None, f"scene {name!r} changed since B rendered it (content hash)"
    return scene, ""


def compare_stores(store_a, store_b, *, alpha: float = GATE_ALPHA, seed: int = 0, estimator=None) -> list:
    """Compare every curve present in both stores (see the module docstring).

    Parameters
    ----------
    store_a, store_b : str or Path
        Results stores (``benchmarks/STORE.md``); A is the baseline.
    alpha : float
        False-alarm rate of the gate over all curves (each at ``alpha / curves``).
    seed : int
        Seed of the bootstrap's generator.
    estimator : callable, optional
        ``estimator(curve, records_b) -> EstimatorKnowledge`` (:func:`estimator_knowledge`):
        B's estimator at a high budget for the verdict; without it the verdict rests on the
        stored images alone (module docstring, "Heavy tails").

    Returns
    -------
    list of CurveComparison
    """
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
            known = estimator(key, rb) if estimator is not None else EstimatorKnowledge("none")
            cmp.tails = known.note
            res = judge(ref, test, known=known, alpha=case_alpha)
            cmp.gate, cmp.verdict, cmp.p_value = res, res.verdict, float(res.p_value)
            cmp.relative_bias, cmp.reason = float(res.relative_bias), res.reason
        out.append(cmp)
    return out
