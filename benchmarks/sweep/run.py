"""``run_sweep``: the run's settings into ``meta.json``, the references, every job not yet
stored (locally or on Dask), then ``summary.json``."""
from __future__ import annotations

import dataclasses
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from mitsuba_scenes.scene_files import scene_file
from reference_tracer.cpus import default_threads
from reference_tracer.validation import positive_int

from .. import references as R
from .. import tails as T
from ..constants import BIAS_TEST_ALPHA, CLOSED_FORM
from ..external import external
from ..files import slug
from ..numbers import finite
from ..references import closed_form_reference_of, mitsuba_identity, reference
from ..scenes import scene_at
from ..store import (file_sha256, finished_keys, job_records, read_meta, read_records, record_key, store_path,
                     timestamp, update_meta, write_image, writer_lock)
from ..tails import DEFAULT_TAIL_SPP
from .execute import machine_info, run_versions
from .jobs import Group, renderer_builds
from .progress import Phases, Progress, render_cost
from .runners import run_dask, run_local
from .summary import TARGET_RELATIVE_RMSE, summarize


@dataclass
class SweepResult:
    """What :func:`run_sweep` did: ``jobs`` planned, ``done`` rendered now, ``skipped`` already
    stored, ``failed`` (label, error) pairs, the summary ``rows`` and each phase's time."""

    store: Path
    jobs: int = 0
    done: int = 0
    skipped: int = 0
    failed: list = field(default_factory=list)
    seconds: float = 0.0
    rows: list = field(default_factory=list)
    interrupted: bool = False
    phases: Phases = field(default_factory=Phases)


def prepare_references(groups, store: Path, *, variant, threads, cache, say, bar) -> dict:
    """``{(scene, width, height): Reference}``: the closed form where a scene has one, else
    Mitsuba's (cached); each copied into the store and recorded in ``meta.json``
    (``references``: the first group naming a scene, its main sweep; ``references_by_size``)."""
    refs, by_scene, by_size = {}, {}, {}
    old_refs = read_meta(store).get("references_by_size", {})
    for g in groups:
        for scene in g.scenes:
            k = (scene, g.width, g.height)
            if k in refs:
                continue
            t0 = time.perf_counter()
            bar.current(f"reference {scene} {g.width}x{g.height} ({g.reference_spp} spp)")
            ref = closed_form_reference_of(scene, g.width, g.height)
            if ref is None:
                ref = reference(scene_at(scene, g.width, g.height), spp=g.reference_spp, variant=variant,
                                threads=threads, cache=cache, log=say)
            bar.advance(_reference_cost(g, ref.cached or ref.variant == CLOSED_FORM))
            how = ("closed form" if ref.variant == CLOSED_FORM else
                   "cached" if ref.cached else f"rendered in {time.perf_counter() - t0:.1f} s")
            say(f"reference {scene} {g.width}x{g.height}: {ref.spp} spp, {ref.variant} ({how})")
            entry = {"spp": ref.spp, "seed": ref.seed, "width": g.width, "height": g.height, "variant": ref.variant,
                     "key": ref.key, "render_seconds": ref.seconds, "scene_hash": ref.scene_hash[:16] or None,
                     "scene_source": getattr(scene_file(scene), "path", None),
                     **_store_copy(store, f"references/{slug(scene, f'{g.width}x{g.height}', f'spp{ref.spp}')}",
                                   ref, old_refs)}
            by_size[f"{scene}@{g.width}x{g.height}"] = entry
            by_scene.setdefault(scene, entry)  # the first group naming a scene is its main sweep
            refs[k] = ref
    update_meta(store, references=by_scene, references_by_size=by_size)  # merged into the stored ones
    return refs


def _reference_cost(g, cached: bool) -> float:
    """Planned seconds of one reference of group ``g`` (a cached one costs a read)."""
    return 0.05 if cached else render_cost(g.width * g.height, g.reference_spp, renderer="mitsuba", overhead=0.5)


def _check_reference_spps(groups) -> None:
    """``ValueError`` where two groups ask one scene at one size for references of different spp
    (a scene and size has one reference), before anything is rendered."""
    asked = {}
    for g in groups:
        for scene in g.scenes:
            spp = asked.setdefault((scene, g.width, g.height), g.reference_spp)
            if spp != g.reference_spp:
                raise ValueError(f"{scene} {g.width}x{g.height} appears in two groups with different "
                                 f"reference spp ({spp} and {g.reference_spp})")


