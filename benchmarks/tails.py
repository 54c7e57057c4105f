"""Tail references: our own estimator at a high budget with the core's per-pixel moments, cached: a verdict on
a heavy-tailed estimator needs its own variance and tail shape, not the render's (low where its rare paths were
missed) nor Mitsuba's (another estimator). See ``benchmarks/STATISTICS.md``."""
from __future__ import annotations

import dataclasses
import hashlib
import io
import json
import time
from dataclasses import dataclass, field

import numpy as np

import reference_tracer as rt
from reference_tracer.estimate import ImageEstimate, SampleMoments
from reference_tracer.imageio import atomic_write
from reference_tracer.validation import positive_int

from .references import cache_dir, load_or_render

__all__ = ["TailReference", "is_cached", "tail_reference", "tail_key", "sample_variance", "variance_is_lower_bound",
           "variance_tail_reference", "DEFAULT_TAIL_SPP", "DEFAULT_TAIL_SEED", "DEFAULT_MAX_TAIL_SAMPLES"]

#: Samples per pixel of a tail reference: 4x the gate's default budget (STATISTICS.md, "Assumptions").
DEFAULT_TAIL_SPP = 16384
#: Seed of tail references: far from the seeds renders under test use (small integers).
DEFAULT_TAIL_SEED = 0x7A11_5EED
#: Largest tail reference :func:`variance_tail_reference` renders, in samples over the image
#: (2^30: 1M spp at 32x32, minutes on two cores).
DEFAULT_MAX_TAIL_SAMPLES = 2 ** 30
FORMAT_VERSION = 1
_ARRAYS = ("mean", "variance", "m2", "m3", "m4", "max")


@dataclass(kw_only=True)
class TailReference(ImageEstimate):
    """An :class:`~reference_tracer.ImageEstimate` of our estimator with its per-pixel ``moments``."""

    moments: SampleMoments = field(repr=False)
    strategy: str
    seed: int
    build: str
    key: str
    cached: bool
    source: str = "ours"


def tail_key(scene_hash: str, *, build: str, strategy: str, spp: int, seed: int, variant: str = "") -> str:
    """Cache key: SHA-256 over the identity (``variant``: a non-default estimator, e.g. a mutant)."""
    ident = {"format": FORMAT_VERSION, "kind": "tails", "scene": scene_hash, "build": build,
             "strategy": strategy, "spp": int(spp), "seed": int(seed), "variant": variant}
    return hashlib.sha256(json.dumps(ident, sort_keys=True).encode()).hexdigest()


def _load(path, meta_path, key, shape):
    """``((seconds, arrays), None)`` of a valid entry, or ``(None, why)``."""
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
    return (float(meta["seconds"]), arrays), None


def is_cached(scene, *, strategy: str, spp: int = DEFAULT_TAIL_SPP, seed: int = DEFAULT_TAIL_SEED,
              cache=None) -> bool:
    """Whether :func:`tail_reference` would find it in the cache (its sidecar exists), for planning."""
    key = tail_key(scene.content_hash(), build=rt.build_id(), strategy=strategy, spp=spp, seed=seed)
    return (cache_dir(cache) / f"{key}.tails.json").exists()


def tail_reference(scene, *, strategy: str, spp: int = DEFAULT_TAIL_SPP, seed: int = DEFAULT_TAIL_SEED,
                   threads=None, cache=None, render=None, variant: str = "", log=None,
                   progress=None, what: str = "") -> TailReference:
    """The tail reference of ``scene`` for ``strategy``, from the cache or rendered.

    A filtered scene's moments are those of its box-filtered twin (the samples').

    Parameters
    ----------
    scene, strategy : reference_tracer.Scene and str
        The scene at the size under test, and one of ``reference_tracer.STRATEGIES``.
    spp, seed, threads, cache : keyword-only
        Budget, seed, rendering threads and cache root (``benchmarks.references.cache_dir``).
    render, variant : keyword-only
        ``render(scene, spp=, strategy=, seed=, threads=, moments=True)`` instead of
        ``reference_tracer.render`` (the self-test's mutants), and its name for the key.
    log, progress, what : keyword-only
        A callable taking a line (rendered or replaced entries), ``progress(done, total)``
        while our tracer renders, and what it is of (``"cornell_box 32x32"``) for the log.

    Returns
    -------
    TailReference
    """
    if strategy not in rt.STRATEGIES:
        raise ValueError(f"strategy must be one of {rt.STRATEGIES}, got {strategy!r}")
    if not scene.camera.filter.is_box:
        scene = dataclasses.replace(scene, camera=dataclasses.replace(scene.camera, filter=rt.Filter("box")))
    spp = positive_int("spp", spp, minimum=2)
    build = rt.build_id()
    key = tail_key(scene.content_hash(), build=build, strategy=strategy, spp=spp, seed=seed, variant=variant)
    folder = cache_dir(cache)
    path, meta_path = folder / f"{key}.tails.npz", folder / f"{key}.tails.json"
    shape = (scene.camera.height, scene.camera.width)

    def render_entry():
        if log is not None:
            log(f"rendering the tail reference of {what or f'{shape[1]}x{shape[0]}'} {strategy} at {spp} spp")
        extra = {} if render is not None or progress is None else {"progress": progress}
        res = (render or rt.render)(scene, spp=spp, strategy=strategy, seed=seed, threads=threads, moments=True,
                                    **extra)
        m = res.moments
        arrays = {"mean": res.mean, "variance": res.variance, "m2": m.m2, "m3": m.m3, "m4": m.m4, "max": m.max}
        buf = io.BytesIO()
        np.savez_compressed(buf, **arrays)
        atomic_write(path, buf.getvalue())
        meta = {"format": FORMAT_VERSION, "key": key, "strategy": strategy, "spp": spp, "seed": seed, "build": build,
                "variant": variant, "seconds": res.seconds, "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
                "sha256": hashlib.sha256(buf.getvalue()).hexdigest()}
        atomic_write(meta_path, json.dumps(meta, indent=1) + "\n")
        return (res.seconds, arrays), False

    def load():
        loaded, why = _load(path, meta_path, key, shape)
        return (None if loaded is None else (loaded, True)), why

    (seconds, arrays), cached = load_or_render(load, render_entry, lock=folder / f"{key}.lock", sidecar=meta_path,
                                               log=log, what=f"tail reference {key[:12]}")
    moments = SampleMoments(n=spp, m2=arrays["m2"], m3=arrays["m3"], m4=arrays["m4"], max=arrays["max"])
    return TailReference(mean=arrays["mean"], variance=arrays["variance"], spp=spp, seconds=float(seconds),
                         moments=moments, strategy=strategy, seed=seed, build=build, key=key, cached=cached)


