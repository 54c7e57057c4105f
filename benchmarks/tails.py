"""Tail references: our own estimator at a high budget, for the statistics of its noise.

A verdict on a heavy-tailed estimator needs the estimator's own variance and tail shape
(skewness, kurtosis) per pixel, not the render's (low where its rare paths were missed)
nor the Mitsuba reference's (another estimator, often 1e4 times less noisy). A *tail
reference* is a render of the same scene with the same tracer build and strategy at a
high spp and a seed far from the ones under test, with the core's per-pixel moments
(``rt.render(..., moments=True)``), cached like the Mitsuba references under
``$RTBENCH_CACHE`` and keyed by the scene's content hash, the build id, the strategy, spp
and seed. See ``benchmarks/STATISTICS.md``.
"""
from __future__ import annotations

import contextlib
import hashlib
import io
import json
import time
from dataclasses import dataclass, field

import numpy as np

from reference_tracer.estimate import ImageEstimate, SampleMoments
from reference_tracer._validate import positive_int

from .references import _lock, cache_dir
from .store import atomic_write_bytes, atomic_write_text

__all__ = ["TailReference", "tail_reference", "tail_key", "DEFAULT_TAIL_SPP", "DEFAULT_TAIL_SEED"]

#: Samples per pixel of a tail reference: 4x the gate's default budget. Rare paths with
#: probability well below 1 / DEFAULT_TAIL_SPP stay unseen; the pixel neighbourhood and the
#: tile and image levels pool many pixels' samples for them (STATISTICS.md, "Assumptions").
DEFAULT_TAIL_SPP = 16384
#: Seed of tail references: far from the seeds renders under test use (small integers).
DEFAULT_TAIL_SEED = 0x7A11_5EED
FORMAT_VERSION = 1
_ARRAYS = ("mean", "variance", "m2", "m3", "m4", "max")


@dataclass(kw_only=True)
class TailReference(ImageEstimate):
    """A tail reference: an :class:`~reference_tracer.ImageEstimate` of our estimator with
    its per-pixel :class:`~reference_tracer.SampleMoments` (``moments``)."""

    moments: SampleMoments = field(repr=False)
    strategy: str
    seed: int
    build: str
    key: str
    cached: bool
    source: str = "ours"


def tail_key(scene_hash: str, *, build: str, strategy: str, spp: int, seed: int, variant: str = "") -> str:
    """Cache key: SHA-256 over the identity of a tail reference (``variant`` names a
    non-default estimator, such as a self-test mutant)."""
    ident = {"format": FORMAT_VERSION, "kind": "tails", "scene": scene_hash, "build": build,
             "strategy": strategy, "spp": int(spp), "seed": int(seed), "variant": variant}
    return hashlib.sha256(json.dumps(ident, sort_keys=True).encode()).hexdigest()


def _load(path, meta_path, key, shape):
    if not meta_path.exists():
        return None, "not cached"
    try:
        meta = json.loads(meta_path.read_text())
        blob = path.read_bytes()
    except (OSError, ValueError) as exc:
        return None, f"unreadable ({exc.__class__.__name__})"
    if meta.get("key") != key or hashlib.sha256(blob).hexdigest() != meta.get("sha256"):
        return None, "checksum mismatch (partial or corrupt file)"
    try:
        with np.load(io.BytesIO(blob)) as z:
            arrays = {k: z[k] for k in _ARRAYS}
    except Exception as exc:  # noqa: BLE001 - any decoding failure means re-render
        return None, f"unreadable ({exc})"
    if any(a.shape != tuple(shape) + (3,) for a in arrays.values()):
        return None, "shape does not match the scene"
    return (meta, arrays), None


def _save(path, meta_path, meta, arrays):
    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)
    blob = buf.getvalue()
    atomic_write_bytes(path, blob)
    atomic_write_text(meta_path, json.dumps(dict(meta, sha256=hashlib.sha256(blob).hexdigest()), indent=1) + "\n")


def tail_reference(scene, *, strategy: str, spp: int = DEFAULT_TAIL_SPP, seed: int = DEFAULT_TAIL_SEED,
                   threads=None, cache=None, render=None, variant: str = "", log=None) -> TailReference:
    """The tail reference of ``scene`` for ``strategy``, from the cache or rendered.

    Parameters
    ----------
    scene : reference_tracer.Scene
        The scene at the size under test.
    strategy : str
        One of ``reference_tracer.STRATEGIES``.
    spp, seed : int, keyword-only
        Budget and seed of the tail reference.
    threads, cache : keyword-only
        Rendering threads; cache root (see ``benchmarks.references.cache_dir``).
    render : callable, keyword-only
        ``render(scene, spp=, strategy=, seed=, threads=, moments=True)`` to use instead of
        ``reference_tracer.render`` (the self-test's mutants); give it a ``variant`` name.
    log : callable, keyword-only
        Called with one line when a tail reference is rendered or an entry is replaced.
    """
    import reference_tracer as rt

    if strategy not in rt.STRATEGIES:
        raise ValueError(f"strategy must be one of {rt.STRATEGIES}, got {strategy!r}")
    spp = positive_int("spp", spp, minimum=2)
    build = rt.build_id()
    key = tail_key(scene.content_hash(), build=build, strategy=strategy, spp=spp, seed=seed, variant=variant)
    folder = cache_dir(cache)
    path, meta_path = folder / f"{key}.tails.npz", folder / f"{key}.tails.json"
    shape = (scene.camera.height, scene.camera.width)
    loaded, _ = _load(path, meta_path, key, shape)  # a valid entry needs no lock (read-only caches)
    with contextlib.nullcontext() if loaded is not None else _lock(folder / f"{key}.lock"):
        if loaded is None:  # again under the lock: another process may have rendered it meanwhile
            loaded, why = _load(path, meta_path, key, shape)
        if loaded is None:
            if why != "not cached" and log is not None:
                log(f"tail reference {key[:12]} is unusable ({why}); re-rendering")
            elif log is not None:
                log(f"rendering the tail reference of {strategy} at {spp} spp ({shape[1]}x{shape[0]})")
            with contextlib.suppress(FileNotFoundError):
                meta_path.unlink()
            res = (render or rt.render)(scene, spp=spp, strategy=strategy, seed=seed, threads=threads, moments=True)
            m = res.moments
            arrays = {"mean": res.mean, "variance": res.variance, "m2": m.m2, "m3": m.m3, "m4": m.m4, "max": m.max}
            meta = {"format": FORMAT_VERSION, "key": key, "strategy": strategy, "spp": spp, "seed": seed,
                    "build": build, "variant": variant, "seconds": res.seconds,
                    "created": time.strftime("%Y-%m-%dT%H:%M:%S%z")}
            _save(path, meta_path, meta, arrays)
            cached = False
        else:
            meta, arrays = loaded
            cached = True
    moments = SampleMoments(n=spp, m2=arrays["m2"], m3=arrays["m3"], m4=arrays["m4"], max=arrays["max"])
    return TailReference(mean=arrays["mean"], variance=arrays["variance"], spp=spp, seconds=float(meta["seconds"]),
                         moments=moments, strategy=strategy, seed=seed, build=build, key=key, cached=cached)
