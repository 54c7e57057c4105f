"""The gate's measured false-alarm rate: many seeds of unbiased strategies, counted by verdict.

:func:`calibrate` renders each (scene, unbiased strategy, spp) with many seeds, compares each
render with its reference as ``rtbench gate`` does (one comparison at ``alpha``, with the tail
reference) and counts pass, fail and undetermined (``rtbench gate --calibrate``); with
``pairs=True`` it measures ``rtbench compare``'s verdict (:func:`benchmarks.gate.judge`) on
pairs of renders of this build instead. The measured tables: ``benchmarks/STATISTICS.md``.
"""
from __future__ import annotations

import math
import statistics
from dataclasses import asdict, dataclass

from scipy import stats

import reference_tracer as rt
from reference_tracer.validation import positive_int

from ..constants import GATE_ALPHA, UNBIASED_STRATEGIES
from ..tails import DEFAULT_TAIL_SPP
from .statistics import EstimatorKnowledge, judge
from .suite import (DEFAULT_REF_SPP, DEFAULT_WIDTH, compare_render, gate_reference, gate_scene, gate_tails,
                    resolve_scenes)

__all__ = ["CalibrationRow", "calibrate", "DEFAULT_CALIBRATION_SPPS", "DEFAULT_CALIBRATION_SEEDS"]

#: The budgets of the false-alarm table.
DEFAULT_CALIBRATION_SPPS = (64, 256, 1024, 4096)
#: Seeds per (scene, strategy, spp): 100 resolves a rate of 0.01 to a 95% interval of [0.0003, 0.054].
DEFAULT_CALIBRATION_SEEDS = 100
#: Seeds of the renders start here: far from the gate's own seed 0 and from the tail references'.
FIRST_SEED = 1_000


@dataclass
class CalibrationRow:
    """Verdict counts of one (scene, strategy, spp) over ``seeds`` renders.

    ``false_alarm_rate`` is ``fail / seeds``; ``ci_low``, ``ci_high`` its exact (Clopper-Pearson)
    95% interval; ``consistent``: ``ci_low <= alpha``. ``spp_needed``: the median budget the
    undetermined verdicts asked for; ``min_detectable_bias``: the determined ones' median power.
    """

    scene: str
    strategy: str
    spp: int
    seeds: int
    alpha: float
    passed: int
    failed: int
    undetermined: int
    false_alarm_rate: float
    ci_low: float
    ci_high: float
    consistent: bool
    spp_needed: int | None
    min_detectable_bias: float

    def to_dict(self) -> dict:
        return asdict(self)


