"""A/B comparison of two results stores, curve by curve (``rtbench compare``; docs/rtbench.md, Comparing
builds): the slope difference B - A and efficiency ratio B / A with 95% percentile-bootstrap intervals (seeds
resampled within each spp), and the gate's verdict of B's top-spp images against A's (run-wide alpha)."""
from __future__ import annotations

import collections
import math
import warnings
from dataclasses import dataclass, field
from functools import partial
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
from .numbers import finite
from .scenes import scene_at
from .store import curve_label, curve_of, read_records
from .tails import tail_reference

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
        return curve_label((self.scene, self.renderer, self.strategy, self.width, self.height))

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


def curve_points(records, *, where: str = "") -> dict:
    """``{spp: [(corrected MSE (else plain), seconds), ...]}`` over the seeds of one curve's records.

    Values are read as the report reads them (:func:`benchmarks.numbers.finite`): a record whose MSE or
    seconds is null is not measured and left out; one whose value is there but no finite number (NaN,
    infinity, a string, a list) is left out with a ``RuntimeWarning`` naming ``where``, never fatal, and
    takes only its own point, not its spp budget.

    >>> curve_points([{"spp": 2, "mse": 0.5, "seconds": 1.0}, {"spp": 2, "mse": 0.3, "mse_corrected": 0.25,
    ...                "seconds": 2}, {"spp": 4, "mse": None, "seconds": 1}])
    {2: [(0.5, 1.0), (0.25, 2.0)]}
    """
    out = collections.defaultdict(list)
    bad = collections.Counter()
    for r in records:
        if r.get("mse") is None or r.get("seconds") is None:
            continue
        field = "mse" if r.get("mse_corrected") is None else "mse_corrected"
        mse, secs = finite(r[field]), finite(r["seconds"])
        if mse is None or secs is None:
            bad[field if mse is None else "seconds"] += 1
            continue
        out[int(r["spp"])].append((mse, secs))
    if bad:
        warnings.warn(f"{where or 'compare'}: {sum(bad.values())} record(s) left out, "
                      f"{' / '.join(sorted(bad))} not a finite number", RuntimeWarning, stacklevel=2)
    return dict(sorted(out.items()))


def _slope(points: dict, pick) -> float | None:
    """The convergence slope of RMSE over spp, ``pick`` choosing seeds; None from fewer than two budgets."""
    spps, rmses = [], []
    for spp, pts in points.items():
        m = float(np.mean([p[0] for p in pick(pts)]))
        if m > 0:
            spps.append(spp)
            rmses.append(math.sqrt(m))
    return convergence_slope(spps, rmses).slope if len(spps) >= 2 else None


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
    def resample(pts):
        return [pts[i] for i in rng.integers(0, len(pts), len(pts))]

    def interval(stat_a, stat_b, combine):
        pairs = [(stat_a(resample), stat_b(resample)) for _ in range(BOOTSTRAP_RESAMPLES)]
        return _ci([None if a is None or b is None else combine(a, b) for a, b in pairs])

    cmp.slope_a, cmp.slope_b = _slope(pa, list), _slope(pb, list)
    if cmp.slope_a is not None and cmp.slope_b is not None:
        cmp.slope_diff = cmp.slope_b - cmp.slope_a
        cmp.slope_diff_ci = interval(partial(_slope, pa), partial(_slope, pb), lambda a, b: b - a)
    top = cmp.top_spp = max(set(pa) & set(pb), default=None)
    if top is None:
        return
    ea, eb = _efficiency(pa[top], list), _efficiency(pb[top], list)
    if ea and eb:
        cmp.efficiency_ratio = eb / ea
        cmp.efficiency_ratio_ci = interval(partial(_efficiency, pa[top]), partial(_efficiency, pb[top]),
                                           lambda a, b: b / a)


def estimator_knowledge(*, tail_spp: int, threads=None, cache=None, externals=(), log=None):
    """The ``estimator=`` of :func:`compare_stores`: ``knowledge(curve, records_b) -> EstimatorKnowledge``.

    Ours when B is this build: the tail reference at ``tail_spp`` (0: none); an external
    renderer among ``externals`` of B's build: 16 batches of its command; anything else:
    none, and why. ``threads``, ``cache``, ``log`` as :func:`benchmarks.tails.tail_reference`.
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
    """``(scene, "")`` as B rendered it (content hash checked), or ``(None, why)``. Only the
    suite's scenes and files named with ``--scene``: a store's ``scene_source`` (maybe code) never runs."""
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
    """A :class:`CurveComparison` of every curve in both stores (A the baseline).

    Parameters
    ----------
    store_a, store_b : str or Path
    alpha : float
        False-alarm rate of the gate over all curves (each at ``alpha / curves``).
    seed : int
        Seed of the bootstrap's generator.
    estimator : callable, optional
        :func:`estimator_knowledge`'s; without it the verdicts rest on the stored images alone.

    Returns
    -------
    list of CurveComparison
    """
    a, b = Path(store_a), Path(store_b)
    by_a, by_b = collections.defaultdict(list), collections.defaultdict(list)
    for store, by in ((a, by_a), (b, by_b)):
        for r in read_records(store):
            by[curve_of(r)].append(r)
    curves = [k for k in by_a if k in by_b]
    if not curves:
        raise ValueError(f"{a} and {b} have no curve (scene, renderer, strategy, size) in common")
    rng = np.random.default_rng(seed)
    case_alpha = alpha / len(curves)
    out = []
    for key in curves:
        ra, rb = by_a[key], by_b[key]
        pa, pb = (curve_points(rs, where=f"{store / 'results.jsonl'}: {curve_label(key)}")
                  for store, rs in ((a, ra), (b, rb)))
        rmse = [[math.sqrt(max(np.mean([p[0] for p in v]), 0)) for v in pts.values()] for pts in (pa, pb)]
        cmp = CurveComparison(*key, build_a=ra[-1].get("build"), build_b=rb[-1].get("build"),
                              spps_a=list(pa), rmse_a=rmse[0], spps_b=list(pb), rmse_b=rmse[1])
        _bootstrap(cmp, pa, pb, rng)
        top = cmp.top_spp
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
