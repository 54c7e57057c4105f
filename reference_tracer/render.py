"""``render``: run the C++ path tracer on a :class:`Scene`."""
from __future__ import annotations

import hashlib
import time
from dataclasses import dataclass, field

import numpy as np

from ._compile import compile_scene
from .validation import positive_int
from .cpus import default_threads
from .estimate import ImageEstimate, SampleMoments
from .scene import FILTERS, Scene
from .strategies import STRATEGIES

__all__ = ["render", "RenderResult", "ImageEstimate", "STRATEGIES", "TRIANGLE_TESTS", "INTEGRATORS", "BLIND_TO_DELTA_LIGHTS",
           "core_scene"]


#: Ray-triangle tests: ``watertight`` (Woop, Benthin and Wald 2013, the default: no ray
#: leaks through shared edges), ``cramer`` (the seed's Cramer's-rule barycentric test in
#: double precision) and ``cramer32`` (the same in single precision).
TRIANGLE_TESTS = ("watertight", "cramer", "cramer32")

#: Strategies that find light only by meeting emitters with sampled directions: they cannot
#: see delta lights (PointLight, SpotLight, DirectionalLight, ProjectorLight), and ``render`` refuses scenes
#: with such lights for them.
BLIND_TO_DELTA_LIGHTS = ("uniform", "cosine", "mixture")

#: How the C++ core runs the paths: ``wavefront`` (the default: a batch of paths per
#: thread, each bounce's intersection queries answered together) and ``scalar`` (one path
#: at a time, the reference implementation). Their images agree bit for bit.
INTEGRATORS = ("wavefront", "scalar")


@dataclass(kw_only=True)
class RenderResult(ImageEstimate):
    """The output of :func:`render`: an :class:`ImageEstimate` (``mean``, ``variance``,
    ``spp``, ``seconds``; ``source`` is ``"ours"``) with the render's settings and counters.

    Attributes
    ----------
    seconds : float
        Wall time of the render itself (scene compilation and BVH build excluded; see
        ``build_seconds``).
    strategy, seed : the render's settings.
    rays : int
        Rays cast (camera, continuation and shadow rays).
    nonfinite_samples : int
        Samples discarded because their value was NaN or Inf (0 in a correct render).
    overflow_pixels : int
        Pixels whose mean or variance overflowed (infinite in single precision) although
        each sample was finite: radiance too large for the image format, e.g. an emitter
        of 1e300 (0 in a correct render).
    moments : SampleMoments or None
        Per-pixel tail diagnostics, when the render was asked for them (``moments=True``).
    pixel_samples : ImageEstimate or None
        A render with a tent or Gaussian filter only: the plain mean and per-sample variance
        of the samples drawn inside each pixel (the box filter's estimate from the same
        samples). The statistics of a filtered pixel are computed from these
        (``benchmarks.gate.filtered``).
    """

    strategy: str
    seed: int
    source: str = "ours"
    rays: int = 0
    nonfinite_samples: int = 0
    overflow_pixels: int = 0
    build_seconds: float = 0.0
    threads: int = 1
    moments: SampleMoments | None = field(default=None, repr=False)
    extra: dict = field(default_factory=dict)
    pixel_samples: ImageEstimate | None = field(default=None, repr=False)

    @property
    def paths_per_second(self) -> float:
        h, w, _ = self.mean.shape
        return h * w * self.spp / self.seconds if self.seconds > 0 else float("inf")


def core_scene(scene: Scene, *, triangle_test: str = "watertight", cached: bool = True):
    """Return the compiled C++ scene (BVH built), cached on the Scene object.

    The compiled scene's ray queries are documented in :mod:`reference_tracer.probe`, which
    is where code outside the package gets it.

    Parameters
    ----------
    scene : Scene
    triangle_test : str, optional
        One of :data:`TRIANGLE_TESTS`.
    cached : bool, optional
        ``False`` builds afresh every call and leaves the cache alone (to time builds).
    """
    if triangle_test not in TRIANGLE_TESTS:
        raise ValueError(f"triangle_test must be one of {TRIANGLE_TESTS}, got {triangle_test!r}")
    if not isinstance(cached, bool):
        raise ValueError(f"cached must be True or False, got {cached!r}")
    from . import _core  # the C++ core loads on first use: image I/O and the scene model work without it

    if not cached:
        return _core.Scene(**compile_scene(scene), triangle_test=TRIANGLE_TESTS.index(triangle_test))
    cache = scene._core_cache
    if triangle_test not in cache:
        cache[triangle_test] = _core.Scene(**compile_scene(scene),
                                           triangle_test=TRIANGLE_TESTS.index(triangle_test))
    return cache[triangle_test]


