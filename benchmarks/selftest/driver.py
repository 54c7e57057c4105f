"""The self-test driver (:func:`run_selftest`): each mutant rendered and judged by the gate and by Mitsuba's rule.

Each mutant is judged with its *own* tail reference at each budget of the ladder up to ``spp``, by
:func:`benchmarks.gate.compare` at ``GATE_ALPHA / 8`` (caught: ``'fail'``; ``'undetermined'`` is
not a catch) and by :func:`benchmarks.gate.mitsuba_rule`; the controls judge the unmutated tracer
the same way (a rule that fails the tracer there has not shown that it caught the bug).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

from reference_tracer.testing import mutants_build_id, render_mutant
from reference_tracer.validation import SEED_MAX, positive_int

from ..constants import GATE_ALPHA
from ..gate.power import MITSUBA_ALPHA, QUICK_SUITE_COMPARISONS, mitsuba_rule
from ..gate.suite import DEFAULT_REF_SPP, DEFAULT_SEED, DEFAULT_SPP, DEFAULT_WIDTH, compare_render, gate_reference
from ..references import reference
from ..tails import DEFAULT_TAIL_SPP, tail_reference
from .catalogue import is_suite_scene, resolve_mutants, selftest_scene

__all__ = ["DEFAULT_SPP_LADDER", "DEFAULT_CASE_ALPHA", "SelftestReport", "ladder", "run_selftest",
           "scene_reference"]

#: budgets at which each mutant is judged (those below the run's spp, then the spp itself).
DEFAULT_SPP_LADDER = (64, 256, 1024, 4096)
#: the level of each comparison in a default gate run of the quick suite.
DEFAULT_CASE_ALPHA = GATE_ALPHA / QUICK_SUITE_COMPARISONS


@dataclass
class SelftestReport:
    """The rows of :func:`run_selftest`, the controls (``(scene, strategy) -> dict``) and the run's figures."""

    rows: list
    controls: dict = field(default_factory=dict)
    alpha: float = DEFAULT_CASE_ALPHA
    spp: int = DEFAULT_SPP
    seconds: float = 0.0

    @property
    def n(self) -> int:
        return len(self.rows)

    @property
    def n_caught(self) -> int:
        return sum(bool(r["caught"]) for r in self.rows)

    @property
    def n_caught_by_mitsuba_rule(self) -> int:
        return sum(bool(r["caught_by_mitsuba_rule"]) for r in self.rows)

    @property
    def catch_rate(self) -> float:
        return self.n_caught / self.n if self.n else 0.0

    @property
    def passed(self) -> bool:
        """The gate catches at least 90% of the mutants and never fewer than Mitsuba's rule."""
        return self.n > 0 and self.n_caught >= 0.9 * self.n and self.n_caught >= self.n_caught_by_mitsuba_rule

    def to_dict(self) -> dict:
        return {"spp": self.spp, "alpha": self.alpha, "mitsuba_alpha": MITSUBA_ALPHA, "mutants": self.n,
                "caught": self.n_caught, "caught_by_mitsuba_rule": self.n_caught_by_mitsuba_rule,
                "catch_rate": self.catch_rate, "passed": self.passed, "seconds": self.seconds,
                "controls": [dict(scene=s, strategy=t, **c) for (s, t), c in self.controls.items()],
                "rows": self.rows}


def ladder(spp: int, spp_ladder=DEFAULT_SPP_LADDER) -> list:
    """The budgets of a run: those of ``spp_ladder`` below ``spp``, then ``spp``.

    >>> ladder(4096), ladder(300, (64, 256, 1024))
    ([64, 256, 1024, 4096], [64, 256, 300])
    """
    return sorted({int(s) for s in spp_ladder if int(s) < spp} | {int(spp)})


def scene_reference(name: str, scene, *, ref_spp: int, threads=None, cache=None, log=None):
    """The reference of a self-test scene: the gate's for suite scenes, else the cached Mitsuba render."""
    if is_suite_scene(name):
        return gate_reference(name, scene, ref_spp=ref_spp, threads=threads, cache=cache, log=log)
    return reference(scene, spp=ref_spp, threads=threads, cache=cache, log=log)


def _judge(out, spp, ref, tails, alpha):
    g = compare_render(out.mean, out.variance, spp, ref, alpha=alpha, tails=tails)
    m = mitsuba_rule(out.mean, ref.mean, ref.variance, spp, alpha=MITSUBA_ALPHA)
    return g, m


