"""High-spp Mitsuba references (``path`` in independent batches, so with a per-sample variance
that error figures subtract), cached (docs/rtbench.md, The reference cache), and the closed forms
that replace them where Mitsuba is wrong."""
from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import os
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import mitsuba_scenes
import reference_tracer as rt
from mitsuba_scenes.suite import closed_form_reference
from mitsuba_scenes.variants import select_variant, versions
from reference_tracer.estimate import ImageEstimate
from reference_tracer.imageio import atomic_write, write_exr
from reference_tracer.validation import SEED_MAX, positive_int

from .constants import CLOSED_FORM, CLOSED_FORM_SPP
from .store import file_sha256

#: environment variable naming the cache folder.
CACHE_ENV = "RTBENCH_CACHE"
#: reference seed: far from the sweep's seeds (Mitsuba batch seeds are hashed from it anyway).
DEFAULT_REFERENCE_SEED = 1_000_003
#: batches of a reference render (the per-sample variance has batches - 1 degrees of freedom).
DEFAULT_REFERENCE_BATCHES = 16
#: bump when the on-disk format or the meaning of a cached entry changes.
FORMAT_VERSION = 1
#: suite scene -> what its closed-form reference is and why it replaces Mitsuba there.
CLOSED_FORM_REASONS = {
    "furnace": "closed form Le (1 - rho^n) / (1 - rho): Mitsuba 3.9.1's sphere-emitter sampling from a "
               "point on the sphere is biased here",
}


@dataclass(kw_only=True)
class Reference(ImageEstimate):
    """A reference image: an :class:`reference_tracer.ImageEstimate` (``source`` ``"mitsuba"`` or
    :data:`CLOSED_FORM`) with its cache entry (``key``, the EXR ``path`` and ``variance_path``),
    whether this call found it ``cached``, and a one-line ``description``."""

    seed: int
    batches: int
    variant: str
    mitsuba_version: str
    key: str
    path: Path | None
    variance_path: Path | None
    cached: bool
    scene_hash: str
    source: str = "mitsuba"
    description: str = ""

    def __post_init__(self):
        if not self.description and self.source == "mitsuba":
            self.description = (f"Mitsuba {self.mitsuba_version} {self.variant} path, {self.spp} spp "
                                f"(cache {self.key[:12]})")


def cache_dir(cache=None) -> Path:
    """``references/`` under ``cache``, ``$RTBENCH_CACHE`` or ``~/.cache/rtbench``; created if missing.

    >>> cache_dir("/tmp/rtbench-cache").as_posix()
    '/tmp/rtbench-cache/references'
    """
    root = cache if cache is not None else (os.environ.get(CACHE_ENV) or Path.home() / ".cache" / "rtbench")
    path = Path(root).expanduser() / "references"
    if path.exists() and not path.is_dir():
        raise ValueError(f"reference cache {path} exists and is not a folder")
    path.mkdir(parents=True, exist_ok=True)
    return path


def reference_key(scene_hash: str, *, mitsuba_version: str, variant: str, spp: int, seed: int,
                  batches: int = DEFAULT_REFERENCE_BATCHES) -> str:
    """Cache key of a reference: SHA-256 over its identity."""
    ident = {"format": FORMAT_VERSION, "scene": scene_hash, "mitsuba": mitsuba_version,
             "variant": variant, "spp": int(spp), "seed": int(seed), "batches": int(batches)}
    return hashlib.sha256(json.dumps(ident, sort_keys=True).encode()).hexdigest()


def mitsuba_identity(variant: str | None = None) -> tuple:
    """``(variant, mitsuba_version)`` after selecting the variant (see ``mitsuba_scenes.variants``)."""
    chosen = select_variant(variant)
    return chosen, versions()["mitsuba"]


@contextlib.contextmanager
def cache_lock(path: Path):
    """Hold an ``flock`` on ``path``: only a process about to write an entry takes it. ``OSError``
    naming the cache when it cannot be created (a read-only cache without this entry)."""
    try:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
    except OSError as exc:
        raise type(exc)(exc.errno, f"{exc.strerror}; cannot write to the cache (it has no valid entry for "
                                   f"this render; give a writable one with --cache DIR or ${CACHE_ENV})",
                        str(path)) from exc
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)  # releases the lock