def _plan_progress(bar, groups, todo, *, variant, cache) -> dict:
    """Plan every step of the run on ``bar`` (cached ones cost a read): references, jobs, tail
    references; returns ``{(scene, strategy, width, height): cost}`` of the tail references."""
    firsts = {}
    for g in groups:
        for scene in g.scenes:
            firsts.setdefault((scene, g.width, g.height), g)
    for (scene, w, h), g in firsts.items():
        bar.plan(_reference_cost(g, closed_form_reference_of(scene, w, h) is not None or R.is_cached(
            scene_at(scene, w, h), spp=g.reference_spp, variant=variant, cache=cache)))
    bar.plan(sum(j.cost for j in todo), len(todo))
    keys = dict.fromkeys((scene, s, g.width, g.height) for g in groups if g.seeds >= 2 for scene in g.scenes
                         for s in g.strategies)
    tails = {(scene, s, w, h): 0.05 if T.is_cached(scene_at(scene, w, h), strategy=s, cache=cache)
             else render_cost(w * h, DEFAULT_TAIL_SPP) for scene, s, w, h in keys}
    bar.plan(sum(tails.values()), len(tails))
    return tails


def _store_copy(store: Path, stem: str, ref, old_refs: dict) -> dict:
    """The ``meta.json`` fields of the store's copy of a reference (``stem``.exr, ``stem``_var.exr):
    paths and checksums. A copy recorded with the same cache key whose bytes match is kept;
    anything else is written afresh from ``ref``."""
    out = {"path": f"{stem}.exr", "variance_path": f"{stem}_var.exr"}
    old = next((e for e in old_refs.values() if e.get("path") == out["path"]), {})
    for rel_key, sum_key, img in (("path", "sha256", ref.mean), ("variance_path", "variance_sha256", ref.variance)):
        rel = out[rel_key]
        fresh = (old.get("key") == ref.key and old.get(sum_key) and (store / rel).is_file()
                 and file_sha256(store / rel) == old[sum_key])
        if not fresh:
            write_image(store, rel, img)
        out[sum_key] = old[sum_key] if fresh else file_sha256(store / rel)
    return out


def _record_settings(store, groups, *, threads, scheduler, variant, preset, alpha) -> None:
    """The run's settings, machine and versions into ``meta.json`` (its first date is kept)."""
    meta = read_meta(store)
    update_meta(store, date=meta.get("date") or timestamp(),
                preset=preset if preset is not None else meta.get("preset", "custom"),
                threads=None if scheduler is not None else int(threads),
                scheduler=str(scheduler) if isinstance(scheduler, str) else (None if scheduler is None else "client"),
                machine=machine_info(), versions=run_versions(variant), alpha=alpha,
                target_relative_rmse=TARGET_RELATIVE_RMSE,
                scene_files={n: scene_file(n).to_dict() for n in dict.fromkeys(s for g in groups for s in g.scenes)
                             if scene_file(n) is not None},
                groups=[{"name": g.name, "scenes": list(g.scenes), "strategies": list(g.strategies),
                         "spps": list(g.spps), "seeds": g.seeds, "width": g.width, "height": g.height,
                         "mitsuba": g.mitsuba, "reference_spp": g.reference_spp,
                         "externals": {e: external(e).template for e in g.externals}} for g in groups])


def _plan(groups, builds) -> tuple:
    """``(jobs without repeats in group order, {curve: its highest spp})``, each job given its
    renderer's build from ``builds``."""
    plan, top, seen = [], {}, set()
    for g in groups:
        for job in g.jobs():
            job = dataclasses.replace(job, build=builds.get(job.renderer))
            if job.key in seen:
                continue
            seen.add(job.key)
            plan.append(job)
            top[job.curve] = max(top.get(job.curve, 0), job.spp)
    return plan, top


def _warn_stale(store, refs, say) -> None:
    """Say so when stored jobs were measured against another reference than this run's."""
    stale = [r for r in read_records(store) if (r["scene"], r["width"], r["height"]) in refs
             and r.get("reference_key") not in (None, refs[(r["scene"], r["width"], r["height"])].key)]
    if stale:
        say(f"warning: {len(stale)} stored job(s) were measured against another reference (other spp, seed, "
            f"Mitsuba or scene version); they are kept - use a new --out to start afresh")


def _say_new_builds(store, plan, done_keys, say) -> None:
    """Name both builds when stored jobs were rendered by another build (they are rendered again)."""
    have = {k[:-1]: k[-1] for k in done_keys}
    other = sorted({(j.renderer, str(have[j.key[:-1]]), str(j.build)) for j in plan
                    if j.key not in done_keys and j.key[:-1] in have})
    for renderer, old, new in other:
        say(f"build changed for {renderer}: {store} holds build {old}, this is build {new}; its jobs are "
            f"rendered again (the old records stay in the file; curves show the latest build)")


def _recorded(store) -> int:
    """How many distinct jobs the store holds (read quietly: the run warns about bad lines once)."""
    return len({record_key(r) for r in job_records(store)[0]})


def _start_run(store) -> int:
    """Append this run to ``meta.json``'s ``runs`` (started now, nothing done yet); its index."""
    runs = read_meta(store).get("runs", [])
    runs.append({"started": timestamp(), "ended": None, "seconds": None, "jobs_done": 0, "interrupted": None})
    update_meta(store, runs=runs)
    return len(runs) - 1


