"""Sweeps: the job list, its execution (locally or on Dask) and the per-curve summary.

A *job* is one render: (scene, renderer, strategy, spp, seed, width, height). Our tracer
runs every strategy asked for; Mitsuba runs its ``path`` integrator (strategy
``"path"``) at the same spp and seeds. Each job is measured against the cached Mitsuba
reference of its scene and size (``benchmarks.references``) and appended to the results
store (``benchmarks.store``, format in ``benchmarks/STORE.md``) as soon as it ends, so an
interrupted sweep resumes where it stopped and never renders a finished job again.

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

import collections
import datetime as _dt
import hashlib
import math
import os
import platform
import socket
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import metrics as M
from .tables import finite
from .store import (KEY_FIELDS, append_record, finished_keys, read_json, read_records, store_path,
                    update_meta, write_image, write_json, SUMMARY, META)

__all__ = ["Job", "Group", "SweepResult", "MITSUBA_STRATEGY", "DEFAULT_ALPHA", "TARGET_RELATIVE_RMSE",
           "TIMING_FIELDS", "make_jobs", "render_seed", "default_threads", "scene_at",
           "execute_job", "run_sweep", "summarize", "target_rmse", "machine_info", "run_versions"]

#: the strategy name of Mitsuba's curves (its ``path`` integrator: NEE + BSDF sampling, MIS).
MITSUBA_STRATEGY = "path"
#: level of the bias test in summary.json (one-sided; see ``metrics.bias_variance``).
DEFAULT_ALPHA = 0.001
#: time-to-target uses target RMSE = this x the reference's RMS radiance.
TARGET_RELATIVE_RMSE = 0.1
#: how long to try to reach a Dask scheduler before giving up.
DASK_CONNECT_TIMEOUT = "20s"
#: record fields that depend on timing or on the machine (ignore them to compare two runs).
TIMING_FIELDS = ("seconds", "paths_per_second", "efficiency", "compile_seconds", "build_seconds",
                 "load_seconds", "wall_seconds", "finished", "host", "threads", "worker")


# ----------------------------------------------------------------------------------- jobs

@dataclass(frozen=True)
class Job:
    """One render of the sweep (its identity is the store key, ``STORE.md``)."""

    scene: str
    renderer: str
    strategy: str
    spp: int
    seed: int
    width: int
    height: int

    @property
    def key(self) -> tuple:
        return tuple(getattr(self, k) for k in KEY_FIELDS)

    @property
    def curve(self) -> tuple:
        return (self.scene, self.renderer, self.strategy, self.width, self.height)

    @property
    def label(self) -> str:
        who = self.strategy if self.renderer == "ours" else f"mitsuba {self.strategy}"
        return f"{self.scene} {self.width}x{self.height} {who} {self.spp} spp seed {self.seed}"

    @property
    def cost(self) -> float:
        """Rough relative cost for the progress bar's time estimate (seconds at ~1 us/sample)."""
        samples = self.width * self.height * self.spp
        return samples * 1e-6 + (0.3 if self.renderer == "mitsuba" else 0.03)


@dataclass(frozen=True)
class Group:
    """A block of a sweep: every scene x curve x spp x seed at one image size.

    Parameters
    ----------
    scenes : tuple of str
        Suite scene names.
    strategies : tuple of str
        Our strategies (``reference_tracer.STRATEGIES``).
    spps : tuple of int
        The spp ladder.
    seeds : int
        Number of independent seeds per (curve, spp); seed indices are ``0 .. seeds-1``.
    width, height : int
    mitsuba : bool
        Add Mitsuba's ``path`` curve.
    reference_spp : int
        Samples of the Mitsuba reference (keep it well above ``max(spps)``).
    name : str
        A label for messages.
    """

    scenes: tuple
    strategies: tuple
    spps: tuple
    seeds: int
    width: int
    height: int
    mitsuba: bool = True
    reference_spp: int = 4096
    name: str = "curves"

    def __post_init__(self):
        validate_group(self)

    def jobs(self) -> list:
        return make_jobs(self.scenes, strategies=self.strategies, spps=self.spps, seeds=self.seeds,
                         width=self.width, height=self.height, mitsuba=self.mitsuba)


def _int_list(name, values, minimum=1):
    if isinstance(values, (str, bytes)) or not hasattr(values, "__iter__"):
        raise ValueError(f"{name} must be a sequence of integers, got {values!r}")
    out = []
    for v in values:
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < minimum:
            raise ValueError(f"{name} must hold integers >= {minimum}, got {v!r}")
        out.append(int(v))
    if not out:
        raise ValueError(f"{name} is empty")
    if len(set(out)) != len(out):
        raise ValueError(f"{name} has repeated values: {out}")
    return tuple(out)