def calibrate(scenes=None, *, strategies=UNBIASED_STRATEGIES, spps=DEFAULT_CALIBRATION_SPPS,
              seeds: int = DEFAULT_CALIBRATION_SEEDS, width: int = DEFAULT_WIDTH, ref_spp: int = DEFAULT_REF_SPP,
              tail_spp: int = DEFAULT_TAIL_SPP, alpha: float = GATE_ALPHA, threads=None, cache=None,
              log=None, on_render=None, on_row=None, height: int | None = None, variant: str | None = None,
              skip=frozenset(), pairs: bool = False) -> list:
    """Measure the gate's verdicts on unbiased renders: one :class:`CalibrationRow` per
    (scene, strategy, spp).

    Parameters
    ----------
    scenes : sequence of str or None
        Suite scenes (None: the whole suite).
    strategies, spps, seeds : keyword-only
        Strategies whose renders must be unbiased (default: all but ``light``), the budgets
        under test and the renders per (scene, strategy, spp) (seeds ``FIRST_SEED ...``).
    width, height, ref_spp, tail_spp, alpha, threads, cache, log, variant : keyword-only
        As for :func:`benchmarks.gate.run_gate`; ``alpha`` is the level of one comparison.
    on_render, on_row : callable, keyword-only
        Called after each render (no argument) and with each finished row.
    skip : set of (scene, strategy, spp), keyword-only
        Rows measured already (a resumed calibration): neither rendered nor returned.
    pairs : bool, keyword-only
        Measure ``rtbench compare``'s verdict on ``seeds`` pairs of renders instead.

    Returns
    -------
    list of CalibrationRow

    Examples
    --------
    >>> rows = calibrate(["cornell_box"], strategies=["mis"], spps=[16], seeds=2, width=8,
    ...                  ref_spp=256, tail_spp=256)  # doctest: +SKIP
    >>> rows[0].passed + rows[0].failed + rows[0].undetermined  # doctest: +SKIP
    2
    """
    names = resolve_scenes(scenes)
    seeds = positive_int("seeds", seeds)
    spps = [positive_int("spp", s, minimum=2) for s in spps]
    for s in strategies:
        if s not in rt.STRATEGIES:
            raise ValueError(f"unknown strategy {s!r}; choose from {', '.join(rt.STRATEGIES)}")
    rows = []
    for name in names:
        if all((name, st, spp) in skip for st in strategies for spp in spps):
            continue
        scene = gate_scene(name, width=width, height=height)
        ref = None if pairs else gate_reference(name, scene, ref_spp=ref_spp, threads=threads, cache=cache, log=log,
                                                variant=variant)
        for strategy in strategies:
            todo = [spp for spp in spps if (name, strategy, spp) not in skip]
            if not todo:
                continue
            tails = gate_tails(scene, strategy, tail_spp=tail_spp, threads=threads, cache=cache, log=log)
            for spp in todo:
                results = []
                for k in range(seeds):
                    if pairs:
                        results.append(_compare_pair(scene, strategy, spp, FIRST_SEED + 2 * k, tails,
                                                     alpha=alpha, threads=threads))
                    else:
                        out = rt.render(scene, spp=spp, strategy=strategy, seed=FIRST_SEED + k, threads=threads)
                        results.append(compare_render(out.mean, out.variance, spp, ref, alpha=alpha, tails=tails,
                                                      pixel_samples=out.pixel_samples,
                                                      pixel_filter=scene.camera.filter))
                    if on_render:
                        on_render()
                row = _row(name, strategy, spp, alpha, results)
                rows.append(row)
                if on_row:
                    on_row(row)
    return rows


def _compare_pair(scene, strategy: str, spp: int, seed: int, tails, *, alpha: float, threads):
    """``rtbench compare``'s verdict on two renders of this build: B (``seed + 1``) against A (``seed``)."""
    a, b = (rt.render(scene, spp=spp, strategy=strategy, seed=s, threads=threads) for s in (seed, seed + 1))
    known = (EstimatorKnowledge(f"tail reference of ours {strategy} at {tails.spp} spp", moments=tails.moments)
             if tails is not None else EstimatorKnowledge("none: --tail-spp 0"))
    return judge((a.mean, a.variance, spp), (b.mean, b.variance, spp), known=known, alpha=alpha)


def _median(values):
    v = [x for x in values if x is not None and x == x]
    return statistics.median_high(v) if v else None


def _row(scene, strategy, spp, alpha, results) -> CalibrationRow:
    counts = {v: sum(r.verdict == v for r in results) for v in ("pass", "fail", "undetermined")}
    n = len(results)
    lo, hi = (float(v) for v in stats.binomtest(counts["fail"], n).proportion_ci(0.95, method="exact"))
    needed = _median(r.spp_needed for r in results if r.verdict == "undetermined")
    mdb = _median(r.min_detectable_bias for r in results if r.verdict != "undetermined")
    return CalibrationRow(scene=scene, strategy=strategy, spp=spp, seeds=n, alpha=alpha, passed=counts["pass"],
                          failed=counts["fail"], undetermined=counts["undetermined"],
                          false_alarm_rate=counts["fail"] / n, ci_low=lo, ci_high=hi, consistent=lo <= alpha,
                          spp_needed=needed, min_detectable_bias=math.nan if mdb is None else mdb)
