"""The tracer with a seeded bug: what the self-test renders to measure the gate's power.

The seeded bugs ("mutants", ``reference_tracer/cpp/mutants.h``) are compiled from the
tracer's own sources into a second extension module whose scene's ``render`` takes a
mutant id; the tracer's own module contains none of them and :func:`reference_tracer.render`
cannot select one. This module is the one door to them: :func:`render_mutant` renders a
scene with one bug and returns the same :class:`~reference_tracer.render.RenderResult` as
``render``. What each bug breaks, and on which scene it is tested, is the harness's
catalogue (``benchmarks.selftest``).

Examples
--------
>>> import reference_tracer as rt
>>> from reference_tracer.testing import mutant_names, render_mutant
>>> mutant_names()[:2]
['none', 'missing_cosine']
>>> cam = rt.Camera(lookfrom=(0, 0, -3), lookat=(0, 0, 0), width=4, height=4)
>>> scene = rt.Scene(camera=cam, shapes=[rt.Sphere((0, 0, 0), 1, rt.Lambertian(0.5))], background=1.0)
>>> a = render_mutant(scene, "none", spp=4, strategy="mis", seed=1, threads=1)
>>> bool((a.mean == rt.render(scene, spp=4, strategy="mis", seed=1, threads=1, integrator="scalar").mean).all())
True
"""
from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np

from ._compile import compile_scene
from .cpus import default_threads
from .estimate import SampleMoments
from .render import INTEGRATORS, RenderResult
from .scene import Scene
from .strategies import STRATEGIES
from .validation import positive_int

__all__ = ["mutant_names", "mutant_id", "mutants_build_id", "mutant_core_scene", "render_mutant"]


def _mutants():
    from . import _mutants  # the compiled module loads on first use, as the tracer's core does

    return _mutants


def mutant_names() -> list:
    """The seeded bugs by id; index 0 is ``'none'`` (the tracer itself).

    Returns
    -------
    list of str

    Examples
    --------
    >>> mutant_names()[0]
    'none'
    """
    return list(_mutants().mutant_names())


def mutant_id(name: str) -> int:
    """The id of the seeded bug ``name``.

    Raises
    ------
    ValueError
        For a name the compiled module does not have.

    Examples
    --------
    >>> mutant_id("none")
    0
    """
    names = mutant_names()
    if name not in names:
        raise ValueError(f"unknown mutant {name!r}; the core has: {', '.join(names[1:])}")
    return names.index(name)


def mutants_build_id() -> str:
    """A 16-hex-digit hash of the compiled mutants module.

    :func:`reference_tracer.build_id` covers only the tracer's own module, which a change to
    a mutant leaves identical; a cache of mutant renders is keyed by this as well.

    Examples
    --------
    >>> len(mutants_build_id())
    16
    """
    return hashlib.sha256(Path(_mutants().__file__).read_bytes()).hexdigest()[:16]


def mutant_core_scene(scene: Scene):
    """``scene`` compiled for the mutants module (cached on the scene beside the tracer's own).

    Its ``render(spp, strategy, seed, threads, progress, moments, integrator=, mutant=)``
    takes the id of a seeded bug (:func:`mutant_id`); the other queries are those of
    :func:`reference_tracer.probe.core_scene`.
    """
    cache = scene._core_cache
    if "_mutants" not in cache:
        cache["_mutants"] = _mutants().Scene(**compile_scene(scene), triangle_test=0)
    return cache["_mutants"]


def render_mutant(scene: Scene, mutant: str, *, spp: int, strategy: str, seed: int = 0, threads=None,
                  moments: bool = False) -> RenderResult:
    """Render ``scene`` with the tracer built with the seeded bug ``mutant``.

    Parameters
    ----------
    scene : Scene
    mutant : str
        A name of :func:`mutant_names`; ``'none'`` is the tracer itself, whose images equal
        ``render``'s bit for bit.
    spp, strategy, seed, threads, moments
        As for :func:`reference_tracer.render` (``threads=None``: all cores). Every render
        runs the scalar integrator, where the seeded bugs live (the tracer's images are the
        same with either integrator); the box filter and the path integrator are used.

    Returns
    -------
    RenderResult

    Raises
    ------
    ValueError
        For an unknown mutant, strategy, or a count out of range.
    """
    k = mutant_id(mutant)
    spp = positive_int("spp", spp)
    if strategy not in STRATEGIES:
        raise ValueError(f"strategy must be one of {STRATEGIES}, got {strategy!r}")
    if threads is None:
        threads = default_threads()
    threads = positive_int("threads", threads)
    out = mutant_core_scene(scene).render(spp, STRATEGIES.index(strategy), int(seed), threads, None, bool(moments),
                                          integrator=INTEGRATORS.index("scalar"), mutant=k)
    n = float(spp)
    mean = out["sum"] / n
    variance = np.maximum(out["sum_sq"] / n - mean * mean, 0.0)
    tails = (SampleMoments.from_shifted_sums(spp, max=out["max"], d=[out[f"d{i}"] for i in range(1, 5)])
             if moments else None)
    return RenderResult(mean=mean.astype(np.float32), variance=variance.astype(np.float32), seconds=out["seconds"],
                        spp=spp, strategy=strategy, seed=int(seed), rays=int(out["rays"]),
                        nonfinite_samples=int(out["nonfinite"]), build_seconds=0.0, threads=threads,
                        moments=tails)