def validate_group(g: Group) -> None:
    """Raise ``ValueError`` with a clear message for a malformed :class:`Group`."""
    import reference_tracer as rt
    from mitsuba_scenes import list_scenes

    suite = list_scenes()
    if isinstance(g.scenes, str) or not g.scenes:
        raise ValueError(f"scenes must be a non-empty sequence of names, got {g.scenes!r}")
    unknown = [s for s in g.scenes if s not in suite]
    if unknown:
        raise ValueError(f"unknown scene(s) {unknown}; the suite has: {', '.join(suite)}")
    if isinstance(g.strategies, str):
        raise ValueError(f"strategies must be a sequence of names, got {g.strategies!r}")
    bad = [s for s in g.strategies if s not in rt.STRATEGIES]
    if bad:
        raise ValueError(f"unknown strategy/strategies {bad}; choose from {', '.join(rt.STRATEGIES)}")
    if len(set(g.strategies)) != len(tuple(g.strategies)):
        raise ValueError(f"strategies has repeated names: {list(g.strategies)}")
    if not g.strategies and not g.mitsuba:
        raise ValueError("nothing to render: no strategy and mitsuba=False")
    _int_list("spps", g.spps)
    for name in ("seeds", "width", "height"):
        v = getattr(g, name)
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
            raise ValueError(f"{name} must be an integer >= 1, got {v!r}")
    r = g.reference_spp
    if isinstance(r, bool) or not isinstance(r, (int, np.integer)) or r < 2:
        raise ValueError(f"reference_spp must be an integer >= 2, got {r!r}")


def make_jobs(scenes, *, strategies, spps, seeds: int, width: int, height: int,
              mitsuba: bool = True) -> list:
    """All jobs of a sweep, cheapest spp first (curves fill in together).

    Examples
    --------
    >>> jobs = make_jobs(["cornell_box"], strategies=["mis"], spps=[1, 4], seeds=2, width=8, height=8)
    >>> len(jobs), jobs[0].label
    (8, 'cornell_box 8x8 mis 1 spp seed 0')
    """
    spps = _int_list("spps", spps)
    curves = [("ours", s) for s in strategies] + ([("mitsuba", MITSUBA_STRATEGY)] if mitsuba else [])
    return [Job(scene, renderer, strategy, spp, seed, int(width), int(height))
            for scene in scenes for spp in sorted(spps) for seed in range(int(seeds))
            for renderer, strategy in curves]


def render_seed(seed: int, spp: int) -> int:
    """The seed given to the renderer for seed index ``seed`` at ``spp``: a 62-bit hash.

    Examples
    --------
    >>> render_seed(0, 4) != render_seed(0, 8) != render_seed(1, 4)
    True
    """
    h = hashlib.sha256(f"rtbench-sweep:{int(seed)}:{int(spp)}".encode()).digest()
    return int.from_bytes(h[:8], "little") >> 2


def default_threads() -> int:
    """All cores this process may use."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def scene_at(name: str, width: int, height: int):
    """Suite scene ``name`` with its camera resized to ``width`` x ``height``."""
    from mitsuba_scenes import get_scene

    return get_scene(name).with_camera_size(int(width), int(height))


def image_paths(job: Job) -> tuple:
    """Store-relative paths of a job's mean and variance EXR images."""
    stem = f"images/{job.scene}_{job.width}x{job.height}/{job.renderer}_{job.strategy}_spp{job.spp}_seed{job.seed}"
    return f"{stem}.exr", f"{stem}_var.exr"


def run_versions(variant: str | None = None) -> dict:
    """Versions recorded with every job: rtbench, our tracer, Mitsuba, Dr.Jit, variant, Python, NumPy."""
    import reference_tracer as rt

    out = {"rtbench": _rtbench_version(), "reference_tracer": rt.__version__,
           "python": platform.python_version(), "numpy": np.__version__}
    try:
        from mitsuba_scenes.variants import versions

        if variant is not None:
            from mitsuba_scenes.variants import select_variant

            select_variant(variant)
        out.update({k: v for k, v in versions().items() if k != "libllvm"})
    except Exception:  # noqa: BLE001 - Mitsuba missing: ours-only records still carry versions
        pass
    return out


def _rtbench_version() -> str:
    try:
        from importlib.metadata import version

        return version("rtbench")
    except Exception:  # noqa: BLE001
        return "unknown"


def machine_info() -> dict:
    """Cores, CPU model and platform for meta.json."""
    cpu = platform.processor() or ""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return {"cores": default_threads(), "cpu": cpu or "unknown", "platform": platform.platform(),
            "host": socket.gethostname()}


# ---------------------------------------------------------------------------- one job

def job_metrics(mean, variance, ref_mean, ref_variance, ref_spp) -> dict:
    """Error figures of one render against the reference (DESIGN.md section 4).

    ``mse_corrected`` removes the reference's own noise, ``mean(ref_variance) / ref_spp``;
    ``variance`` is the mean per-pixel per-sample variance of the render (None when the
    renderer gave none). Non-finite results become None.

    Examples
    --------
    >>> ref = np.ones((8, 8, 3)); img = ref + 0.1
    >>> m = job_metrics(img, None, ref, np.zeros_like(ref), 64)
    >>> round(m["mse"], 6), round(m["rmse"], 6), m["variance"]
    (0.01, 0.1, None)
    """
    mean = np.asarray(mean, dtype=np.float64)
    ref = np.asarray(ref_mean, dtype=np.float64)
    mse = M.mse(mean, ref)
    out = {"mse": mse, "rmse": math.sqrt(mse) if mse >= 0 else math.nan,
           "relmse": M.relmse(mean, ref), "ssim": M.ssim(mean, ref),
           "mse_corrected": M.mse_corrected(mean, ref, ref_variance, ref_spp),
           "variance": None}
    if variance is not None:
        v = np.asarray(variance, dtype=np.float64)
        if np.all(np.isfinite(v)):
            out["variance"] = float(v.mean())
    return {k: finite(v) for k, v in out.items()}


