"""``render_mitsuba``: render a scene with Mitsuba 3, with per-pixel RGB variance.

Mitsuba's ``moment`` integrator gives second moments in XYZ only, so the per-sample
RGB variance is estimated from K independent batches (docs/conventions.md):
the spp are split into K batches of as equal size as possible, each rendered with its
own seed, and the between-batch spread gives the variance.
"""
from __future__ import annotations

import contextlib
import hashlib
import os
import signal
import threading
import time
from dataclasses import dataclass, field

import numpy as np

import reference_tracer as rt

from .importer import checked_film_size
from .translate import to_mitsuba
from .variants import select_variant

__all__ = ["render_mitsuba", "MitsubaRender", "load_file", "film_sizes", "file_resolver_scope", "mesh_merge_safe",
           "batch_seeds", "split_spp", "batch_estimate", "DEFAULT_BATCHES"]

#: Batches used when ``batches=None`` (capped by ``spp``).
DEFAULT_BATCHES = 16


class _CtrlC:
    """Ctrl-C during a Mitsuba render, as ``KeyboardInterrupt``.

    Mitsuba installs its own C-level SIGINT handler for each ``mi.render`` call: it cancels
    the render ("Received interrupt signal, winding down.."), which then either returns a
    partial image or raises a ``RuntimeError`` (Dr.Jit's), and hands the signal on to
    Python, whose handler runs once the call is back in Python code, possibly inside
    Mitsuba's own Python wrappers that turn it into another error. So while :func:`render_mitsuba`
    runs, SIGINT only sets :attr:`hit` while a Mitsuba call is under way (and raises
    ``KeyboardInterrupt`` at once outside one); :meth:`call` raises ``KeyboardInterrupt``
    after a call during which SIGINT arrived, whatever the call returned or raised. A
    Mitsuba error with no SIGINT is raised as it is. Installed in the main thread only, and
    only where SIGINT has Python's default handler (an ignored SIGINT stays ignored, a
    caller's own handler is left alone).
    """

    def __init__(self):
        self.hit = False
        self.in_call = False
        self.previous = None

    def _handler(self, signum, frame):
        self.hit = True
        if not self.in_call:
            raise KeyboardInterrupt

    def __enter__(self):
        if threading.current_thread() is threading.main_thread() \
                and signal.getsignal(signal.SIGINT) is signal.default_int_handler:
            self.previous = signal.signal(signal.SIGINT, self._handler)
        return self

    def __exit__(self, *exc):
        if self.previous is not None:
            signal.signal(signal.SIGINT, self.previous)
        return False

    def call(self, fn, *args, **kwargs):
        self.in_call = True
        try:
            out = fn(*args, **kwargs)
        except Exception as exc:
            if self.hit:
                raise KeyboardInterrupt from exc
            raise
        finally:
            self.in_call = False
        if self.hit:  # a cancelled render may return a partial image: never use it
            raise KeyboardInterrupt
        return out


@dataclass(kw_only=True)
class MitsubaRender(rt.ImageEstimate):
    """The output of :func:`render_mitsuba`, an :class:`reference_tracer.ImageEstimate`
    (``source`` is ``"mitsuba"``); unpacks as ``(mean, variance, seconds)``.

    Attributes
    ----------
    mean : (H, W, 3) float32
        Per-pixel mean radiance over all ``spp`` samples.
    variance : (H, W, 3) float32
        Per-sample variance estimated from the batches (NaN when ``batches == 1``).
    seconds : float
        Wall time of the timed renders (warm-up excluded).
    compile_seconds : float
        JIT variants: warm-up wall time minus the timed time of the same batch sizes
        (kernel compilation and first-launch cost); 0 for ``scalar_rgb``.
    load_seconds : float
        Time of ``mi.load_dict``.
    variant, seed, threads : the settings used.
    batch_spp, batch_seeds : lists
        Samples and Mitsuba seed of each batch.
    """

    variant: str
    seed: int
    source: str = "mitsuba"
    threads: int | None = None
    compile_seconds: float = 0.0
    load_seconds: float = 0.0
    batch_spp: list = field(default_factory=list)
    batch_seeds: list = field(default_factory=list)

    def __iter__(self):
        return iter((self.mean, self.variance, self.seconds))

    @property
    def batches(self) -> int:
        return len(self.batch_spp)


