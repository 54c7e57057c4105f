"""Rendering with a seeded bug: the one way to reach the mutants.

The mutants are compiled from the tracer's own sources (``reference_tracer/cpp/mutants.h``)
into a second extension module, ``reference_tracer._mutants``, whose ``Scene.render`` takes
``mutant=<id>``; the tracer's module ``reference_tracer._core`` contains none of them and
``reference_tracer.render`` cannot select one. :func:`render_mutant` compiles the scene for
``_mutants`` and returns the same :class:`reference_tracer.render.RenderResult` as
``rt.render`` (so it can be passed as ``render=`` to :func:`benchmarks.tails.tail_reference`).
"""
from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np

__all__ = ["mutant_names", "mutant_id", "mutants_build_id", "render_mutant"]


def mutant_names() -> list:
    """The mutants of ``reference_tracer._mutants`` by id; index 0 is ``'none'`` (the tracer)."""
    from reference_tracer import _mutants

    return list(_mutants.mutant_names())


def mutants_build_id() -> str:
    """A 16-hex-digit hash of the compiled ``_mutants`` module (``rt.build_id()`` covers only
    ``_core``, which a change to a mutant leaves identical): part of the cache key of a
    mutant's tail reference."""
    from reference_tracer import _mutants

    return hashlib.sha256(Path(_mutants.__file__).read_bytes()).hexdigest()[:16]


def _compiled(scene):
    """``scene`` compiled for ``_mutants`` (cached on the scene beside ``_core``'s)."""
    from reference_tracer import _mutants
    from reference_tracer._compile import compile_scene

    cache = scene._core_cache
    if "_mutants" not in cache:
        cache["_mutants"] = _mutants.Scene(**compile_scene(scene), triangle_test=0)
    return cache["_mutants"]


def mutant_id(name: str) -> int:
    """The core's id of mutant ``name`` (ValueError for an unknown name)."""
    names = mutant_names()
    if name not in names:
        raise ValueError(f"unknown mutant {name!r}; the core has: {', '.join(names[1:])}")
    return names.index(name)


def render_mutant(scene, mutant: str, *, spp: int, strategy: str, seed: int = 0, threads=None,
                  moments: bool = False):
    """Render ``scene`` with the tracer built with seeded bug ``mutant`` (``'none'``: the tracer).

    Same arguments and result as :func:`reference_tracer.render` (``triangle_test`` and
    ``progress`` left at their defaults); images from ``'none'`` equal ``rt.render``'s
    bit for bit.
    """
    import reference_tracer as rt
    from reference_tracer._validate import positive_int
    from reference_tracer.estimate import SampleMoments
    from reference_tracer.render import RenderResult

    k = mutant_id(mutant)
    spp = positive_int("spp", spp)
    if strategy not in rt.STRATEGIES:
        raise ValueError(f"strategy must be one of {rt.STRATEGIES}, got {strategy!r}")
    if threads is None:
        from ..sweep.jobs import default_threads

        threads = default_threads()
    threads = positive_int("threads", threads)
    # The seeded bugs live in the scalar integrator; the tracer's images are the same with
    # either integrator (tests/test_wavefront.py), so every self-test render uses it.
    out = _compiled(scene).render(spp, rt.STRATEGIES.index(strategy), int(seed), threads, None, bool(moments),
                                   integrator=rt.INTEGRATORS.index("scalar"), mutant=k)
    n = float(spp)
    mean = out["sum"] / n
    variance = np.maximum(out["sum_sq"] / n - mean * mean, 0.0)
    tails = (SampleMoments.from_shifted_sums(spp, max=out["max"], d=[out[f"d{i}"] for i in range(1, 5)])
             if moments else None)
    return RenderResult(mean=mean.astype(np.float32), variance=variance.astype(np.float32), seconds=out["seconds"],
                        spp=spp, strategy=strategy, seed=int(seed), rays=int(out["rays"]),
                        nonfinite_samples=int(out["nonfinite"]), build_seconds=0.0, threads=threads,
                        moments=tails)
