"""The gate's measured false-alarm rate: many seeds of unbiased strategies, counted by verdict.

A verdict is a claim, so its false-alarm rate is measured, not assumed: for each scene,
unbiased strategy and budget, :func:`calibrate` renders our tracer with many seeds,
compares each render with the Mitsuba reference exactly as ``rtbench gate`` does (one
comparison at level ``alpha``, with the tail reference of the same estimator), and counts
pass, fail and undetermined. Undetermined is never a failure in this table and never a
pass in a power table; both show it. ``rtbench gate --calibrate`` prints the table;
``benchmarks/STATISTICS.md`` holds the measured one.

With ``pairs=True`` (``--compare-pairs``) it measures ``rtbench compare``'s verdict
instead: two renders of this build per seed, B (seed ``FIRST_SEED + 2k + 1``) judged
against A (seed ``FIRST_SEED + 2k``) by :func:`benchmarks.gate.judge`, the function
``compare_stores`` uses, with the tail reference as ``compare`` takes it for two stores of
this build. No Mitsuba reference is involved: under "nothing changed" A is the reference.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

from scipy import stats

import reference_tracer as rt
from reference_tracer.validation import positive_int

from ..constants import GATE_ALPHA, UNBIASED_STRATEGIES
from ..tails import DEFAULT_TAIL_SPP
from .paired import EstimatorKnowledge, judge
from .suite import (DEFAULT_REF_SPP, DEFAULT_WIDTH, compare_render, gate_reference, gate_scene, gate_tails,
                    resolve_scenes)

__all__ = ["CalibrationRow", "calibrate", "clopper_pearson", "DEFAULT_CALIBRATION_SPPS", "DEFAULT_CALIBRATION_SEEDS"]

#: The budgets of the false-alarm table (issue 18).
DEFAULT_CALIBRATION_SPPS = (64, 256, 1024, 4096)
#: Seeds per (scene, strategy, spp): 100 resolves a rate of 0.01 to a 95% interval of [0.0003, 0.054].
DEFAULT_CALIBRATION_SEEDS = 100
#: Seeds of the renders start here: far from the gate's own seed 0 and from the tail references'.
FIRST_SEED = 1_000


def clopper_pearson(k: int, n: int, confidence: float = 0.95) -> tuple:
    """Exact (Clopper-Pearson) confidence interval of a binomial rate ``k / n``.

    Examples
    --------
    >>> lo, hi = clopper_pearson(0, 100)
    >>> lo, round(hi, 4)
    (0.0, 0.0362)
    """
    if n <= 0:
        return math.nan, math.nan
    a = 1.0 - confidence
    lo = 0.0 if k == 0 else float(stats.beta.ppf(a / 2, k, n - k + 1))
    hi = 1.0 if k == n else float(stats.beta.ppf(1 - a / 2, k + 1, n - k))
    return lo, hi


@dataclass
class CalibrationRow:
    """Verdict counts of one (scene, strategy, spp) over ``seeds`` renders.

    ``false_alarm_rate`` is ``fail / seeds`` (undetermined counted apart, never as a
    failure); ``ci_low``, ``ci_high`` its 95% Clopper-Pearson interval; ``consistent`` is
    ``ci_low <= alpha``: the measured rate is compatible with the promised one.
    ``spp_needed`` is the median budget the undetermined verdicts asked for (None if none).
    ``min_detectable_bias``: median power of the determined comparisons (global relative bias).
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


def _median(values):
    v = sorted(x for x in values if x is not None and x == x)
    return v[len(v) // 2] if v else None


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
    strategies : sequence of str, keyword-only
        Strategies whose renders must be unbiased (default: all but ``light``).
    spps : sequence of int, keyword-only
        Budgets of the renders under test.
    seeds : int, keyword-only
        Renders per (scene, strategy, spp), seeds ``FIRST_SEED ...``.
    width, ref_spp, tail_spp, alpha, threads, cache, log : keyword-only
        As for :func:`benchmarks.gate.run_gate`; ``alpha`` is the level of one comparison.
    height, variant : keyword-only
        Image height (default: the width) and the Mitsuba variant of the references
        (default: the fastest that works).
    on_render, on_row : callable, keyword-only
        Called after each render (no argument) and with each finished row.
    skip : set of (scene, strategy, spp), keyword-only
        Rows measured already (a resumed calibration): neither rendered nor returned.
    pairs : bool, keyword-only
        Measure ``rtbench compare``'s verdict on pairs of renders instead of the gate's
        against Mitsuba (module docstring); ``seeds`` pairs per row.

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


def _row(scene, strategy, spp, alpha, results) -> CalibrationRow:
    counts = {v: sum(r.verdict == v for r in results) for v in ("pass", "fail", "undetermined")}
    n = len(results)
    lo, hi = clopper_pearson(counts["fail"], n)
    needed = _median(r.spp_needed for r in results if r.verdict == "undetermined")
    mdb = _median(r.min_detectable_bias for r in results if r.verdict != "undetermined")
    return CalibrationRow(scene=scene, strategy=strategy, spp=spp, seeds=n, alpha=alpha, passed=counts["pass"],
                          failed=counts["fail"], undetermined=counts["undetermined"],
                          false_alarm_rate=counts["fail"] / n, ci_low=lo, ci_high=hi, consistent=lo <= alpha,
                          spp_needed=needed, min_detectable_bias=math.nan if mdb is None else mdb)
