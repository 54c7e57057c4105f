"""The statistical regression gate: does our tracer still converge to the reference images?

:func:`compare` tests one render against one reference (pixel, tile, image and
neighbour-correlation levels; verdict pass, fail or undetermined, a :class:`GateResult`);
:func:`judge` applies it to two renders of one estimator (``rtbench compare``);
:func:`run_gate` drives ``rtbench gate`` over the suite; :func:`calibrate` measures the
false-alarm rate, :func:`power_row` the power on injected biases; :func:`mitsuba_rule`
re-implements Mitsuba 3's per-pixel rule for comparison. The method, its assumptions and
its measured rates: ``benchmarks/STATISTICS.md``.

Examples
--------
>>> import numpy as np
>>> from benchmarks.gate import compare
>>> ref = np.full((8, 8, 3), 0.5)
>>> compare(ref, np.full_like(ref, 0.25), 64, ref, np.full_like(ref, 0.25), 4096).passed
True
"""
from __future__ import annotations

from .calibration import CalibrationRow, calibrate
from .levels import DEFAULT_VALIDITY, edgeworth_error, spp_needed
from .power import (INJECTIONS, MITSUBA_ALPHA, QUICK_SUITE_COMPARISONS, MitsubaRuleResult, PowerRow, injected_scene,
                    mitsuba_rule, power_row)
from .statistics import LEVELS, EstimatorKnowledge, GateResult, compare, judge
from .suite import (DEFAULT_REF_SPP, DEFAULT_SEED, DEFAULT_SPP, DEFAULT_STRATEGY, DEFAULT_WIDTH, GateCase,
                    GateReport, compare_render, gate_reference, gate_scene, resolve_scenes, resolve_strategies,
                    run_gate, write_p_images)

__all__ = [
    "compare", "edgeworth_error", "spp_needed", "DEFAULT_VALIDITY", "LEVELS", "GateResult", "mitsuba_rule",
    "MitsubaRuleResult", "MITSUBA_ALPHA", "EstimatorKnowledge", "judge",
    "DEFAULT_SPP", "DEFAULT_WIDTH", "DEFAULT_REF_SPP", "DEFAULT_SEED", "DEFAULT_STRATEGY", "GateCase",
    "GateReport", "gate_scene", "gate_reference", "compare_render", "resolve_scenes", "resolve_strategies",
    "run_gate", "write_p_images", "CalibrationRow", "calibrate",
    "INJECTIONS", "QUICK_SUITE_COMPARISONS", "PowerRow", "injected_scene", "power_row",
]