def execute_job(job: Job, ref_mean, ref_variance, ref_spp: int, *, threads: int, variant=None,
                keep_image: bool = False, keep_stats: bool = False, reference_info=None) -> dict:
    """Render one job, measure it against the reference and build its record.

    Runs anywhere (locally or on a Dask worker): it touches no file. Returns
    ``{"record": dict, "images": {relpath: array}}``; the caller writes the images
    and then appends the record.

    Parameters
    ----------
    job : Job
    ref_mean, ref_variance : (H, W, 3) arrays
        Reference mean and per-sample variance at the job's size.
    ref_spp : int
    threads : int, keyword-only
        Threads for our tracer and for Mitsuba (``drjit.set_thread_count``).
    variant : str or None, keyword-only
        Mitsuba variant (use the client's choice so all records agree).
    keep_image : bool, keyword-only
        Return the mean image for the store (``record["image"]``).
    keep_stats : bool, keyword-only
        Return mean and variance images for the bias test (``record["stats_image"]``).
    reference_info : dict or None, keyword-only
        Copied into the record (reference spp, seed, key).
    """
    import reference_tracer as rt

    t_job = time.perf_counter()
    scene = scene_at(job.scene, job.width, job.height)
    rseed = render_seed(job.seed, job.spp)
    extra = {}
    if job.renderer == "ours":
        res = rt.render(scene, spp=job.spp, strategy=job.strategy, seed=rseed, threads=threads)
        mean, var, seconds = res.mean, res.variance, float(res.seconds)
        extra = {"rays": int(res.rays), "nonfinite_samples": int(res.nonfinite_samples),
                 "build_seconds": float(res.build_seconds)}
    elif job.renderer == "mitsuba":
        from mitsuba_scenes import render_mitsuba

        if job.strategy != MITSUBA_STRATEGY:
            raise ValueError(f"Mitsuba jobs use strategy {MITSUBA_STRATEGY!r}, got {job.strategy!r}")
        out = render_mitsuba(scene, spp=job.spp, seed=rseed, variant=variant, threads=threads, batches=1)
        mean, var, seconds = out.mean, None, float(out.seconds)
        extra = {"rays": None, "nonfinite_samples": None, "compile_seconds": float(out.compile_seconds),
                 "load_seconds": float(out.load_seconds)}
    else:
        raise ValueError(f"renderer must be 'ours' or 'mitsuba', got {job.renderer!r}")
    if mean.shape != np.shape(ref_mean):
        raise ValueError(f"{job.label}: image {mean.shape} vs reference {np.shape(ref_mean)}")
    # one sample carries no estimate of its spread (ours would report 0)
    met = job_metrics(mean, var if job.spp > 1 else None, ref_mean, ref_variance, ref_spp)
    pps = job.width * job.height * job.spp / seconds if seconds > 0 else None
    eff = None
    if met["mse"] is not None and met["mse"] > 0 and seconds > 0:
        eff = M.efficiency(met["mse"], seconds)
    images = {}
    img_path, var_path = image_paths(job)
    if keep_image or keep_stats:
        images[img_path] = np.asarray(mean, dtype=np.float32)
    if keep_stats and var is not None:
        images[var_path] = np.asarray(var, dtype=np.float32)
    record = {k: getattr(job, k) for k in KEY_FIELDS}
    record.update(met)
    record.update({
        "seconds": seconds, "rays": extra.get("rays"), "paths_per_second": pps, "threads": int(threads),
        "image": img_path if keep_image else None,
        "stats_image": img_path if keep_stats else None,
        "stats_variance_image": var_path if (keep_stats and var is not None) else None,
        "efficiency": eff, "render_seed": rseed,
        "nonfinite_samples": extra.get("nonfinite_samples"),
        "compile_seconds": extra.get("compile_seconds"), "build_seconds": extra.get("build_seconds"),
        "load_seconds": extra.get("load_seconds"),
        "versions": run_versions(variant),
    })
    if reference_info:
        record.update({f"reference_{k}": v for k, v in reference_info.items()})
    record["wall_seconds"] = time.perf_counter() - t_job
    record["host"] = socket.gethostname()
    record["finished"] = _dt.datetime.now().astimezone().isoformat(timespec="seconds")
    return {"record": record, "images": images}


# ----------------------------------------------------------------------- references

