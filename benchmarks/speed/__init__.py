"""Speed measurements against Mitsuba 3 (``rtbench speed``): :func:`render_benchmark` (paired renders, headline
:func:`suite_summary`), :func:`ray_benchmark` (closest hits against Embree), :func:`scaling_benchmark` (cost against
work); :func:`speed_verdicts` judges the speed targets and :func:`verdict_lines` words them (:mod:`.targets`);
:mod:`.builds` runs other builds of the core. Speed is reported, never asserted by the tests. How to measure, today's
numbers: ``benchmarks/PERFORMANCE.md``."""
from __future__ import annotations

from .common import WALL_CLOCK_NOTE
from .rays import (hit_agreement, intersect_mitsuba, intersect_ours, mesh_scene, primary_rays, random_rays,
                   ray_benchmark, torus_mesh)
from .render import (DEFAULT_RR_DEPTHS, DEFAULT_STRATEGIES, DEFAULT_VARIANTS, REFERENCE_KINDS, render_benchmark,
                     check_depths, render_config, rr_label)
from .scaling import fit_log_growth, scaling_benchmark
from .suite import GEOMEAN, suite_summary
from .targets import speed_verdicts, verdict_lines

__all__ = ["WALL_CLOCK_NOTE", "DEFAULT_STRATEGIES", "DEFAULT_VARIANTS", "DEFAULT_RR_DEPTHS", "REFERENCE_KINDS",
           "render_benchmark", "render_config", "check_depths", "rr_label", "suite_summary", "GEOMEAN", "ray_benchmark",
           "scaling_benchmark", "torus_mesh", "mesh_scene", "primary_rays", "random_rays", "intersect_ours",
           "intersect_mitsuba", "hit_agreement", "fit_log_growth", "speed_verdicts", "verdict_lines"]
