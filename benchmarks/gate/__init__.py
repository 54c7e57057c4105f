"""The statistical regression gate: does our tracer still converge to the reference images?

One job, in three modules:

- :mod:`~benchmarks.gate.statistics`: :func:`compare`, the test of one render against
  one reference (pixel, tile and image levels; its value :class:`GateResult` is in
  :mod:`~benchmarks.gate.result`); Sidak's correction is :mod:`benchmarks.stats`'s. :mod:`~benchmarks.gate.mitsuba_rule`
  re-implements Mitsuba 3's own per-pixel rule (:func:`mitsuba_rule`) to compare the two;
  :mod:`~benchmarks.gate.paired`: :func:`judge`, the same test of one render against another
  of the same estimator (``rtbench compare``'s verdict).
- :mod:`~benchmarks.gate.suite`: the suite driver behind ``rtbench gate``
  (:func:`run_gate`: scenes, references, renders, p-value images of failures).
- :mod:`~benchmarks.gate.power`: the measured power of the gate on injected biases
  (the table's rows; its printing is in :mod:`benchmarks.commands._gate_tables`).
- :mod:`~benchmarks.gate.heavy_tails`: when a statistic of a heavy-tailed estimator may
  be tested (Edgeworth bound) and how many spp would decide.
- :mod:`~benchmarks.gate.calibration`: the measured false-alarm rate on unbiased renders
  of every strategy (``rtbench gate --calibrate``).

Verdicts are three-valued (pass, fail, undetermined) and valid for heavy-tailed
estimators when the tail diagnostics of the same estimator are given
(:mod:`benchmarks.tails`); the method is in ``benchmarks/STATISTICS.md``.

The run's false-alarm rate is :data:`benchmarks.constants.GATE_ALPHA`; the strategies are
:data:`benchmarks.constants.STRATEGIES`; references are
:class:`benchmarks.references.Reference` objects (a Mitsuba render or a closed form).

Examples
--------
>>> import numpy as np
>>> from benchmarks.gate import compare
>>> ref = np.full((8, 8, 3), 0.5)
>>> compare(ref, np.full_like(ref, 0.25), 64, ref, np.full_like(ref, 0.25), 4096).passed
True
"""
from __future__ import annotations

from .calibration import CalibrationRow, calibrate, clopper_pearson
from .mitsuba_rule import MITSUBA_ALPHA, MitsubaRuleResult, mitsuba_rule
from .power import INJECTIONS, QUICK_SUITE_COMPARISONS, PowerRow, injected_scene, power_row, power_table
from .result import LEVELS, GateResult
from .heavy_tails import DEFAULT_VALIDITY, edgeworth_error, spp_needed
from .paired import EstimatorKnowledge, judge
from .statistics import compare
from .suite import (DEFAULT_REF_SPP, DEFAULT_SEED, DEFAULT_SPP, DEFAULT_STRATEGY, DEFAULT_WIDTH, GateCase,
                    GateReport, compare_render, gate_reference, gate_scene, resolve_scenes, resolve_strategies,
                    run_gate, write_p_images)

__all__ = [
    # statistics
    "compare", "edgeworth_error", "spp_needed", "DEFAULT_VALIDITY", "LEVELS", "GateResult", "mitsuba_rule", "MitsubaRuleResult", "MITSUBA_ALPHA",
    "EstimatorKnowledge", "judge",
    # suite driver
    "DEFAULT_SPP", "DEFAULT_WIDTH", "DEFAULT_REF_SPP", "DEFAULT_SEED", "DEFAULT_STRATEGY", "GateCase",
    "GateReport", "gate_scene", "gate_reference", "compare_render", "resolve_scenes", "resolve_strategies",
    "run_gate", "write_p_images",
    # calibration
    "CalibrationRow", "calibrate", "clopper_pearson",
    # power
    "INJECTIONS", "QUICK_SUITE_COMPARISONS", "PowerRow", "injected_scene", "power_row", "power_table",
]