def _prepare_references(groups, store: Path, *, variant, threads, cache, say) -> dict:
    """Ensure each (scene, width, height) has its reference; copy it into the store.

    Returns ``{(scene, w, h): (mean, variance, info)}``.
    """
    from .references import CLOSED_FORM, closed_form_reference_of, reference

    refs = {}
    by_scene, by_size = {}, {}
    for g in groups:
        for scene in g.scenes:
            k = (scene, g.width, g.height)
            if k in refs:
                if refs[k][2]["spp"] != g.reference_spp:
                    raise ValueError(f"{scene} {g.width}x{g.height} appears in two groups with different "
                                     f"reference spp ({refs[k][2]['spp']} and {g.reference_spp})")
                continue
            t0 = time.perf_counter()
            ref = closed_form_reference_of(scene, g.width, g.height)
            if ref is None:
                ref = reference(scene_at(scene, g.width, g.height), spp=g.reference_spp, variant=variant,
                                threads=threads, cache=cache, log=say)
            how = ("closed form" if ref.variant == CLOSED_FORM else
                   "cached" if ref.cached else f"rendered in {time.perf_counter() - t0:.1f} s")
            say(f"reference {scene} {g.width}x{g.height}: {ref.spp} spp, {ref.variant} ({how})")
            stem = f"references/{scene}_{g.width}x{g.height}_spp{ref.spp}"
            mpath, vpath = f"{stem}.exr", f"{stem}_var.exr"
            for rel, img in ((mpath, ref.mean), (vpath, ref.variance)):
                if not (store / rel).exists():
                    write_image(store, rel, img)
            info = {"spp": ref.spp, "seed": ref.seed, "key": ref.key, "variant": ref.variant}
            entry = {"spp": ref.spp, "seed": ref.seed, "path": mpath, "variance_path": vpath,
                     "width": g.width, "height": g.height, "variant": ref.variant, "key": ref.key,
                     "render_seconds": ref.seconds}
            by_size[f"{scene}@{g.width}x{g.height}"] = entry
            by_scene.setdefault(scene, entry)  # the first group naming a scene is its main sweep
            refs[k] = (ref.mean, ref.variance, info)
    meta = read_json(store / META, default={}) or {}
    old = meta.get("references") if isinstance(meta.get("references"), dict) else {}
    update_meta(store, references={**by_scene, **{k: v for k, v in old.items() if k not in by_scene}},
                references_by_size=by_size)
    return refs


# -------------------------------------------------------------------------- execution

@dataclass
class SweepResult:
    """What :func:`run_sweep` did.

    ``jobs`` in the plan, ``done`` rendered now, ``skipped`` already in the store,
    ``failed`` (job label, error text) pairs, ``seconds`` wall time, ``rows`` the
    summary rows, ``store`` the folder.
    """

    store: Path
    jobs: int = 0
    done: int = 0
    skipped: int = 0
    failed: list = field(default_factory=list)
    seconds: float = 0.0
    rows: list = field(default_factory=list)
    interrupted: bool = False


class _Progress:
    """A rich progress bar over estimated job cost: jobs done, current job, time left."""

    def __init__(self, total_cost: float, total_jobs: int, *, enabled: bool, console=None):
        self.enabled = enabled and total_jobs > 0
        self.jobs_total = total_jobs
        self.jobs_done = 0
        if not self.enabled:
            return
        from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn
        from rich.table import Column

        self.progress = Progress(TextColumn("[bold]{task.fields[jobs]}[/] jobs", table_column=Column(no_wrap=True)),
                                 BarColumn(bar_width=24), TimeElapsedColumn(table_column=Column(no_wrap=True)),
                                 TextColumn("left", table_column=Column(no_wrap=True)),
                                 TimeRemainingColumn(table_column=Column(no_wrap=True)),
                                 TextColumn("{task.description}", table_column=Column(
                                     ratio=1, no_wrap=True, overflow="ellipsis")),
                                 console=console, transient=False, speed_estimate_period=120)
        self.task = self.progress.add_task("", total=total_cost, jobs=f"0/{total_jobs}")
        self.progress.start()

    def current(self, label: str):
        if self.enabled:
            self.progress.update(self.task, description=label)

    def advance(self, cost: float):
        self.jobs_done += 1
        if self.enabled:
            self.progress.update(self.task, advance=cost, jobs=f"{self.jobs_done}/{self.jobs_total}")

    def log(self, text: str):
        if self.enabled:
            self.progress.console.print(text, highlight=False, markup=False)

    def stop(self):
        if self.enabled:
            self.progress.stop()


def _store_result(store: Path, result: dict) -> dict:
    for rel, img in result["images"].items():
        write_image(store, rel, img)
    append_record(store, result["record"])  # last: a record always has its images
    return result["record"]


def _run_local(todo, refs, store, *, threads, variant, keep, bar, say, failures):
    done = 0
    for job in todo:
        bar.current(job.label)
        mean, var, info = refs[(job.scene, job.width, job.height)]
        ki, ks = keep(job)
        try:
            res = execute_job(job, mean, var, info["spp"], threads=threads, variant=variant,
                              keep_image=ki, keep_stats=ks, reference_info=info)
        except KeyboardInterrupt:
            raise
        except Exception as exc:  # noqa: BLE001 - one failed job must not sink the sweep
            failures.append((job.label, f"{type(exc).__name__}: {exc}"))
            say(f"FAILED {job.label}: {type(exc).__name__}: {exc}")
            bar.advance(job.cost)
            continue
        _store_result(store, res)
        done += 1
        bar.advance(job.cost)
    return done