def sample_variance(tails) -> np.ndarray:
    """Per-pixel per-sample variance of a tail reference (ddof 1), float rounding of identical
    samples (relative spread below 1e-6) set to zero."""
    m = tails.moments
    var = np.asarray(m.m2, dtype=np.float64) * (m.n / (m.n - 1.0))
    mean = np.asarray(tails.mean, dtype=np.float64)
    return np.where(var <= (1e-6 * np.abs(mean)) ** 2, 0.0, var)


def variance_is_lower_bound(tails, *, share: float = 0.5, weight: float = 0.1) -> bool:
    """Whether a tail reference's variance is only a lower bound: pixels where a single sample
    carries more than ``share`` of the squared deviations hold more than ``weight`` of the
    image's summed variance.

    Examples
    --------
    >>> from reference_tracer.estimate import SampleMoments
    >>> x = np.zeros(1000); x[0] = 1000.0  # one sample carries everything
    >>> d = [x.sum(), (x**2).sum(), (x**3).sum(), (x**4).sum()]
    >>> m = SampleMoments.from_shifted_sums(1000, d=d, max=x.max())
    >>> class T: pass
    >>> t = T(); t.moments, t.mean = m, np.array(x.mean())
    >>> variance_is_lower_bound(t)
    True
    """
    m = tails.moments
    var = sample_variance(tails)
    mean = np.asarray(tails.mean, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        one = np.where(var > 0, (np.asarray(m.max) - mean) ** 2 / (var * m.n), 0.0)
    total = float(var.sum())
    if total <= 0:
        return False
    return float((var / total * (one > share)).sum()) > weight


def variance_tail_reference(scene, *, strategy: str, spp: int = DEFAULT_TAIL_SPP,
                            max_samples: int = DEFAULT_MAX_TAIL_SAMPLES, log=None, what: str = "",
                            **kw) -> TailReference:
    """:func:`tail_reference` at ``spp`` and, where :func:`variance_is_lower_bound` holds, once more
    at the largest budget ``max_samples`` allows (intermediate budgets stay dominated by single
    samples: ``benchmarks/STATISTICS.md``, "Variance of extremely heavy-tailed estimators")."""
    tails = tail_reference(scene, strategy=strategy, spp=spp, log=log, what=what, **kw)
    pixels = int(scene.camera.width) * int(scene.camera.height)
    top = max_samples // pixels
    if variance_is_lower_bound(tails) and top > tails.spp:
        name = f"{what} " if what else ""
        if log is not None:
            log(f"the variance of {name}{strategy} rests on single samples at {tails.spp} spp; "
                f"tail reference at {top} spp (minutes)")
        if log is not None and kw.get("render") is None:
            kw = {**kw, "progress": progress_lines(log, f"tail reference of {name}{strategy} at {top} spp")}
        tails = tail_reference(scene, strategy=strategy, spp=top, log=log, what=what, **kw)
    return tails


def progress_lines(log, what: str, *, step: int = 10):
    """A ``progress(done, total)`` callback logging one line per ``step`` percent with the time taken
    and left.

    Examples
    --------
    >>> lines = []
    >>> cb = progress_lines(lines.append, "x", step=50)
    >>> for done in range(5):
    ...     cb(done, 4)
    >>> [line.split(" (")[0] for line in lines]
    ['x: 50%', 'x: 100%']
    """
    t0, last = time.monotonic(), [0]

    def callback(done, total):
        pct = int(100 * done / total) // step * step if total else 100
        if pct > last[0]:
            last[0] = pct
            took = time.monotonic() - t0
            left = took * (total - done) / done if done else float("nan")
            log(f"{what}: {pct}% ({took:.0f} s, about {left:.0f} s left)")

    return callback
