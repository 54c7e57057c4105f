"""Error-vs-spp sweeps into a results store, and their per-curve summary.

A *job* is one render (scene, renderer, strategy, spp, seed, width, height), measured
against the cached reference of its scene and size and appended to the results store as
soon as it ends, so an interrupted sweep resumes where it stopped. Seeds, timing and the
summary's figures: docs/rtbench.md and ``benchmarks/STATISTICS.md``.

Examples
--------
>>> from benchmarks.sweep import Group, run_sweep
>>> g = Group(scenes=("cornell_box",), strategies=("mis",), spps=(1, 4), seeds=2,
...           width=8, height=8, reference_spp=256)
>>> run_sweep([g], out="/tmp/rtbench-demo", progress=False).done  # doctest: +SKIP
8
"""
from __future__ import annotations

from ..constants import BIAS_TEST_ALPHA as DEFAULT_ALPHA
from ..numbers import finite
from .execute import TIMING_FIELDS, job_metrics
from .jobs import Group, Job, make_jobs, render_seed
from .run import run_sweep
from .summary import summarize

__all__ = ["DEFAULT_ALPHA", "Group", "Job", "TIMING_FIELDS", "finite", "job_metrics", "make_jobs", "render_seed",
           "run_sweep", "summarize"]