def _run_dask(todo, refs, store, *, address, variant, keep, bar, say, failures, poll=2.0):
    """One job per worker: each task is pinned to an idle worker (any thread count)."""
    try:
        from distributed import Client, wait
    except ImportError as exc:  # pragma: no cover - dask is a dependency
        raise ValueError("--scheduler needs dask.distributed (pip install distributed)") from exc

    client = address if not isinstance(address, str) else None
    own = client is None
    if own:
        try:
            client = Client(address, timeout=DASK_CONNECT_TIMEOUT)
        except (OSError, TimeoutError) as exc:
            raise ValueError(f"cannot reach the Dask scheduler at {address!r}: {exc}") from exc
    done = 0
    running = {}   # future -> (job, worker)
    pending = collections.deque(todo)
    scattered = {}
    try:
        def workers():
            info = client.scheduler_info(n_workers=-1) if _accepts_n_workers(client) else client.scheduler_info()
            return {addr: int(w.get("nthreads", 1) or 1) for addr, w in info.get("workers", {}).items()}

        pool = workers()
        t_wait = time.monotonic()
        while not pool:
            if time.monotonic() - t_wait > 60:
                raise ValueError(f"the Dask cluster at {address!r} has no workers")
            time.sleep(1.0)
            pool = workers()
        say(f"dask: {len(pool)} worker(s) at {client.scheduler.address}, one job per worker")
        for k, (mean, var, info) in refs.items():
            scattered[k] = (client.scatter(mean, broadcast=True), client.scatter(var, broadcast=True), info)
        busy = set()
        while pending or running:
            for addr in list(pool):
                if addr in busy or not pending:
                    continue
                job = pending.popleft()
                mean_f, var_f, info = scattered[(job.scene, job.width, job.height)]
                ki, ks = keep(job)
                fut = client.submit(execute_job, job, mean_f, var_f, info["spp"], threads=pool[addr],
                                    variant=variant, keep_image=ki, keep_stats=ks, reference_info=info,
                                    workers=[addr], allow_other_workers=False, pure=False,
                                    key=f"rtbench-{job.scene}-{job.renderer}-{job.strategy}-{job.spp}-"
                                        f"{job.seed}-{job.width}x{job.height}-{time.monotonic_ns()}")
                running[fut] = (job, addr)
                busy.add(addr)
                bar.current(job.label)
            if not running:
                time.sleep(poll)
                pool = workers()
                continue
            try:
                finished, _ = wait(list(running), timeout=poll, return_when="FIRST_COMPLETED")
            except TimeoutError:  # nothing finished within `poll`: look at the workers again
                finished = []
            for fut in finished:
                job, addr = running.pop(fut)
                busy.discard(addr)
                if fut.status == "finished":
                    _store_result(store, fut.result())
                    done += 1
                else:
                    try:
                        exc = fut.exception()
                    except Exception as e:  # noqa: BLE001
                        exc = e
                    failures.append((job.label, f"{type(exc).__name__}: {exc}"))
                    say(f"FAILED {job.label}: {type(exc).__name__}: {exc}")
                bar.advance(job.cost)
            pool = workers()
            # a worker that left: requeue its job (its task would wait for it forever)
            for fut, (job, addr) in list(running.items()):
                if addr not in pool:
                    fut.cancel()
                    running.pop(fut)
                    busy.discard(addr)
                    pending.appendleft(job)
                    say(f"dask: worker {addr} left; requeued {job.label}")
    finally:
        for fut in running:
            fut.cancel()
        if own:
            client.close()
    return done


def _accepts_n_workers(client) -> bool:
    import inspect

    try:
        return "n_workers" in inspect.signature(client.scheduler_info).parameters
    except (TypeError, ValueError):
        return False


