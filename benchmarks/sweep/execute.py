"""One job, anywhere: render it, measure it against its reference, build its record (nothing here
touches a file, so a job runs the same locally and on a Dask worker); the versions and machine
facts recorded with every job and in ``meta.json``."""
from __future__ import annotations

import dataclasses
import math
import platform
import socket
import time
from importlib.metadata import version

import numpy as np

import mitsuba_scenes
import reference_tracer as rt
from mitsuba_scenes.scene_files import restore_registry
from mitsuba_scenes.scene_files import scene_file as registered_scene_file
from mitsuba_scenes.variants import select_variant, versions
from reference_tracer.build import git_describe
from reference_tracer.cpus import default_threads

from .. import external as externals
from .. import metrics as M
from ..constants import MITSUBA_DIRECT, MITSUBA_STRATEGY
from ..numbers import finite
from ..scenes import scene_at, scene_info
from ..store import KEY_FIELDS, timestamp
from .jobs import Job, image_paths, render_seed

#: record fields that depend on timing, the machine or the checkout (ignore them to compare two runs).
TIMING_FIELDS = ("seconds", "paths_per_second", "efficiency", "compile_seconds", "build_seconds",
                 "load_seconds", "wall_seconds", "finished", "host", "threads", "worker", "build_git")


def job_metrics(mean, variance, ref_mean, ref_variance, ref_spp) -> dict:
    """Error figures of one render against the reference (:mod:`benchmarks.metrics`).

    ``*_corrected`` remove the reference's own noise; ``flip`` is None without the
    ``flip-evaluator`` package; ``variance`` (mean per-sample variance) only when the renderer
    gave one. Non-finite results become None.

    >>> ref = np.ones((8, 8, 3)); img = ref + 0.1
    >>> m = job_metrics(img, None, ref, np.zeros_like(ref), 64)
    >>> round(m["mse"], 6), round(m["rmse"], 6), "variance" in m
    (0.01, 0.1, False)
    """
    mean = np.asarray(mean, dtype=np.float64)
    ref = np.asarray(ref_mean, dtype=np.float64)
    mse = M.mse(mean, ref)
    out = {"mse": mse, "rmse": math.sqrt(mse) if mse >= 0 else math.nan,
           "relmse": M.relmse(mean, ref), "ssim": M.ssim(mean, ref),
           "flip": M.flip(mean, ref) if M.flip_available() else None,
           "mse_corrected": M.mse_corrected(mean, ref, ref_variance, ref_spp),
           "relmse_corrected": M.relmse_corrected(mean, ref, ref_variance, ref_spp)}
    if variance is not None and np.all(np.isfinite(variance)):
        out["variance"] = float(np.mean(variance, dtype=np.float64))
    return {k: finite(v) for k, v in out.items()}


def _render(job: Job, scene, rseed: int, *, threads: int, variant) -> tuple:
    """``(mean, variance or None, seconds, extra record fields)`` of the job's render."""
    if job.renderer == "ours":
        res = rt.render(scene, spp=job.spp, strategy=job.strategy, seed=rseed, threads=threads)
        extra = {"rays": int(res.rays), "nonfinite_samples": int(res.nonfinite_samples),
                 "build_seconds": float(res.build_seconds)}
        return res.mean, res.variance, float(res.seconds), extra
    if job.renderer == "mitsuba":
        direct = getattr(scene, "direct", None)
        allowed = tuple(MITSUBA_DIRECT) if direct is not None else (MITSUBA_STRATEGY,)
        if job.strategy not in allowed:
            raise ValueError(f"Mitsuba renders this scene as curve(s) {', '.join(allowed)}, not {job.strategy!r}")
        if direct is not None:  # Mitsuba's `direct` with the sample counts of the curve's strategy
            scene = dataclasses.replace(scene, direct=rt.Direct(*direct.counts(MITSUBA_DIRECT[job.strategy])))
        out = mitsuba_scenes.render_mitsuba(scene, spp=job.spp, seed=rseed, variant=variant, threads=threads,
                                            batches=1)
        # one batch at the full spp: no per-pixel variance (summary.json has the between-seed one)
        return out.mean, None, float(out.seconds), {"rays": None, "nonfinite_samples": None,
                                                    "compile_seconds": float(out.compile_seconds),
                                                    "load_seconds": float(out.load_seconds)}
    ext = externals.external(job.renderer)
    if ext is None:
        raise ValueError(f"renderer must be 'ours', 'mitsuba' or a registered external renderer, got {job.renderer!r}")
    mean, seconds = externals.render_external(ext, scene, spp=job.spp, seed=rseed & 0x7FFFFFFF)
    return mean, None, seconds, {"rays": None, "nonfinite_samples": int((~np.isfinite(mean)).sum())}