def render_bytes(width: int, height: int, *, moments: bool = False) -> int:
    """Peak memory of a render's images, in bytes: the core's per-pixel double sums
    (2 arrays, 7 with ``moments``), the float64 mean, variance and one temporary computed
    from them and the float32 results, 3 channels each.

    Examples
    --------
    >>> render_bytes(100, 100)
    1440000
    """
    per_channel = 8 * (2 + (5 if moments else 0)) + 8 * 3 + 4 * 2
    return int(width) * int(height) * 3 * per_channel


def available_memory() -> int | None:
    """Bytes this process can still allocate: the smaller of the system's available memory
    and the room left under a cgroup (container) limit; None where neither is known."""
    limits = []
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    limits.append(int(line.split()[1]) * 1024)
    except (OSError, ValueError):
        pass
    try:
        with open("/sys/fs/cgroup/memory.max") as fh:
            cap = fh.read().strip()
        if cap != "max":
            with open("/sys/fs/cgroup/memory.current") as fh:
                limits.append(int(cap) - int(fh.read().strip()))
    except (OSError, ValueError):
        pass
    return min(limits) if limits else None


def check_memory(width: int, height: int, *, moments: bool = False, available: int | None = None) -> None:
    """Raise ``ValueError`` before rendering when the images cannot fit in memory.

    Examples
    --------
    >>> check_memory(14000, 14000, available=2 * 2**30)
    Traceback (most recent call last):
    ...
    ValueError: a 14000x14000 render needs about 26.3 GiB for its images, but only 2.0 GiB of memory is available; render a smaller image
    """
    need = render_bytes(width, height, moments=moments)
    have = available_memory() if available is None else available
    if have is not None and need > have:
        raise ValueError(f"a {width}x{height} render needs about {need / 2**30:.1f} GiB for its images, but only "
                         f"{have / 2**30:.1f} GiB of memory is available; render a smaller image")