def run_sweep(groups, *, out, threads: int | None = None, scheduler=None, variant: str | None = None,
              progress: bool = True, cache=None, alpha: float = DEFAULT_ALPHA,
              target_relative: float = TARGET_RELATIVE_RMSE, preset: str | None = None,
              console=None) -> SweepResult:
    """Run (or resume) a sweep into a results store and write its summary.

    Steps: references for every (scene, size) (cached; copied into the store), then
    every job not yet in ``results.jsonl`` (appended one by one), then
    ``summary.json`` from all records. Interrupt it at any point (Ctrl-C, kill) and run
    it again with the same arguments: finished jobs are skipped, nothing is lost.

    Parameters
    ----------
    groups : sequence of Group
    out : str or Path, keyword-only
        The results store folder.
    threads : int or None, keyword-only
        Threads per local job for both renderers (default: all cores). Ignored with
        ``scheduler`` (each worker's thread count is used).
    scheduler : str, distributed.Client or None, keyword-only
        Address of a Dask distributed scheduler (``tcp://host:8786``) or a Client.
    variant : str or None, keyword-only
        Mitsuba variant (default: the fastest that works).
    progress : bool, keyword-only
        Show a progress bar (rich) and one line per reference.
    cache : str or Path or None, keyword-only
        Reference cache root (default ``$RTBENCH_CACHE`` or ``~/.cache/rtbench``).
    alpha : float, keyword-only
        Level of the bias test in the summary.
    target_relative : float, keyword-only
        Target RMSE for time-to-target, relative to the reference's RMS radiance.
    preset : str or None, keyword-only
        Recorded in meta.json.
    console : rich.console.Console or None, keyword-only

    Returns
    -------
    SweepResult
    """
    t_start = time.perf_counter()
    groups = list(groups)
    if not groups:
        raise ValueError("the sweep has no groups")
    for g in groups:
        if not isinstance(g, Group):
            raise ValueError(f"groups must hold benchmarks.sweep.Group objects, got {type(g).__name__}")
    if threads is None:
        threads = default_threads()
    elif isinstance(threads, bool) or not isinstance(threads, (int, np.integer)) or threads < 1:
        raise ValueError(f"threads must be an integer >= 1, got {threads!r}")
    if not 0 < alpha < 1:
        raise ValueError(f"alpha must be in (0, 1), got {alpha}")
    if not target_relative > 0:
        raise ValueError(f"target_relative must be positive, got {target_relative}")
    store = store_path(out)

    if progress and console is None:
        from rich.console import Console

        console = Console(stderr=True)

    def say(text):
        if progress:
            console.print(text, highlight=False, markup=False)

    from .references import mitsuba_identity

    variant, mversion = mitsuba_identity(variant)
    versions = run_versions(variant)
    meta = read_json(store / META, default={}) or {}
    update_meta(store, date=meta.get("date") or _dt.datetime.now().astimezone().isoformat(timespec="seconds"),
                preset=preset if preset is not None else meta.get("preset", "custom"),
                threads=None if scheduler is not None else int(threads),
                scheduler=str(scheduler) if isinstance(scheduler, str) else (None if scheduler is None else "client"),
                machine=machine_info(), versions=versions, alpha=alpha, target_relative_rmse=target_relative,
                groups=[{"name": g.name, "scenes": list(g.scenes), "strategies": list(g.strategies),
                         "spps": list(g.spps), "seeds": g.seeds, "width": g.width, "height": g.height,
                         "mitsuba": g.mitsuba, "reference_spp": g.reference_spp} for g in groups])

    refs = _prepare_references(groups, store, variant=variant, threads=int(threads), cache=cache, say=say)

    plan, top = [], {}
    seen = set()
    for g in groups:
        for job in g.jobs():
            if job.key in seen:
                continue
            seen.add(job.key)
            plan.append(job)
            top[job.curve] = max(top.get(job.curve, 0), job.spp)
    done_keys = finished_keys(store)
    stale = [r for r in read_records(store) if (r["scene"], r["width"], r["height"]) in refs
             and r.get("reference_key") not in (None, refs[(r["scene"], r["width"], r["height"])][2]["key"])]
    if stale:
        say(f"warning: {len(stale)} stored job(s) were measured against another reference (other spp, seed, "
            f"Mitsuba or scene version); they are kept - use a new --out to start afresh")
    todo = [j for j in plan if j.key not in done_keys]
    result = SweepResult(store=store, jobs=len(plan), skipped=len(plan) - len(todo))
    if result.skipped:
        say(f"resuming: {result.skipped} of {len(plan)} jobs already in {store}")

    def keep(job):
        return job.seed == 0, job.spp == top[job.curve]

    bar = _Progress(sum(j.cost for j in todo), len(todo), enabled=progress, console=console)
    log = bar.log if bar.enabled else say
    try:
        if scheduler is None:
            result.done = _run_local(todo, refs, store, threads=int(threads), variant=variant, keep=keep,
                                     bar=bar, say=log, failures=result.failed)
        else:
            result.done = _run_dask(todo, refs, store, address=scheduler, variant=variant, keep=keep,
                                    bar=bar, say=log, failures=result.failed)
    except KeyboardInterrupt:
        result.interrupted = True
        raise
    finally:
        bar.stop()
        elapsed = time.perf_counter() - t_start
        meta = read_json(store / META, default={}) or {}
        runs = list(meta.get("runs") or []) + [{"started": _dt.datetime.now().astimezone().isoformat(
            timespec="seconds"), "seconds": elapsed, "jobs_done": result.done, "interrupted": result.interrupted}]
        update_meta(store, runs=runs, total_seconds=float(sum(r.get("seconds") or 0 for r in runs)))
    result.rows = summarize(store, alpha=alpha, target_relative=target_relative)
    result.seconds = time.perf_counter() - t_start
    meta = read_json(store / META, default={}) or {}
    runs = meta.get("runs") or []
    if runs:
        runs[-1]["seconds"] = result.seconds
    update_meta(store, runs=runs, total_seconds=float(sum(r.get("seconds") or 0 for r in runs)))
    return result


# ---------------------------------------------------------------------------- summary

def target_rmse(ref_mean, *, relative: float = TARGET_RELATIVE_RMSE) -> float:
    """Target RMSE of a scene: ``relative`` x the RMS of the reference's radiance.

    Examples
    --------
    >>> target_rmse(np.full((4, 4, 3), 2.0), relative=0.1)
    0.2
    """
    r = np.asarray(ref_mean, dtype=np.float64)
    return float(relative * math.sqrt(float(np.mean(r * r))))


def _num(v):
    if v is None or isinstance(v, bool):
        return math.nan
    try:
        return float(v)
    except (TypeError, ValueError):
        return math.nan


def _nanmean(vals):
    a = np.asarray([_num(v) for v in vals], dtype=np.float64)
    a = a[np.isfinite(a)]
    return float(a.mean()) if a.size else math.nan


