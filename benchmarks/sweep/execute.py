"""One job, anywhere: render it, measure it against its reference, build its record.

Nothing here touches a file, so a job runs the same locally and on a Dask worker; the
caller stores what :func:`execute_job` returns. Also the versions and machine facts
recorded with every job and in ``meta.json``.
"""
from __future__ import annotations

import dataclasses
import datetime as _dt
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

from .. import metrics as M
from .. import external as externals
from ..constants import MITSUBA_DIRECT, MITSUBA_STRATEGY
from ..scenes import scene_at, scene_info
from ..store import KEY_FIELDS
from .coerce import finite
from .jobs import Job, image_paths, render_seed

__all__ = ["TIMING_FIELDS", "mitsuba_scene", "job_metrics", "execute_job", "reference_info", "run_versions", "machine_info"]

#: record fields that depend on timing, the machine or the checkout (ignore them to compare two runs):
#: ``build_git`` (git describe) changes with any commit, the build id only with the tracer.
TIMING_FIELDS = ("seconds", "paths_per_second", "efficiency", "compile_seconds", "build_seconds",
                 "load_seconds", "wall_seconds", "finished", "host", "threads", "worker", "build_git")


def job_metrics(mean, variance, ref_mean, ref_variance, ref_spp) -> dict:
    """Error figures of one render against the reference (:mod:`benchmarks.metrics`).

    ``mse_corrected`` and ``relmse_corrected`` remove the reference's own noise,
    ``ref_variance / ref_spp`` (relMSE's weights for the latter);
    ``flip`` is :func:`benchmarks.metrics.flip` (None where the ``flip-evaluator`` package
    is missing); ``variance`` is the mean per-pixel per-sample variance of the render,
    present only when the renderer gave one (ours at 2+ spp; a record never holds a null
    variance). Non-finite results become None.

    Examples
    --------
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
    if variance is not None:
        v = np.asarray(variance, dtype=np.float64)
        if np.all(np.isfinite(v)):
            out["variance"] = float(v.mean())
    return {k: finite(v) for k, v in out.items()}


def reference_info(reference) -> dict:
    """What a record says of its reference (as ``reference_<field>``): spp, seed, cache key, variant.

    ``reference`` is a :class:`benchmarks.references.Reference` (a closed-form one included).
    """
    return {"spp": reference.spp, "seed": reference.seed, "key": reference.key, "variant": reference.variant}


def mitsuba_scene(scene, strategy: str):
    """``scene`` as Mitsuba renders curve ``strategy``: as it is (``path``), or for a scene with
    the ``direct`` integrator with the sample counts of :data:`MITSUBA_DIRECT`'s strategy."""
    direct = getattr(scene, "direct", None)
    if strategy == MITSUBA_STRATEGY and direct is None:
        return scene
    if strategy in MITSUBA_DIRECT and direct is not None:
        return dataclasses.replace(scene, direct=rt.Direct(*direct.counts(MITSUBA_DIRECT[strategy])))
    allowed = tuple(MITSUBA_DIRECT) if direct is not None else (MITSUBA_STRATEGY,)
    raise ValueError(f"Mitsuba renders this scene as curve(s) {', '.join(allowed)}, not {strategy!r}")


