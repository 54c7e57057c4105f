"""The harness's self-test (``rtbench selftest``): the gate's power against seeded bugs.

:data:`CATALOGUE` lists the mutants (realistic bugs compiled into a second build of the core,
reachable only through :mod:`reference_tracer.testing`) and the scene and strategy that expose
each (with three scenes of its own); :func:`run_selftest` records
whether the gate and Mitsuba's rule catch each one, and from how many spp. The printed table:
:mod:`benchmarks.commands.selftest`.
"""
from __future__ import annotations

from reference_tracer.testing import mutant_id, mutant_names, render_mutant

from .catalogue import CATALOGUE, SELFTEST_SCENES, Mutant, resolve_mutants, selftest_scene
from .driver import DEFAULT_CASE_ALPHA, DEFAULT_SPP_LADDER, SelftestReport, ladder, run_selftest, scene_reference

__all__ = ["CATALOGUE", "Mutant", "resolve_mutants", "DEFAULT_CASE_ALPHA", "DEFAULT_SPP_LADDER",
           "SelftestReport", "ladder", "run_selftest", "scene_reference", "mutant_id", "mutant_names",
           "render_mutant", "SELFTEST_SCENES", "selftest_scene"]
