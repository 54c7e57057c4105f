"""The gate against ourselves: references from a results store of a named build of our tracer.

For what Mitsuba cannot render, a trusted build renders the scenes once into a results store
(:func:`write_reference_store`, ``rtbench gate --write-reference STORE``) and later builds are
gated against those images (:func:`store_reference`, ``--reference STORE``): "this build renders
what build X rendered", not "this is right".
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

import reference_tracer as rt
from reference_tracer.build import build_info
from reference_tracer.validation import positive_int

from ..files import slug
from ..references import DEFAULT_REFERENCE_SEED, Reference
from ..scenes import scene_at, scene_info
from ..store import (append_record, dedupe_records, finished_keys, read_image, read_records,
                     write_image, writer_lock)

__all__ = ["write_reference_store", "store_reference", "pooled_image"]


def write_reference_store(names, store, *, spp: int, width: int, height: int | None = None,
                          strategy: str = "mis", threads: int | None = None, log=None) -> list:
    """Render each scene once with our tracer at ``spp`` into results store ``store``; returns the
    records written (with the build, the scene hash, the mean and per-sample variance images).
    The store's writer lock is held throughout: a second writer renders only what is missing."""
    width = positive_int("width", width)
    height = width if height is None else positive_int("height", height)
    out = []
    with writer_lock(store, say=log):  # one writer at a time; a second one waits, then resumes
        done = finished_keys(store)
        for name in names:
            scene = scene_at(name, width, height)
            key = (name, "ours", strategy, int(spp), 0, width, height, build_info()["build"])
            if key in done:
                if log:
                    log(f"reference store {store}: {name} {width}x{height} {strategy} {spp} spp of this build "
                        "is there already")
                continue
            res = rt.render(scene, spp=spp, strategy=strategy, seed=DEFAULT_REFERENCE_SEED, threads=threads)
            stem = f"images/{slug(name, f'{width}x{height}')}/{slug('ours', strategy, f'spp{spp}', 'seed0')}"
            write_image(store, f"{stem}.exr", res.mean)
            write_image(store, f"{stem}_var.exr", res.variance)
            rec = {"scene": name, "renderer": "ours", "strategy": strategy, "spp": int(spp), "seed": 0,
                   "width": width, "height": height, "mse": None, "seconds": float(res.seconds),
                   "image": f"{stem}.exr", "stats_image": f"{stem}.exr", "stats_variance_image": f"{stem}_var.exr",
                   "render_seed": DEFAULT_REFERENCE_SEED, "nonfinite_samples": int(res.nonfinite_samples),
                   **scene_info(name, scene), **build_info()}
            append_record(store, rec)
            out.append(rec)
            if log:
                log(f"reference store {store}: {name} {width}x{height} {strategy} {spp} spp, build {rec['build']} "
                    f"({res.seconds:.1f} s)")
    return out


def _image_name(record, key):
    """An image field of a record: a file name, else None (null, or no string: absent, never fatal)."""
    v = record.get(key)
    return v if isinstance(v, str) and v else None


def _records(store, build):
    if build is None:
        return read_records(store)
    raw = read_records(store, dedupe=False)  # the job records of every build, lines that are none skipped
    recs = dedupe_records([r for r in raw if r.get("build") == build])
    if not recs:
        builds = sorted({str(r.get("build")) for r in raw})
        raise ValueError(f"reference store {store} holds no records of build {build}; it has: {', '.join(builds)}")
    return recs


def store_reference(store, name: str, scene, *, build: str | None = None) -> Reference:
    """The reference of scene ``name`` (at ``scene``'s size) from a results store of our tracer:
    the curve with the most samples at its top spp (seeds pooled) among the records of ``build``
    (None: each curve's latest). ``ValueError`` where there is none or the scene changed."""
    store = Path(store)
    if not (store / "results.jsonl").is_file():
        raise ValueError(f"--reference {store} is not a results store (no results.jsonl)")
    w, h = scene.camera.width, scene.camera.height
    recs = [r for r in _records(store, build) if r.get("scene") == name and r.get("renderer") == "ours"
            and (r.get("width"), r.get("height")) == (w, h) and _image_name(r, "stats_image")
            and _image_name(r, "stats_variance_image")]
    if not recs:
        raise ValueError(f"reference store {store} has no image of ours for {name} at {w}x{h}"
                         + (f" by build {build}" if build else "") + " (write one with gate --write-reference)")
    want = scene.content_hash()[:16]
    stale = [r for r in recs if r.get("scene_hash") not in (None, want)]
    if stale:
        raise ValueError(f"reference store {store}: {name} was rendered from another scene description "
                         f"(hash {stale[0]['scene_hash']}, now {want})")
    best = None
    for strategy in sorted({r["strategy"] for r in recs}, key=lambda s: s != "mis"):
        mine = [r for r in recs if r["strategy"] == strategy]
        top = max(int(r["spp"]) for r in mine)
        pooled = pooled_image(store, mine, top)
        if pooled is not None and (best is None or pooled[2] > best[0][2]):
            best = (pooled, strategy, mine[-1])
    if best is None:
        raise ValueError(f"reference store {store}: no usable image of {name} at {w}x{h}")
    (mean, var, n), strategy, rec = best
    b, git = rec.get("build"), rec.get("build_git")
    return Reference(mean=np.asarray(mean, np.float32), variance=np.asarray(var, np.float32), spp=int(n),
                     seed=int(rec.get("render_seed") or 0), batches=1, variant=f"ours {b}", mitsuba_version="-",
                     key=f"store:{store.resolve()}:{name}:{w}x{h}:{b}", path=None, variance_path=None, seconds=0.0,
                     cached=True, scene_hash=want, source="store",
                     description=f"our build {b}" + (f" (git {git})" if git else "") + f", {strategy} {n} spp, "
                                 f"from {store}")


def pooled_image(store, records, spp: int):
    """``(mean, per-sample variance, total spp)`` of a curve's stored images at ``spp``, or None: the
    seeds' mean, and the stored variance images' mean, else ``spp`` x the between-seed variance."""
    recs = [r for r in records if int(r["spp"]) == spp and (_image_name(r, "stats_image") or _image_name(r, "image"))]
    if not recs:
        return None
    means = np.stack([read_image(store, _image_name(r, "stats_image") or _image_name(r, "image"), rgb=True)
                      for r in recs])
    var_paths = [_image_name(r, "stats_variance_image") for r in recs]
    if all(var_paths):
        var = np.mean([read_image(store, p, rgb=True) for p in var_paths], axis=0)
    elif len(recs) >= 2:
        var = means.var(axis=0, ddof=1) * spp
    else:
        return None
    return means.mean(axis=0), var, spp * len(recs)
