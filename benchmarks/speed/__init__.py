"""Speed measurements: ours against Mitsuba 3, on renders and on raw ray casting (``rtbench speed``).

:func:`render_benchmark` (paired renders: paths/s, efficiency; its headline :func:`suite_summary`),
:func:`ray_benchmark` (closest hits against Embree) and :func:`scaling_benchmark` (cost against work) return JSON-able
dicts; :func:`speed_verdicts` judges the speed targets on them (:mod:`.targets`); :mod:`.builds` builds the core in
other configurations and runs code against them. Speed is measured and reported, never asserted by the tests. How to
measure and today's numbers: ``benchmarks/PERFORMANCE.md``.
"""
from __future__ import annotations

from .common import WALL_CLOCK_NOTE
from .rays import (hit_agreement, intersect_mitsuba, intersect_ours, mesh_scene, primary_rays, random_rays,
                   ray_benchmark, torus_mesh)
from .render import DEFAULT_RR_DEPTHS, DEFAULT_STRATEGIES, DEFAULT_VARIANTS, REFERENCE_KINDS, render_benchmark, rr_label
from .scaling import fit_log_growth, scaling_benchmark
from .suite import GEOMEAN, suite_summary
from .targets import speed_verdicts

__all__ = ["WALL_CLOCK_NOTE", "DEFAULT_STRATEGIES", "DEFAULT_VARIANTS", "DEFAULT_RR_DEPTHS", "REFERENCE_KINDS",
           "render_benchmark", "rr_label", "suite_summary", "GEOMEAN", "ray_benchmark", "scaling_benchmark",
           "torus_mesh", "mesh_scene", "primary_rays", "random_rays", "intersect_ours", "intersect_mitsuba",
           "hit_agreement", "fit_log_growth", "speed_verdicts"]