def render(scene: Scene, *, spp: int = 16, strategy: str = "mixture", seed: int = 0,
           threads: int | None = None, triangle_test: str = "watertight",
           progress=None, moments: bool = False, integrator: str = "wavefront") -> RenderResult:
    """Render ``scene`` with the C++ path tracer.

    The image for a given (scene, spp, strategy, seed) is bit-identical whatever the
    thread count: every pixel draws from its own PCG (64-bit) stream seeded from ``seed`` and
    the pixel index. Ctrl-C stops the render promptly with ``KeyboardInterrupt``.

    Parameters
    ----------
    scene : Scene
    spp : int, keyword-only
        Samples per pixel, >= 1.
    strategy : {'uniform', 'cosine', 'light', 'mixture', 'mis'}, keyword-only
        Direction sampling at non-specular bounces. ``light`` is biased on purpose: it
        samples only directions toward emitters and so sees only light that arrives
        straight from an emitter (no indirect light at diffuse surfaces). In a scene with
        ``direct`` (Mitsuba's ``direct`` integrator) it picks the techniques of the first
        surface's samples: :meth:`Direct.counts`. A scene with delta lights (``PointLight``,
        ``SpotLight``, ``DirectionalLight``, ``ProjectorLight``) renders with ``mis`` or ``light`` only: the
        others (:data:`BLIND_TO_DELTA_LIGHTS`) cannot see such lights and are refused.
    seed : int, keyword-only
        Seed of the random streams, 0 <= seed < 2**64.
    threads : int or None, keyword-only
        Worker threads; None uses all cores.
    triangle_test : {'watertight', 'cramer', 'cramer32'}, keyword-only
        Ray-triangle intersection test (see ``TRIANGLE_TESTS``).
    progress : callable or None, keyword-only
        Called as ``progress(done_rows, total_rows)`` from the calling thread while the
        render runs.
    moments : bool, keyword-only
        Also accumulate per-pixel central moments up to the fourth and the largest sample
        (``result.moments``, a :class:`SampleMoments`): the tail diagnostics the harness's
        statistics use. The image is the same either way.
    integrator : {'wavefront', 'scalar'}, keyword-only
        How the C++ core runs the paths (see ``INTEGRATORS``). ``wavefront`` traces a
        batch of paths per thread and hands each bounce's intersection queries to the
        scene together (four rays per vector instruction, eight with AVX-512, in scenes
        of up to 32 spheres and quads); ``scalar`` traces one path at a time and is the reference
        implementation. Both draw the same random numbers in the same order, so the
        image is the same bit for bit, except where a ray meets two primitives at
        exactly the same distance (either hit is then correct).

    Returns
    -------
    RenderResult

    Examples
    --------
    >>> import reference_tracer as rt
    >>> from mitsuba_scenes import get_scene  # doctest: +SKIP
    >>> result = rt.render(get_scene("cornell_box", width=64, height=64), spp=16,
    ...                    strategy="mis", seed=1)  # doctest: +SKIP
    >>> result.mean.shape  # doctest: +SKIP
    (64, 64, 3)
    """
    if not isinstance(scene, Scene):
        raise ValueError(f"scene must be a reference_tracer.Scene, got {scene!r}")
    spp = positive_int("spp", spp)
    if strategy not in STRATEGIES:
        raise ValueError(f"strategy must be one of {STRATEGIES}, got {strategy!r}")
    if strategy in BLIND_TO_DELTA_LIGHTS and scene.delta_lights:
        names = ", ".join(sorted({type(light).__name__ for light in scene.delta_lights}))
        raise ValueError(f"strategy {strategy!r} cannot see the scene's delta lights ({names}): it collects light "
                         "only where a sampled direction meets an emitter, and no direction meets a point, spot or "
                         "directional light; render with 'mis' or 'light'")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= seed < 2**64:
        raise ValueError(f"seed must be an integer in [0, 2**64), got {seed!r}")
    if threads is None:
        threads = default_threads()
    threads = positive_int("threads", threads)
    if progress is not None and not callable(progress):
        raise ValueError("progress must be callable or None")

    if not isinstance(moments, bool):
        raise ValueError(f"moments must be True or False, got {moments!r}")
    if integrator not in INTEGRATORS:
        raise ValueError(f"integrator must be one of {INTEGRATORS}, got {integrator!r}")
    check_memory(scene.camera.width, scene.camera.height, moments=moments)

    t0 = time.perf_counter()
    core = core_scene(scene, triangle_test=triangle_test)
    build = time.perf_counter() - t0
    if not scene.camera.filter.is_box:
        if moments:
            raise ValueError("moments (tail diagnostics) describe the samples, not the filter: render the scene "
                             "with the box filter for them (the samples are the same); a filtered pixel is a ratio of "
                             "weighted sums, not a mean of samples")
        return _render_filtered(core, scene, spp=spp, strategy=strategy, seed=int(seed), threads=threads,
                                progress=progress, integrator=integrator, build=build)
    out = core.render(spp, STRATEGIES.index(strategy), int(seed), threads, progress, moments,
                      INTEGRATORS.index(integrator), **_direct_counts(scene, strategy))
    n = float(spp)
    mean = out["sum"] / n
    with np.errstate(over="ignore", invalid="ignore"):
        variance = np.maximum(out["sum_sq"] / n - mean * mean, 0.0)
        mean, variance = mean.astype(np.float32), variance.astype(np.float32)
    overflow = int(np.count_nonzero(~(np.isfinite(mean) & np.isfinite(variance)).all(axis=-1)))
    return RenderResult(mean=mean, variance=variance, overflow_pixels=overflow,
                        seconds=out["seconds"], spp=spp, strategy=strategy, seed=int(seed),
                        rays=int(out["rays"]), nonfinite_samples=int(out["nonfinite"]),
                        build_seconds=build, threads=threads,
                        moments=(SampleMoments.from_shifted_sums(spp, max=out["max"],
                                                                 d=[out[f"d{k}"] for k in range(1, 5)])
                                 if moments else None))