def _render(job: Job, scene, rseed: int, *, threads: int, variant) -> tuple:
    """``(mean, variance or None, seconds, extra record fields)`` of the job's render."""
    if job.renderer == "ours":
        res = rt.render(scene, spp=job.spp, strategy=job.strategy,
                        seed=rseed, threads=threads)
        extra = {"rays": int(res.rays), "nonfinite_samples": int(res.nonfinite_samples),
                 "build_seconds": float(res.build_seconds)}
        return res.mean, res.variance, float(res.seconds), extra
    if job.renderer == "mitsuba":
        scene = mitsuba_scene(scene, job.strategy)
        out = mitsuba_scenes.render_mitsuba(scene, spp=job.spp, seed=rseed,
                                            variant=variant, threads=threads, batches=1)
        extra = {"rays": None, "nonfinite_samples": None, "compile_seconds": float(out.compile_seconds),
                 "load_seconds": float(out.load_seconds)}
        # one batch at the full spp: no per-pixel variance (summary.json has the between-seed one)
        return out.mean, None, float(out.seconds), extra

    ext = externals.external(job.renderer)
    if ext is not None:
        mean, seconds = externals.render_external(ext, scene, spp=job.spp, seed=rseed & 0x7FFFFFFF)
        return mean, None, seconds, {"rays": None, "nonfinite_samples": int((~np.isfinite(mean)).sum())}
    raise ValueError(f"renderer must be 'ours', 'mitsuba' or a registered external renderer, got {job.renderer!r}")


def _register_here(scene_file, external) -> None:
    """Register the job's scene file and external renderer in this process if missing."""
    if scene_file is not None and registered_scene_file(scene_file.name) is None:
        restore_registry([scene_file])
    if external is not None and externals.external(external.name) is None:
        externals.restore_externals([external])


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
    """Render one job, measure it against the reference and build its record.

    Runs anywhere (locally or on a Dask worker): it touches no file. Returns
    ``{"record": dict, "images": {relpath: array}}``; the caller writes the images
    and then appends the record.

    Parameters
    ----------
    job : Job
    reference : benchmarks.references.Reference
        The reference at the job's size: mean, per-sample variance and spp; its spp,
        seed, key and variant are copied into the record (``reference_*``).
    threads : int, keyword-only
        Threads for our tracer and for Mitsuba (``drjit.set_thread_count``).
    variant : str or None, keyword-only
        Mitsuba variant (use the client's choice so all records agree).
    keep_image : bool, keyword-only
        Return the mean image for the store (``record["image"]``).
    keep_stats : bool, keyword-only
        Return mean and variance images for the bias test (``record["stats_image"]``).
    scene_file, external : keyword-only
        The job's :class:`mitsuba_scenes.scene_files.SceneFile` and
        :class:`benchmarks.external.ExternalRenderer` entries, registered here first when
        this process does not know them (a Dask worker, including one that joined after
        the run started).
    """
    _register_here(scene_file, external)
    t_job = time.perf_counter()
    builds = _check_build(job)
    rseed = render_seed(job.seed, job.spp)
    scene = scene_at(job.scene, job.width, job.height)
    mean, var, seconds, extra = _render(job, scene, rseed, threads=threads, variant=variant)
    if mean.shape != np.shape(reference.mean):
        raise ValueError(f"{job.label}: image {mean.shape} vs reference {np.shape(reference.mean)}")
    # one sample carries no estimate of its spread (ours would report 0)
    met = job_metrics(mean, var if job.spp > 1 else None, reference.mean, reference.variance, reference.spp)
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
        **scene_info(job.scene, scene), **builds,
    })
    record.update({f"reference_{k}": v for k, v in reference_info(reference).items()})
    record["wall_seconds"] = time.perf_counter() - t_job
    record["host"] = socket.gethostname()
    record["finished"] = _dt.datetime.now().astimezone().isoformat(timespec="seconds")
    return {"record": record, "images": images}


def run_versions(variant: str | None = None) -> dict:
    """Versions recorded with every job: rtbench, our tracer, Mitsuba, Dr.Jit, variant, Python, NumPy."""
    out = {"rtbench": _rtbench_version(), "reference_tracer": rt.__version__,
           "python": platform.python_version(), "numpy": np.__version__}
    try:
        if variant is not None:
            select_variant(variant)
        out.update({k: v for k, v in versions().items() if k != "libllvm"})
    except Exception:  # noqa: BLE001 - Mitsuba missing: ours-only records still carry versions
        pass
    return out


def _rtbench_version() -> str:
    try:
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
