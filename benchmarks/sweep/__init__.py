"""Error-vs-spp sweeps into a results store, and their per-curve summary.

This package's one job: run the renders of a sweep (locally or on Dask), measure each
against its reference, append it to the results store, and summarise the curves.

A *job* is one render: (scene, renderer, strategy, spp, seed, width, height). Our tracer
runs every strategy asked for; Mitsuba runs its ``path`` integrator (strategy
``"path"``) at the same spp and seeds. Each job is measured against the cached Mitsuba
reference of its scene and size (``benchmarks.references``) and appended to the results
store (``benchmarks.store``, format in ``benchmarks/STORE.md``) as soon as it ends, so an
interrupted sweep resumes where it stopped and never renders a finished job again.

Modules: :mod:`~benchmarks.sweep.jobs` (the job list and its validation),
:mod:`~benchmarks.sweep.execute` (one job, anywhere), :mod:`~benchmarks.sweep.runners`
(local and Dask), :mod:`~benchmarks.sweep.run` (``run_sweep``),
:mod:`~benchmarks.sweep.summary` (``summary.json``), :mod:`~benchmarks.sweep.presets`
(``rtbench run``'s presets).

Seeds
-----
The ``seed`` of a job is an index ``0 .. K-1``. The seed actually given to the renderer,
``render_seed``, is hashed from (seed, spp): renders at different spp are independent
(our tracer's streams would otherwise make spp=2 a prefix of spp=4), which the
convergence fit and its confidence interval assume. Mitsuba derives its own batch seeds
from ``render_seed`` by hashing as well, and the reference uses a seed far from these.

Timing
------
Locally one job runs at a time with every core; our ``threads`` and Mitsuba's
(``drjit.set_thread_count``) are set to the same number and recorded. Mitsuba jobs time
one ``mi.render`` call at the full spp (after an untimed warm-up that compiles its
kernels, reported as ``compile_seconds``), like our single ``rt.render`` call; that
single batch carries no per-pixel variance, so Mitsuba records have ``variance: null``
(``summary.json`` has the between-seed variance for every curve). With ``scheduler=``
the jobs go to a Dask distributed cluster, one job per worker at a time, using as many
threads as the worker has.

Examples
--------
>>> from benchmarks.sweep import Group, run_sweep
>>> g = Group(scenes=("cornell_box",), strategies=("mis",), spps=(1, 4), seeds=2,
...           width=8, height=8, reference_spp=256)
>>> result = run_sweep([g], out="/tmp/rtbench-demo", progress=False)  # doctest: +SKIP
>>> result.done, result.failed  # doctest: +SKIP
(8, 0)
"""
from __future__ import annotations

from ..constants import BIAS_TEST_ALPHA, MITSUBA_STRATEGY
from .coerce import as_float, finite
from .execute import TIMING_FIELDS, execute_job, job_metrics, machine_info, reference_info, run_versions
from .jobs import Group, Job, check_int, check_int_list, image_paths, make_jobs, render_seed, validate_group
from .run import SweepResult, prepare_references, run_sweep
from .summary import TARGET_RELATIVE_RMSE, _bias_verdict, summarize, target_rmse  # noqa: F401 - _bias_verdict: tests

__all__ = ["Job", "Group", "SweepResult", "MITSUBA_STRATEGY", "DEFAULT_ALPHA", "TARGET_RELATIVE_RMSE",
           "TIMING_FIELDS", "make_jobs", "render_seed", "validate_group",
           "image_paths", "check_int", "check_int_list", "execute_job", "job_metrics", "reference_info",
           "prepare_references", "run_sweep", "summarize", "target_rmse", "machine_info", "run_versions",
           "finite", "as_float"]

#: level of one bias test in summary.json (``benchmarks.constants.BIAS_TEST_ALPHA``; one-sided,
#: see ``metrics.bias_variance``).
DEFAULT_ALPHA = BIAS_TEST_ALPHA
