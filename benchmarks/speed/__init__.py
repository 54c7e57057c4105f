"""Speed measurements: how fast ours is against Mitsuba 3, on renders and on raw ray casting.

Three measurements, each a plain function returning a JSON-able dict (``rtbench speed``
prints them; its tables live in :mod:`benchmarks.commands.speed`):

:func:`render_benchmark` (:mod:`.render`)
    Paired, interleaved renders of each scene by ours (each strategy) and Mitsuba's
    ``path`` integrator (each variant), in each Russian-roulette configuration (Mitsuba's
    default ``rr_depth`` 5, then none): paths/s, ms/spp, RMSE and efficiency at equal
    spp; its headline (:func:`suite_summary`, :mod:`.suite`) is every scene and the
    geometric mean of the ratios.
:func:`ray_benchmark` (:mod:`.rays`)
    Closest-hit queries on a generated torus with primary and random rays, ours vs
    Mitsuba (Embree) on the same rays: Mrays/s and hit agreement.
:func:`scaling_benchmark` (:mod:`.scaling`)
    Paths/s vs resolution and threads, and cost per ray vs triangle count fitted as
    ``a + b ln n``.

Timing, robust summaries (the median and its order-statistics interval), machine
identity and Mitsuba variant selection are shared (:mod:`.common`): wall and process CPU
time are recorded side by side, since the machine may be shared. Speed is measured and
reported, never asserted by the tests; the speed targets (:mod:`.targets`) are judged
from a run's own results: :func:`speed_verdicts`, one verdict per target (met, not met or
not judged, with the median ratio and its 90% interval over the rounds).

Examples
--------
>>> from benchmarks.speed import hit_agreement
>>> import numpy as np
>>> hit_agreement(np.array([1.0, np.inf]), np.array([1.0, np.inf]))["hit_agreement"]
1.0
"""
from __future__ import annotations

from .common import WALL_CLOCK_NOTE, environment, median_order_interval
from .rays import (RAY_KINDS, hit_agreement, intersect_mitsuba, intersect_ours, mesh_scene, primary_rays,
                   random_rays, ray_benchmark, torus_mesh)
from .render import (DEFAULT_RR_DEPTHS, DEFAULT_STRATEGIES, DEFAULT_VARIANTS, REFERENCE_KINDS, render_benchmark,
                     rr_label)
from .scaling import fit_log_growth, scaling_benchmark
from .suite import GEOMEAN, geometric_mean, suite_summary
from .targets import TARGETS, Target, ray_verdicts, render_verdicts, speed_verdicts

__all__ = ["WALL_CLOCK_NOTE", "DEFAULT_STRATEGIES", "DEFAULT_VARIANTS", "DEFAULT_RR_DEPTHS", "REFERENCE_KINDS",
           "RAY_KINDS", "render_benchmark", "rr_label", "suite_summary", "geometric_mean", "GEOMEAN",
           "ray_benchmark", "scaling_benchmark",
           "torus_mesh", "mesh_scene", "primary_rays", "random_rays",
           "intersect_ours", "intersect_mitsuba", "hit_agreement", "fit_log_growth",
           "environment", "median_order_interval", "Target", "TARGETS", "render_verdicts", "ray_verdicts",
           "speed_verdicts"]