def split_spp(spp: int, batches: int) -> list:
    """Split ``spp`` into ``min(batches, spp)`` sizes that differ by at most one.

    Examples
    --------
    >>> split_spp(10, 4)
    [3, 3, 2, 2]
    >>> split_spp(1, 16)
    [1]
    """
    k = min(int(batches), int(spp))
    return [spp // k + (1 if i < spp % k else 0) for i in range(k)]


def batch_seeds(seed: int, count: int) -> list:
    """Mitsuba seeds for ``count`` batches: distinct, far apart, derived by hashing.

    Neighbouring Mitsuba seeds can share per-pixel random streams in ``scalar_rgb``, so
    seeds are SHA-256 hashes of ``(seed, batch)`` reduced to 31 bits.

    Examples
    --------
    >>> len(set(batch_seeds(0, 64)))
    64
    """
    out, used = [], set()
    for k in range(count):
        salt = 0
        while True:
            h = hashlib.sha256(f"rtbench-mitsuba:{int(seed)}:{k}:{salt}".encode()).digest()
            s = int.from_bytes(h[:4], "little") & 0x7FFFFFFF
            if s not in used:
                break
            salt += 1
        used.add(s)
        out.append(s)
    return out


def batch_estimate(means, sizes) -> tuple:
    """The mean and per-sample variance of a render from the means of its independent batches.

    With batch means ``m_k`` of ``n_k`` samples each (``K`` batches), the mean is the
    size-weighted ``sum_k n_k m_k / sum_k n_k`` and the per-sample variance the between-batch
    ``sum_k n_k (m_k - mean)^2 / (K - 1)``, unbiased for batches of any sizes
    (docs/conventions.md); NaN for one batch, whose spread is unknown.

    Parameters
    ----------
    means : sequence of (H, W, C) array_like
        The batch means, in the order of ``sizes``.
    sizes : sequence of int
        The samples per pixel of each batch.

    Returns
    -------
    mean, variance : (H, W, C) float32

    Examples
    --------
    >>> mean, var = batch_estimate([np.full((1, 1, 1), 1.0), np.full((1, 1, 1), 3.0)], [1, 1])
    >>> float(mean[0, 0, 0]), float(var[0, 0, 0])
    (2.0, 2.0)
    """
    means = np.asarray(means, dtype=np.float64)
    n = np.asarray(sizes, dtype=np.float64)[:, None, None, None]
    mean = (n * means).sum(axis=0) / n.sum()
    if len(sizes) > 1:
        variance = (n * (means - mean) ** 2).sum(axis=0) / (len(sizes) - 1)
    else:
        variance = np.full_like(mean, np.nan)
    return mean.astype(np.float32), variance.astype(np.float32)


def mesh_merge_safe(scene) -> bool:
    """False when Mitsuba's mesh merging (``optimize=True``) must be off for ``scene``.

    Mitsuba 3.9.1 merges meshes that share a BSDF into one, and fails ("the two meshes
    are incompatible") when one of them has ``flip_normals``: a cube or mesh with
    flipped normals. Merging is only a speed-up, so it is turned off for such scenes.
    """
    if not isinstance(scene, rt.Scene):
        return True
    return not any(s.flip_normals for s in scene.shapes if isinstance(s, rt.Box))


def _film_nodes(mi, state) -> list:
    return [n for n in state.nodes if n.type == mi.ObjectType.Film]


@contextlib.contextmanager
def file_resolver_scope(folder=None):
    """Mitsuba's (thread's) file resolver replaced by a copy for the block, ``folder`` first
    on it when given, and restored afterwards: the ``<path>`` folders that parsing a file adds
    to it do not stay for the next file (nor hide from ``from_mitsuba`` that a file adds them)."""
    import mitsuba as mi  # deferred: after the variant and libLLVM are chosen (select_variant)

    backup = mi.file_resolver()
    resolver = mi.FileResolver(backup)
    if folder is not None:
        resolver.prepend(str(folder))
    mi.set_file_resolver(resolver)
    try:
        yield resolver
    finally:
        mi.set_file_resolver(backup)


def film_sizes(path, *, params=None) -> list:
    """``(width, height)`` of each film of Mitsuba XML file ``path``, as its parser reads
    them (``$name`` values from ``params`` or the file's defaults; Mitsuba's 768x576 where
    a film leaves them out). Parses only: nothing is loaded, the file resolver is left as it
    was. The active variant is used."""
    import mitsuba as mi  # deferred: after the variant and libLLVM are chosen (select_variant)

    cfg = mi.parser.ParserConfig(mi.variant())
    with file_resolver_scope():
        state = mi.parser.parse_file(cfg, str(path), **{str(k): str(v) for k, v in (params or {}).items()})
    return [(int(n.props["width"]) if "width" in n.props.keys() else 768,
             int(n.props["height"]) if "height" in n.props.keys() else 576) for n in _film_nodes(mi, state)]


def load_file(path, *, params=None, film_size=None, optimize: bool = True):
    """``mi.load_file(path, optimize=optimize, **params)``, with every film's width and height set to
    ``film_size``.

    With ``film_size=(width, height)`` the file is loaded by the steps of ``mi.load_file``
    (parse with the file's folder first on the file resolver, transform, instantiate), the
    films' ``width`` and ``height`` replaced after parsing: the same scene at another size,
    includes and relative paths resolved as Mitsuba resolves them, no file written. The
    thread's file resolver is restored afterwards (``<path>`` entries do not leak into the
    next load). ``ValueError`` when the scene has no ``<film>`` to resize; Mitsuba's own
    errors (``RuntimeError``) pass through. The active variant is used. ``optimize=False`` turns
    Mitsuba's merging of meshes and of equal objects off, as ``mi.load_file`` does.
    """
    import mitsuba as mi  # deferred: after the variant and libLLVM are chosen (select_variant)

    params = {str(k): str(v) for k, v in (params or {}).items()}
    if film_size is None:
        with file_resolver_scope():
            return mi.load_file(str(path), optimize=optimize, **params)

    width, height = checked_film_size(film_size)
    with file_resolver_scope(os.path.dirname(os.path.abspath(str(path)))):
        cfg = mi.parser.ParserConfig(mi.variant())
        cfg.merge_equivalent = cfg.merge_meshes = bool(optimize)
        state = mi.parser.parse_file(cfg, str(path), **params)
        films = _film_nodes(mi, state)
        if not films:
            raise ValueError(f"{path}: no <film> whose size could be set (Mitsuba's default film is 768x576)")
        for node in films:
            node.props["width"] = width
            node.props["height"] = height
        mi.parser.transform_all(cfg, state)
        return mi.parser.instantiate(cfg, state)


def render_mitsuba(scene, *, spp: int, seed: int = 0, variant: str | None = None,
                   threads: int | None = None, batches: int | None = None, params=None,
                   film_size=None) -> MitsubaRender:
    """Render ``scene`` with Mitsuba's ``path`` integrator, in independent batches.

    Parameters
    ----------
    scene : reference_tracer.Scene or dict or str or os.PathLike
        Our scene (translated with :func:`mitsuba_scenes.to_mitsuba`), a Mitsuba
        scene dict, or the path of a Mitsuba XML file (``mi.load_file``), rendered as
        it is (its film must give an RGB image).
    spp : int, keyword-only
        Total samples per pixel, >= 1.
    seed : int, keyword-only
        Base seed; batch seeds are hashed from it (:func:`batch_seeds`).
    variant : str or None, keyword-only
        Mitsuba variant; None uses :func:`mitsuba_scenes.variants.select_variant`.
    threads : int or None, keyword-only
        Worker threads (``drjit.set_thread_count``); None leaves Dr.Jit's setting.
    params : dict or None, keyword-only
        XML files only: ``$name`` values, as ``mi.load_file(path, **params)`` takes them.
    film_size : (int, int) or None, keyword-only
        XML files only: ``(width, height)`` replacing the size of the file's film
        (:func:`load_file`); ``from_mitsuba(path, film_size=...)`` is our side of it.
    batches : int or None, keyword-only
        Number of batches K (default ``min(16, spp)``; capped at ``spp``). When K does
        not divide ``spp`` the batch sizes differ by one and the estimators below
        weight each batch by its size. ``spp=1`` (or ``batches=1``) gives one batch
        and a variance of NaN: one sample carries no estimate of its spread.

    Returns
    -------
    MitsubaRender
        ``mean`` and ``variance``: :func:`batch_estimate` of the batches; ``seconds``
        excludes the warm-up render that JIT variants get first (``compile_seconds``
        reports it).

    Examples
    --------
    >>> from mitsuba_scenes import get_scene, render_mitsuba
    >>> mean, var, sec = render_mitsuba(get_scene("cornell_box", width=16, height=16),
    ...                                 spp=8, seed=0, variant="scalar_rgb")
    >>> mean.shape, var.shape
    ((16, 16, 3), (16, 16, 3))
    """
    if not isinstance(scene, (rt.Scene, dict, str, os.PathLike)):
        raise ValueError(f"scene must be a reference_tracer.Scene, a Mitsuba scene dict or an XML path, "
                         f"got {type(scene).__name__}")
    if (params or film_size is not None) and not isinstance(scene, (str, os.PathLike)):
        raise ValueError("params and film_size apply to Mitsuba XML files only")
    if isinstance(spp, bool) or not isinstance(spp, (int, np.integer)) or spp < 1:
        raise ValueError(f"spp must be an integer >= 1, got {spp!r}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be an integer >= 0, got {seed!r}")
    if batches is None:
        batches = DEFAULT_BATCHES
    if isinstance(batches, bool) or not isinstance(batches, (int, np.integer)) or batches < 1:
        raise ValueError(f"batches must be an integer >= 1, got {batches!r}")
    if threads is not None and (isinstance(threads, bool) or not isinstance(threads, (int, np.integer))
                                or threads < 1):
        raise ValueError(f"threads must be an integer >= 1 or None, got {threads!r}")

    with _CtrlC() as guard:
        return _render_batches(scene, spp=spp, seed=seed, variant=variant, threads=threads, batches=batches,
                               params=params, film_size=film_size, guard=guard)


def _render_batches(scene, *, spp, seed, variant, threads, batches, params, film_size, guard: _CtrlC):
    """:func:`render_mitsuba` after its checks; every Mitsuba call through ``guard.call``."""
    chosen = select_variant(variant)
    import drjit as dr  # deferred: after the variant and libLLVM are chosen (select_variant)
    import mitsuba as mi  # deferred: after the variant and libLLVM are chosen (select_variant)

    if threads is not None:
        dr.set_thread_count(int(threads))
    t0 = time.perf_counter()
    if isinstance(scene, (str, os.PathLike)):
        mscene = guard.call(load_file, scene, params=params, film_size=film_size)
    else:
        mscene = guard.call(mi.load_dict, to_mitsuba(scene) if isinstance(scene, rt.Scene) else scene,
                            optimize=mesh_merge_safe(scene))
    load_seconds = time.perf_counter() - t0

    sizes = split_spp(int(spp), int(batches))
    seeds = batch_seeds(int(seed), len(sizes))

    def run(n, s):
        # np.array forces evaluation (and waits for it): inside the guarded call
        return guard.call(lambda: np.array(mi.render(mscene, spp=int(n), seed=int(s)), dtype=np.float64))

    compile_seconds = 0.0
    jit = not chosen.startswith("scalar")
    warm = {}
    if jit:  # compile the kernels of each distinct batch size once, untimed
        for n in sorted(set(sizes)):
            t = time.perf_counter()
            run(n, 0x5EED)
            warm[n] = time.perf_counter() - t

    w, h = (int(x) for x in mscene.sensors()[0].film().size())
    # A `moment` integrator appends its AOVs (the wrapped integrator's mean and second moment,
    # in XYZ) after the R, G, B of the image: the image is the first three channels.
    extra = len(mscene.integrator().aov_names())
    means = np.empty((len(sizes), h, w, 3))
    times = []
    for k, (n, s) in enumerate(zip(sizes, seeds)):
        t = time.perf_counter()
        img = run(n, s)
        times.append(time.perf_counter() - t)
        if img.shape != (h, w, 3 + extra):
            raise RuntimeError(f"Mitsuba returned an image of shape {img.shape}, expected {(h, w, 3 + extra)}")
        means[k] = img[..., :3]
    if jit:
        for n, tw in warm.items():
            timed = [tk for tk, nk in zip(times, sizes) if nk == n]
            compile_seconds += max(0.0, tw - min(timed))

    mean, variance = batch_estimate(means, sizes)
    return MitsubaRender(mean=mean, variance=variance, seconds=float(sum(times)), variant=chosen, spp=int(spp),
                         seed=int(seed), threads=threads, compile_seconds=compile_seconds, load_seconds=load_seconds,
                         batch_spp=sizes, batch_seeds=seeds)