def _direct_counts(scene: Scene, strategy: str) -> dict:
    """The core's keyword arguments for Mitsuba's ``direct`` (none: the path integrator)."""
    if scene.direct is None:
        return {}
    ne, nb = scene.direct.counts(strategy)
    return {"direct_emitter": ne, "direct_bsdf": nb}


#: independent batches of a filtered render, for its per-pixel variance (as Mitsuba's references).
FILTER_BATCHES = 16


def _batch_seed(seed: int, k: int) -> int:
    """Seed of batch ``k`` of a filtered render: far from ``seed`` and from the other batches'."""
    digest = hashlib.sha256(f"filtered-batch:{seed}:{k}".encode()).digest()
    return int.from_bytes(digest[:8], "little")


def _render_filtered(core, scene: Scene, *, spp, strategy, seed, threads, progress, integrator, build):
    """A render with a tent or Gaussian filter, in ``K = min(16, spp)`` independent batches.

    The image is Mitsuba's estimator over all the samples: every pixel's summed weighted
    radiance over its summed weights, the sums pooled over the batches. Its per-sample
    variance comes from the batches, ``sum_k n_k (B_k - mean)^2 / (K - 1)`` with ``B_k`` batch
    ``k``'s own image of ``n_k`` spp (so ``variance / spp`` is the variance of the mean), as
    for Mitsuba's references: a filtered pixel is a ratio of correlated sums, whose samples
    have no variance of their own. One batch (spp 1) has no variance: NaN.
    """
    f = scene.camera.filter
    kind = FILTERS.index(f.kind)
    param = f.radius if f.kind == "tent" else f.stddev
    K = min(FILTER_BATCHES, spp)
    sizes = [spp // K + (1 if k < spp % K else 0) for k in range(K)]
    sums, images, seconds, rays, nonfinite = None, [], 0.0, 0, 0
    box_sum = box_sq = 0.0
    for k, n in enumerate(sizes):
        done = sum(sizes[:k])

        def batch_progress(rows_done, rows_total, done=done, n=n):
            if progress is not None:
                progress(int((done + n * rows_done / max(rows_total, 1)) / spp * rows_total), rows_total)

        out = core.render(n, STRATEGIES.index(strategy), _batch_seed(seed, k), threads,
                          batch_progress if progress is not None else None, False, INTEGRATORS.index(integrator),
                          filter=kind, filter_param=float(param), **_direct_counts(scene, strategy))
        acc = out["filtered"]
        box_sum, box_sq = box_sum + out["sum"], box_sq + out["sum_sq"]
        sums = acc.copy() if sums is None else sums + acc
        with np.errstate(invalid="ignore", divide="ignore"):
            images.append(acc[..., :3] / acc[..., 3:])
        seconds += out["seconds"]
        rays += int(out["rays"])
        nonfinite += int(out["nonfinite"])
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        mean = sums[..., :3] / sums[..., 3:]
        if K > 1:
            n_k = np.asarray(sizes, dtype=np.float64)[:, None, None, None]
            variance = np.sum(n_k * (np.stack(images) - mean) ** 2, axis=0) / (K - 1)
        else:
            variance = np.full_like(mean, np.nan)
        box_mean = box_sum / spp
        box_var = np.maximum(box_sq / spp - box_mean * box_mean, 0.0)
    mean, variance = mean.astype(np.float32), variance.astype(np.float32)
    overflow = int(np.count_nonzero(~np.isfinite(mean).all(axis=-1)))
    pixels = ImageEstimate(mean=box_mean.astype(np.float32), variance=box_var.astype(np.float32), spp=spp,
                           seconds=seconds, source="ours")
    return RenderResult(mean=mean, variance=variance, overflow_pixels=overflow, seconds=seconds, spp=spp,
                        strategy=strategy, seed=int(seed), rays=rays, nonfinite_samples=nonfinite,
                        build_seconds=build, threads=threads, extra={"filter": f.kind, "batches": K},
                        pixel_samples=pixels)