def _bias_verdict(imgs, vars_, spp, ref_mean, ref_var, ref_spp, *, alpha):
    """Is the curve's expectation different from the reference's? The regression gate's test.

    The mean over K seeds is the mean of K * spp samples; its per-sample variance is the
    seeds' own per-sample variance where recorded (ours), else the between-seed variance
    times spp (Mitsuba's sweep renders carry no variance image). ``benchmarks.gate.compare``
    then tests tiles and the whole image with a false-alarm rate <= ``alpha``: a
    precision-weighted test, so a few very noisy pixels (light edges) cannot hide a bias
    elsewhere, as they can in the unweighted ``bias2`` estimate beside it.
    ``bias_z`` is the normal quantile of the gate's p-value (capped at 40).
    """
    from scipy import stats

    from . import gate

    k = len(imgs)
    if k < 2:
        # One render's own sample variance is no basis for a verdict where the samples
        # are heavy-tailed: uniform sampling at 50 spp (the 400x400 seed comparison) has
        # tiles whose rare paths did not occur, and was flagged at z = 18 while its slope
        # was -0.50. Independent seeds are required.
        return {"bias_significant": None, "bias_p": None, "bias_z": None}
    mean = np.mean(np.stack(imgs), axis=0)
    if spp > 1 and all(v is not None for v in vars_):
        # rt.render's per-sample variance is E[x^2] - E[x]^2 over each seed's spp samples
        per_sample = np.mean(np.stack(vars_), axis=0) * (spp / (spp - 1.0))
    else:
        per_sample = np.var(np.stack(imgs), axis=0, ddof=1) * spp
    n = k * spp
    if n < 2:
        return {"bias_significant": None, "bias_p": None, "bias_z": None}
    res = gate.compare(mean, per_sample, n, ref_mean, ref_var, max(int(ref_spp), 2), alpha=alpha, var_ddof=1)
    # Tile and image levels only (Bonferroni over the two): a biased *estimator* shows in
    # pooled statistics, while single-pixel tests are unreliable where a pixel's samples
    # are dominated by rare events (uniform sampling of a small light: a few seeds carry
    # all of its variance even at thousands of samples).
    p = float(min(1.0, 2.0 * min(res.level_p["tile"], res.level_p["image"])))
    z = float(min(stats.norm.isf(p / 2.0), 40.0)) if p > 0 else 40.0
    levels = [lv for lv in ("tile", "image") if 2.0 * res.level_p[lv] < alpha]
    return {"bias_significant": p < alpha, "bias_p": p, "bias_z": z, "bias_levels": levels}


def _curve_stats(recs, ref, store, *, alpha, target):
    """Summary figures of one (scene, renderer, strategy, width, height) curve."""
    from .store import read_image

    by_spp = collections.defaultdict(list)
    for r in recs:
        by_spp[int(r["spp"])].append(r)
    spps = sorted(by_spp)
    mse_c = np.array([_nanmean(r.get("mse_corrected") for r in by_spp[s]) for s in spps])
    mse_p = np.array([_nanmean(r.get("mse") for r in by_spp[s]) for s in spps])
    secs = np.array([_nanmean(r.get("seconds") for r in by_spp[s]) for s in spps])
    row = {"spps": spps, "seeds": max(len(by_spp[s]) for s in spps)}

    # convergence: one point per spp, RMSE from the seed-averaged reference-noise-corrected MSE
    ok = np.isfinite(mse_c) & (mse_c > 0)
    row.update(slope=None, slope_ci=None, slope_stderr=None, slope_points=int(ok.sum()))
    if ok.sum() >= 2 and len(set(np.asarray(spps)[ok])) >= 2:
        fit = M.convergence_slope(np.asarray(spps)[ok], np.sqrt(mse_c[ok]))
        row.update(slope=fit.slope, slope_stderr=fit.stderr,
                   slope_ci=[fit.ci_low, fit.ci_high] if math.isfinite(fit.ci_low) else None)
    okp = np.isfinite(mse_p) & (mse_p > 0)
    row["slope_uncorrected"] = None
    if okp.sum() >= 2:
        row["slope_uncorrected"] = M.convergence_slope(np.asarray(spps)[okp], np.sqrt(mse_p[okp])).slope

    # bias and variance over seeds at the highest spp that kept its images
    row.update(bias2=None, bias2_stderr=None, bias_z=None, bias_p=None, bias_significant=None, bias_levels=None,
               bias_spp=None, bias_seeds=None, relative_bias=None, variance=None, bias_method=None)
    top = spps[-1]
    stats = [r for r in by_spp[top] if r.get("stats_image")]
    if ref is not None and stats:
        ref_mean, ref_var, ref_spp = ref
        imgs, vars_ = [], []
        for r in sorted(stats, key=lambda r: r["seed"]):
            try:
                imgs.append(read_image(store, r["stats_image"]))
                vars_.append(read_image(store, r["stats_variance_image"]) if r.get("stats_variance_image") else None)
            except Exception:  # noqa: BLE001 - a missing/corrupt image: no bias figure for this curve
                imgs = []
                break
        bv, method = None, None
        if len(imgs) >= 2:
            bv = M.bias_variance(np.stack(imgs), ref_mean, ref_var, ref_spp, spp=top, alpha=alpha)
            method = "seeds"
        elif len(imgs) == 1 and vars_[0] is not None and top > 1:
            # one seed: the renderer's own per-sample variance, E[x^2] - E[x]^2 (de-biased by n/(n-1))
            bv = M.bias_variance(np.stack(imgs), ref_mean, ref_var, ref_spp, var_k=np.stack(vars_), spp=top,
                                 alpha=alpha, variance_source="samples", var_ddof=1)
            method = "samples"
        if bv is not None:
            row.update(bias2=bv.bias2, bias2_stderr=bv.bias2_se, bias_spp=top, bias_seeds=bv.k,
                       relative_bias=bv.relative_bias, variance=bv.sample_variance, bias_method=method)
            row.update(_bias_verdict(imgs, vars_, top, ref_mean, ref_var, ref_spp, alpha=alpha))
    if row["variance"] is None:
        row["variance"] = _nanmean(r.get("variance") for r in recs)

    # cost: efficiency at the top spp, throughput, time to the target RMSE
    row["efficiency"] = None
    if math.isfinite(mse_c[-1]) and mse_c[-1] > 0 and secs[-1] > 0:
        row["efficiency"] = M.efficiency(mse_c[-1], secs[-1])
    row["samples_per_second"] = _nanmean(r.get("paths_per_second") for r in by_spp[top])
    row["seconds_at_top"] = secs[-1]
    row["target_rmse"] = target
    row["time_to_target"] = None
    if target is not None and ok.any():
        row["time_to_target"] = M.time_to_error(secs[ok], np.sqrt(mse_c[ok]), target)
    row["rmse_at_top"] = math.sqrt(mse_p[-1]) if mse_p[-1] >= 0 else None
    return row