def _check_build(job: Job) -> dict:
    """The record's build fields; ``RuntimeError`` when this process's tracer is another build
    than the job was planned with (a Dask worker running other code than the client)."""
    if job.renderer != "ours":
        return {"build": job.build, "build_git": None}
    here = rt.build_id()
    if job.build is not None and job.build != here:
        raise RuntimeError(f"{job.label}: planned for tracer build {job.build}, but this process runs build {here}")
    return {"build": here, "build_git": git_describe()}


def execute_job(job: Job, reference, *, threads: int, variant=None, keep_image: bool = False,
                keep_stats: bool = False, scene_file=None, external=None) -> dict:
    """Render one job, measure it against ``reference`` and build its record.

    Returns ``{"record": dict, "images": {relpath: array}}``; the caller writes the images,
    then appends the record. ``keep_image``: keep the mean image (``record["image"]``);
    ``keep_stats``: mean and variance for the bias test (``record["stats_image"]``);
    ``scene_file``, ``external``: the job's scene file and external renderer, registered
    first where this process lacks them (a Dask worker).
    """
    if scene_file is not None and registered_scene_file(scene_file.name) is None:
        restore_registry([scene_file])
    if external is not None and externals.external(external.name) is None:
        externals.restore_externals([external])
    t_job = time.perf_counter()
    builds = _check_build(job)
    rseed = render_seed(job.seed, job.spp)
    scene = scene_at(job.scene, job.width, job.height)
    mean, var, seconds, extra = _render(job, scene, rseed, threads=threads, variant=variant)
    if mean.shape != np.shape(reference.mean):
        raise ValueError(f"{job.label}: image {mean.shape} vs reference {np.shape(reference.mean)}")
    # one sample carries no estimate of its spread (ours would report 0)
    met = job_metrics(mean, var if job.spp > 1 else None, reference.mean, reference.variance, reference.spp)
    img_path, var_path = image_paths(job)
    images = {img_path: np.asarray(mean, dtype=np.float32)} if keep_image or keep_stats else {}
    if keep_stats and var is not None:
        images[var_path] = np.asarray(var, dtype=np.float32)
    record = {k: getattr(job, k) for k in KEY_FIELDS}
    record.update(met)
    record.update({
        "seconds": seconds, "rays": extra.get("rays"),
        "paths_per_second": job.width * job.height * job.spp / seconds if seconds > 0 else None,
        "threads": int(threads), "image": img_path if keep_image else None,
        "stats_image": img_path if keep_stats else None,
        "stats_variance_image": var_path if (keep_stats and var is not None) else None,
        "efficiency": M.efficiency(met["mse"], seconds) if (met["mse"] or 0) > 0 and seconds > 0 else None,
        "render_seed": rseed, "nonfinite_samples": extra.get("nonfinite_samples"),
        "compile_seconds": extra.get("compile_seconds"), "build_seconds": extra.get("build_seconds"),
        "load_seconds": extra.get("load_seconds"), "versions": run_versions(variant),
        **scene_info(job.scene, scene), **builds,
    })
    record.update({"reference_spp": reference.spp, "reference_seed": reference.seed, "reference_key": reference.key,
                   "reference_variant": reference.variant})
    record["wall_seconds"] = time.perf_counter() - t_job
    record["host"] = socket.gethostname()
    record["finished"] = timestamp()
    return {"record": record, "images": images}


def run_versions(variant: str | None = None) -> dict:
    """Versions recorded with every job: rtbench, our tracer, Mitsuba, Dr.Jit, variant, Python, NumPy."""
    try:
        rtbench = version("rtbench")
    except Exception:  # noqa: BLE001 - not installed as a package
        rtbench = "unknown"
    out = {"rtbench": rtbench, "reference_tracer": rt.__version__, "python": platform.python_version(),
           "numpy": np.__version__}
    try:
        if variant is not None:
            select_variant(variant)
        out.update({k: v for k, v in versions().items() if k != "libllvm"})
    except Exception:  # noqa: BLE001 - Mitsuba missing: ours-only records still carry versions
        pass
    return out


def machine_info() -> dict:
    """Cores, CPU model and platform for meta.json."""
    cpu = platform.processor() or ""
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next((ln.split(":", 1)[1].strip() for ln in f if ln.startswith("model name")), cpu)
    except OSError:
        pass
    return {"cores": default_threads(), "cpu": cpu or "unknown", "platform": platform.platform(),
            "host": socket.gethostname()}