def load_or_render(load, render, *, lock: Path, sidecar: Path, force: bool = False, log=None, what: str = ""):
    """A cache entry: ``load() -> (value or None, why)``'s value, else, under the lock (another process may
    have rendered it meanwhile; a read-only cache serves valid entries without it) and with the ``sidecar``
    removed first (a crash leaves no false hit), ``render()``'s; ``log`` is told when ``what`` was unusable."""
    if not force:
        value, _ = load()
        if value is not None:
            return value
    with cache_lock(lock):
        if not force:
            value, why = load()
            if value is not None:
                return value
            if why != "not cached" and log is not None:
                log(f"{what} is unusable ({why}); re-rendering")
        with contextlib.suppress(FileNotFoundError):
            sidecar.unlink()
        return render()


def _paths(folder: Path, key: str):
    return folder / f"{key}.mean.exr", folder / f"{key}.var.exr", folder / f"{key}.json"


def _key(scene_hash: str, *, spp: int, seed: int, variant, batches: int) -> tuple:
    """``(variant chosen, Mitsuba's version, cache key)`` of a reference."""
    chosen, mversion = mitsuba_identity(variant)
    key = reference_key(scene_hash, mitsuba_version=mversion, variant=chosen, spp=spp, seed=seed,
                        batches=min(batches, spp))
    return chosen, mversion, key


def is_cached(scene, *, spp: int, seed: int = DEFAULT_REFERENCE_SEED, variant: str | None = None,
              batches: int = DEFAULT_REFERENCE_BATCHES, cache=None) -> bool:
    """Whether :func:`reference` would find this reference in the cache (its sidecar exists;
    the files are checked when it is read). For planning a run's progress, nothing more."""
    key = _key(scene.content_hash(), spp=spp, seed=seed, variant=variant, batches=batches)[2]
    return _paths(cache_dir(cache), key)[2].exists()


def _reference(meta: dict, mean, var, folder: Path, *, cached: bool) -> Reference:
    """The :class:`Reference` of a cache entry's sidecar ``meta`` and images."""
    mean_path, var_path, _ = _paths(folder, meta["key"])
    return Reference(mean=mean, variance=var, spp=int(meta["spp"]), seed=int(meta["seed"]),
                     batches=int(meta["batches"]), variant=str(meta["variant"]),
                     mitsuba_version=str(meta["mitsuba_version"]), key=meta["key"], path=mean_path,
                     variance_path=var_path, seconds=float(meta.get("seconds", 0.0)), cached=cached,
                     scene_hash=str(meta["scene_hash"]))


def load_reference(key: str, *, shape=None, cache=None):
    """``(Reference, None)`` from a valid cache entry (of ``shape`` (H, W) when given), or
    ``(None, reason)`` when it is missing or corrupt."""
    folder = cache_dir(cache)
    mean_path, var_path, meta_path = _paths(folder, key)
    if not meta_path.exists():
        return None, "not cached"
    try:
        meta = json.loads(meta_path.read_text())
    except (OSError, ValueError) as exc:
        return None, f"sidecar unreadable ({exc.__class__.__name__})"
    if not isinstance(meta, dict) or meta.get("key") != key or meta.get("format") != FORMAT_VERSION:
        return None, "sidecar does not describe this key"
    for p, field in ((mean_path, "mean_sha256"), (var_path, "variance_sha256")):
        if not p.exists():
            return None, f"{p.name} missing"
        if file_sha256(p) != meta.get(field):
            return None, f"{p.name} checksum mismatch (partial or corrupt file)"
    try:
        mean, var = rt.read_exr(mean_path), rt.read_exr(var_path)
    except Exception as exc:  # noqa: BLE001 - any decoding failure means re-render
        return None, f"EXR unreadable ({exc})"
    want = tuple(meta.get("shape") or ())
    if mean.shape != want or var.shape != want or (shape is not None and tuple(shape) != want[:2]):
        return None, f"shape {mean.shape} does not match the sidecar/scene"
    if not (np.all(np.isfinite(mean)) and np.all(np.isfinite(var)) and np.all(var >= 0)):
        return None, "non-finite or negative values"
    return _reference(meta, mean, var, folder, cached=True), None


