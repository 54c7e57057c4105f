"""The harness's self-test: the gate's power against real bugs, measured on seeded ones.

One job: render the tracer with each bug of a catalogue of realistic mistakes
("mutants", compiled into a second build of the C++ core and reachable only through
:mod:`reference_tracer.testing`) and record whether
the gate (:func:`benchmarks.gate.compare`, with the mutant's own tail reference) and
Mitsuba's own rule (:func:`benchmarks.gate.mitsuba_rule`) catch it at the gate's default
budget, and from how many samples per pixel on (``rtbench selftest``).

- :mod:`~benchmarks.selftest.catalogue`: the mutants (:data:`CATALOGUE`): what each breaks,
  the scene and strategy it is tested with and why;
- :mod:`~benchmarks.selftest.scenes`: the three scenes built for bugs no suite scene shows;
- :mod:`~benchmarks.selftest.driver`: :func:`run_selftest`.

The printed table is :mod:`benchmarks.commands.selftest`.
"""
from __future__ import annotations

from reference_tracer.testing import mutant_id, mutant_names, render_mutant

from .catalogue import CATALOGUE, Mutant, mutant, resolve_mutants
from .driver import DEFAULT_CASE_ALPHA, DEFAULT_SPP_LADDER, SelftestReport, ladder, run_selftest, scene_reference
from .scenes import SELFTEST_SCENES, selftest_scene

__all__ = ["CATALOGUE", "Mutant", "mutant", "resolve_mutants", "DEFAULT_CASE_ALPHA", "DEFAULT_SPP_LADDER",
           "SelftestReport", "ladder", "run_selftest", "scene_reference", "mutant_id", "mutant_names",
           "render_mutant", "SELFTEST_SCENES", "selftest_scene"]