def run_selftest(mutants=None, *, spp: int = DEFAULT_SPP, width: int = DEFAULT_WIDTH,
                 ref_spp: int = DEFAULT_REF_SPP, tail_spp: int = DEFAULT_TAIL_SPP,
                 spp_ladder=DEFAULT_SPP_LADDER, alpha: float = DEFAULT_CASE_ALPHA, seed: int = DEFAULT_SEED,
                 controls: bool = True, threads=None, cache=None, on_row=None, log=None) -> SelftestReport:
    """Render every mutant (or those named) and record which rule catches it at which budget.

    Parameters
    ----------
    mutants : sequence of str, str or None
        Mutant names (None: the whole catalogue; a string may be comma-separated).
    spp, width, ref_spp, tail_spp, seed : int, keyword-only
        The verdict's budget, the image side, the references' and tail references' spp and the
        renders' seed (defaults: the gate's).
    spp_ladder : sequence of int, keyword-only
        Budgets below ``spp`` at which each mutant is judged too (:func:`ladder`).
    alpha : float, keyword-only
        Level of each gate comparison.
    controls : bool, keyword-only
        Also judge the unmutated tracer on each (scene, strategy) at ``spp``.
    threads, cache, on_row, log : keyword-only
        Rendering threads, cache root, a callable taking each row and one taking a progress line.

    Returns
    -------
    SelftestReport
        One row (dict) per mutant: its catalogue entry, the gate's ``verdict`` at ``spp`` and
        figures, ``caught`` (verdict 'fail'), ``caught_by_mitsuba_rule``, the smallest budget
        each caught it at (None: none), the ``ladder`` of verdicts and the control's verdicts.
    """
    selected = resolve_mutants(mutants)
    spp = positive_int("spp", spp, minimum=2)
    width = positive_int("width", width)
    ref_spp = positive_int("ref_spp", ref_spp, minimum=2)
    tail_spp = positive_int("tail_spp", tail_spp, minimum=2)
    seed = positive_int("seed", seed, minimum=0, maximum=SEED_MAX)
    budgets = ladder(spp, [positive_int("spp_ladder", s, minimum=2) for s in spp_ladder])
    if threads is not None:
        threads = positive_int("threads", threads)
    if not (isinstance(alpha, (int, float)) and 0 < alpha < 1):
        raise ValueError(f"alpha must be in (0, 1), got {alpha!r}")
    say = log or (lambda line: None)

    t_start = time.perf_counter()
    scenes, refs, control = {}, {}, {}
    rows = []
    for mut in selected:
        t0 = time.perf_counter()
        if mut.scene not in scenes:
            scenes[mut.scene] = selftest_scene(mut.scene, width=width)
            say(f"reference of {mut.scene} (rendered with Mitsuba at {ref_spp} spp if not cached)")
            refs[mut.scene] = scene_reference(mut.scene, scenes[mut.scene], ref_spp=ref_spp, threads=threads,
                                              cache=cache, log=say)
        scene, ref = scenes[mut.scene], refs[mut.scene]
        key = (mut.scene, mut.strategy)
        if controls and key not in control:
            say(f"control: the tracer on {mut.scene} / {mut.strategy} at {spp} spp")
            tails0 = tail_reference(scene, strategy=mut.strategy, spp=tail_spp, threads=threads, cache=cache, log=say)
            out = render_mutant(scene, "none", spp=spp, strategy=mut.strategy, seed=seed, threads=threads)
            g, m = _judge(out, spp, ref, tails0, alpha)
            control[key] = {"verdict": g.verdict, "p_value": float(g.p_value),
                            "caught_by_mitsuba_rule": not m.passed}

        say(f"{mut.name}: tail reference ({tail_spp} spp, cached per mutant)")

        def render(sc, *, _name=mut.name, **kw):
            return render_mutant(sc, _name, **kw)

        # keyed by the mutant and the build of the mutants module (rt.build_id() covers the tracer's only)
        tails = tail_reference(scene, strategy=mut.strategy, spp=tail_spp, threads=threads, cache=cache,
                               render=render, variant=f"{mut.name}@{mutants_build_id()}", log=say)
        steps = []
        for n in budgets:  # the last is spp: the row's verdict
            say(f"{mut.name}: {mut.scene} / {mut.strategy} at {n} spp")
            out = render_mutant(scene, mut.name, spp=n, strategy=mut.strategy, seed=seed, threads=threads)
            g, m = _judge(out, n, ref, tails, alpha)
            steps.append({"spp": n, "verdict": g.verdict, "p_value": float(g.p_value),
                          "relative_bias": float(g.relative_bias), "caught_by_mitsuba_rule": not m.passed})
        row = {
            **mut.to_dict(), "mutant": mut.name, "width": width, "spp": spp, "seed": seed, "alpha": alpha,
            "verdict": g.verdict, "reason": g.reason, "caught": g.verdict == "fail", "p_value": float(g.p_value),
            "relative_bias": float(g.relative_bias), "relative_bias_se": float(g.relative_bias_se),
            "worst_tile_relative_bias": float(g.worst_tile_relative_bias),
            "min_detectable_bias": float(g.min_detectable_bias),
            "min_detectable_tile_bias": float(g.min_detectable_tile_bias),
            "caught_by_mitsuba_rule": not m.passed, "mitsuba_fraction_passed": float(m.fraction_passed),
            "smallest_spp_caught": next((s["spp"] for s in steps if s["verdict"] == "fail"), None),
            "smallest_spp_caught_by_mitsuba_rule": next((s["spp"] for s in steps if s["caught_by_mitsuba_rule"]),
                                                        None),
            "ladder": steps, "reference": ref.source, "reference_spp": int(ref.spp), "tail_spp": tail_spp,
            "control_verdict": control[key]["verdict"] if controls else None,
            "control_caught_by_mitsuba_rule": control[key]["caught_by_mitsuba_rule"] if controls else None,
            "seconds": time.perf_counter() - t0,
        }
        del row["name"]
        rows.append(row)
        if on_row:
            on_row(row)
    return SelftestReport(rows=rows, controls=control, alpha=float(alpha), spp=spp,
                          seconds=time.perf_counter() - t_start)