def reference(scene, *, spp: int = 4096, seed: int = DEFAULT_REFERENCE_SEED, variant: str | None = None,
              threads: int | None = None, batches: int = DEFAULT_REFERENCE_BATCHES, cache=None,
              force: bool = False, log=None) -> Reference:
    """The Mitsuba reference of ``scene`` (its camera size included) at ``spp`` samples, from the cache or rendered.

    Parameters
    ----------
    scene : reference_tracer.Scene
    spp, seed, batches : int, keyword-only
        Samples per pixel (>= 2), base seed (away from the sweep's) and independent batches for
        the per-sample variance (at most ``spp``).
    variant, threads, cache : keyword-only
        Mitsuba variant (None: the fastest that works), Dr.Jit's threads (None: all cores),
        cache root (:func:`cache_dir`).
    force : bool, keyword-only
        Render and replace even a valid entry.
    log : callable or None, keyword-only
        Told when a corrupt entry is replaced.

    Returns
    -------
    Reference
    """
    if not isinstance(scene, rt.Scene):
        raise ValueError(f"scene must be a reference_tracer.Scene, got {type(scene).__name__}")
    spp = positive_int("spp", spp, minimum=2)
    seed = positive_int("seed", seed, minimum=0, maximum=SEED_MAX)
    batches = positive_int("batches", batches, minimum=2)
    scene_hash = scene.content_hash()
    chosen, mversion, key = _key(scene_hash, spp=spp, seed=seed, variant=variant, batches=batches)
    folder = cache_dir(cache)
    mean_path, var_path, meta_path = _paths(folder, key)

    def render():
        t0 = time.perf_counter()
        out = mitsuba_scenes.render_mitsuba(scene, spp=spp, seed=seed, variant=chosen, threads=threads,
                                            batches=min(batches, spp))
        wall = time.perf_counter() - t0
        mean = np.asarray(out.mean, dtype=np.float32)
        var = np.asarray(out.variance, dtype=np.float32)
        if not (np.all(np.isfinite(mean)) and np.all(np.isfinite(var))):
            raise RuntimeError(f"Mitsuba reference of {scene_hash[:12]} has non-finite pixels")
        write_exr(mean_path, mean)
        write_exr(var_path, var)
        meta = {"format": FORMAT_VERSION, "key": key, "scene_hash": scene_hash, "spp": spp, "seed": seed,
                "batches": len(out.batch_spp), "variant": chosen, "mitsuba_version": mversion,
                "shape": list(mean.shape), "seconds": float(out.seconds), "wall_seconds": wall,
                "compile_seconds": float(out.compile_seconds), "threads": threads,
                "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
                "mean_sha256": file_sha256(mean_path), "variance_sha256": file_sha256(var_path)}
        atomic_write(meta_path, json.dumps(meta, indent=1) + "\n")
        return _reference(meta, mean, var, folder, cached=False)

    return load_or_render(lambda: load_reference(key, shape=(scene.camera.height, scene.camera.width), cache=cache),
                          render, lock=folder / f"{key}.lock", sidecar=meta_path, force=force, log=log,
                          what=f"reference cache entry {key[:12]}")


def closed_form_reference_of(name: str, width: int, height: int):
    """The exact reference of suite scene ``name`` when it has one (``furnace``), else None: a
    :class:`Reference` of zero variance whose ``source`` and ``variant`` are :data:`CLOSED_FORM`.

    >>> ref = closed_form_reference_of("furnace", 4, 2)
    >>> ref.mean.shape, float(ref.variance.max()), round(float(ref.mean[0, 0, 0]), 5)
    ((2, 4, 3), 0.0, 2.08057)
    >>> closed_form_reference_of("cornell_box", 4, 4) is None
    True
    """
    mean = closed_form_reference(name, width=width, height=height)
    if mean is None:
        return None
    mean = np.asarray(mean, dtype=np.float32)
    return Reference(mean=mean, variance=np.zeros_like(mean), spp=CLOSED_FORM_SPP, seed=0, batches=0,
                     variant=CLOSED_FORM, mitsuba_version="-", key=f"closed-form-{name}-{width}x{height}",
                     path=None, variance_path=None, seconds=0.0, cached=True, scene_hash="", source=CLOSED_FORM,
                     description=CLOSED_FORM_REASONS.get(name, CLOSED_FORM))