def summarize(store, *, alpha: float = DEFAULT_ALPHA, target_relative: float = TARGET_RELATIVE_RMSE) -> list:
    """Per (scene, renderer, strategy, width, height): the figures of ``summary.json``.

    From the store's records and images:

    * ``slope``, ``slope_ci`` (95%), ``slope_stderr``: least-squares fit of log RMSE over
      log spp, one point per spp, RMSE = sqrt of the seed-averaged reference-noise-
      corrected MSE (``slope_uncorrected`` uses the plain MSE);
    * ``bias2``, ``bias2_stderr``, ``bias_z``, ``bias_p``, ``bias_significant`` (level
      ``alpha``, one-sided), ``relative_bias``: ``metrics.bias_variance`` over the seeds at
      the highest spp (``bias_spp``); with one seed, the renderer's own per-sample
      variance is used instead (``bias_method``);
    * ``variance``: per-sample variance (between-seed variance of the image x spp);
    * ``efficiency``: 1 / (corrected MSE x seconds) at the highest spp;
    * ``time_to_target``: seconds to reach ``target_rmse`` (= ``target_relative`` x the
      reference's RMS radiance), log-log interpolated, null if not reached;
    * ``samples_per_second`` (pixel samples per second at the highest spp) and the
      ``*_vs_mitsuba`` ratios against Mitsuba's ``path`` curve of the same scene and size.

    Writes ``summary.json`` and returns its rows.
    """
    from .store import read_image

    store = Path(store)
    records = read_records(store)
    meta = read_json(store / META, default={}) or {}
    refs_meta = meta.get("references_by_size") if isinstance(meta.get("references_by_size"), dict) else {}
    curves = collections.defaultdict(list)
    for r in records:
        curves[(r["scene"], r["renderer"], r["strategy"], r["width"], r["height"])].append(r)
    ref_cache, targets, rows = {}, {}, []
    for (scene, renderer, strategy, w, h), recs in curves.items():
        k = (scene, w, h)
        if k not in ref_cache:
            info = refs_meta.get(f"{scene}@{w}x{h}")
            ref_cache[k] = None
            if info:
                try:
                    ref_cache[k] = (read_image(store, info["path"]).astype(np.float64),
                                    read_image(store, info["variance_path"]).astype(np.float64), int(info["spp"]))
                except Exception:  # noqa: BLE001 - missing reference: figures that need it stay null
                    ref_cache[k] = None
        ref = ref_cache[k]
        target = target_rmse(ref[0], relative=target_relative) if ref is not None else None
        if target is not None:
            targets.setdefault(scene, target)
        row = {"scene": scene, "renderer": renderer, "strategy": strategy, "width": w, "height": h}
        row.update(_curve_stats(recs, ref, store, alpha=alpha, target=target))
        rows.append(row)
    # ratios against Mitsuba's curve of the same scene and size
    mits = {(r["scene"], r["width"], r["height"]): r for r in rows if r["renderer"] == "mitsuba"}
    for r in rows:
        m = mits.get((r["scene"], r["width"], r["height"]))
        r["efficiency_vs_mitsuba"] = _ratio(r.get("efficiency"), m.get("efficiency") if m else None)
        r["samples_per_second_vs_mitsuba"] = _ratio(r.get("samples_per_second"),
                                                    m.get("samples_per_second") if m else None)
    order = {"uniform": 0, "cosine": 1, "light": 2, "mixture": 3, "mis": 4}
    rows.sort(key=lambda r: (r["scene"], r["width"], r["height"], r["renderer"] != "ours",
                             order.get(r["strategy"], 9)))
    write_json(store / SUMMARY, {"rows": rows, "alpha": alpha, "target_relative_rmse": target_relative,
                                 "notes": {
                                     "slope": "fit of log sqrt(mean over seeds of mse_corrected) on log spp, "
                                              "one point per spp; slope_ci is its 95% t interval",
                                     "bias": f"bias2: metrics.bias_variance at bias_spp over bias_seeds "
                                             f"seeds; bias_significant, bias_p: tile and image levels of "
                                             f"benchmarks.gate.compare on the mean over seeds (Bonferroni), "
                                             f"level {alpha}, 2+ seeds needed; bias_z: normal quantile of bias_p. "
                                             f"Estimators whose value rests on rare paths (uniform sampling "
                                             f"of small lights on glossy plates) are flagged until they "
                                             f"converge: their error at that spp is real",
                                     "efficiency": "1 / (mean mse_corrected x mean seconds) at the highest spp",
                                     "target_rmse": f"{target_relative} x RMS of the reference radiance"}})
    if targets:
        update_meta(store, target_rmse=targets)
    return rows


def _ratio(a, b):
    a, b = _num(a), _num(b)
    if not (math.isfinite(a) and math.isfinite(b)) or b == 0:
        return None
    return a / b