def _end_run(store, index: int, **fields) -> None:
    """Complete this run's entry in ``meta.json`` (end, seconds, jobs stored) and the total."""
    runs = read_meta(store).get("runs", [])
    runs[index:index + 1] = [{**(runs[index] if index < len(runs) else {}), "ended": timestamp(), **fields}]
    update_meta(store, runs=runs, total_seconds=sum(finite(r.get("seconds")) or 0.0 for r in runs))


def run_sweep(groups, *, out, threads: int | None = None, scheduler=None, variant: str | None = None,
              progress: bool = True, cache=None, alpha: float = BIAS_TEST_ALPHA, preset: str | None = None,
              escalate_tails: bool = True) -> SweepResult:
    """Run (or resume) a sweep into a results store and write its summary.

    Interrupt it at any point and run it again: finished jobs are skipped. The store's writer
    lock is held throughout (a second run waits, then resumes); ``meta.json``'s ``runs`` gets
    this run's entry even when interrupted (``benchmarks/STORE.md``).

    Parameters
    ----------
    groups : sequence of Group
    out : str or Path, keyword-only
        The results store folder.
    threads, scheduler : keyword-only
        Threads per local job (default all cores), or a Dask scheduler address or Client
        (each worker's own threads).
    variant, preset : str or None, keyword-only
        Mitsuba variant (default: the fastest that works); the preset recorded in ``meta.json``.
    progress : bool or Progress, keyword-only
        Show a progress bar (the caller's, which may plan more steps) and messages.
    cache, alpha, escalate_tails : keyword-only
        As :func:`benchmarks.sweep.summarize` (``cache`` also for the references).

    Returns
    -------
    SweepResult
    """
    groups = list(groups)
    if not groups or not all(isinstance(g, Group) for g in groups):
        raise ValueError(f"groups must be benchmarks.sweep.Group objects, got {groups!r:.200}")
    threads = default_threads() if threads is None else positive_int("threads", threads)
    if not 0 < alpha < 1:
        raise ValueError(f"alpha must be in (0, 1), got {alpha}")
    _check_reference_spps(groups)
    store = store_path(out)
    variant, mitsuba_version = mitsuba_identity(variant)
    with writer_lock(store, say=lambda text: print(text, file=sys.stderr, flush=True)):
        t_start = time.perf_counter()  # this run's time, not its wait for another run
        result = SweepResult(store=store)
        run_index = _start_run(store)
        recorded_before = _recorded(store)
        try:
            _sweep(groups, store, result, threads=threads, scheduler=scheduler, variant=variant,
                   mitsuba_version=mitsuba_version, cache=cache, alpha=alpha, preset=preset, progress=progress,
                   escalate_tails=escalate_tails)
        except BaseException:
            result.interrupted = True
            raise
        finally:
            result.seconds = time.perf_counter() - t_start
            # counted in the store (only this run appends, under the writer lock): exact even when
            # Ctrl-C lands between a record's write and the runner's count
            stored = _recorded(store) - recorded_before
            _end_run(store, run_index, seconds=result.seconds, jobs_done=stored, interrupted=result.interrupted)
    return result


def _sweep(groups, store, result, *, threads, scheduler, variant, mitsuba_version, cache, alpha,
           preset, progress, escalate_tails) -> None:
    """The steps of :func:`run_sweep`, with the store's writer lock held; fills ``result``."""
    _record_settings(store, groups, threads=threads, scheduler=scheduler, variant=variant, preset=preset, alpha=alpha)
    plan, top = _plan(groups, renderer_builds(variant, mitsuba_version))
    done_keys = finished_keys(store)
    todo = [j for j in plan if j.key not in done_keys]
    bar = progress if isinstance(progress, Progress) else Progress(enabled=bool(progress))
    log = bar.log  # silent unless the bar is shown
    tail_plan = _plan_progress(bar, groups, todo, variant=variant, cache=cache)
    try:
        with result.phases("references"):
            refs = prepare_references(groups, store, variant=variant, threads=threads, cache=cache, say=log, bar=bar)
        _warn_stale(store, refs, log)
        result.jobs, result.skipped = len(plan), len(plan) - len(todo)
        if result.skipped:
            log(f"resuming: {result.skipped} of {len(plan)} jobs already in {store}")
        _say_new_builds(store, plan, done_keys, log)

        def keep(job):  # seed 0's image; the top spp's mean and variance for the bias test
            return {"keep_image": job.seed == 0, "keep_stats": job.spp == top[job.curve]}

        with result.phases("jobs"):
            if scheduler is None:
                run_local(todo, refs, store, threads=threads, variant=variant, keep=keep, bar=bar, say=log,
                          failures=result.failed, tally=result)
            else:
                run_dask(todo, refs, store, address=scheduler, variant=variant, keep=keep, bar=bar, say=log,
                         failures=result.failed, tally=result)
        with result.phases("tail references and summary"):
            result.rows = summarize(store, alpha=alpha, cache=cache,
                                    threads=threads, log=log, escalate=escalate_tails, bar=bar,
                                    tail_plan=tail_plan)
    finally:
        if bar is not progress:
            bar.stop()
