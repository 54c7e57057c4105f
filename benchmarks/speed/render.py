"""The paired render benchmark: ours vs Mitsuba's ``path`` integrator, paths/s and error at equal spp.

:func:`render_benchmark` renders each scene with ours (every strategy and integrator, of the installed core and other
``builds``), Mitsuba (each variant) and external renderers at the same settings, per Russian-roulette configuration:
after a warm-up each, ``repeats`` rounds run every configuration once, interleaved and alternating who goes first, so
that load hits both sides of a pair alike; a ratio is the median of the rounds'. PERFORMANCE.md, How to measure."""
from __future__ import annotations

import contextlib
import dataclasses
import functools
import itertools
import math
import resource

import numpy as np

import reference_tracer as rt
from mitsuba_scenes import known_scenes
from mitsuba_scenes.render import batch_seeds
from reference_tracer import INTEGRATORS
from reference_tracer.probe import core_scene
from reference_tracer.validation import positive_int

from ..constants import MITSUBA_STRATEGY, STRATEGIES, UNBIASED_STRATEGIES
from ..external import STRATEGY as EXTERNAL_STRATEGY
from ..external import render_external
from ..metrics import efficiency, mse, mse_corrected
from ..references import reference
from ..scenes import scene_at
from .builds import CoreWorker
from .common import (available_variants, environment, load_mitsuba, median, mitsuba_kernel_workers,
                     mitsuba_render_timed, mitsuba_versions, name_list, spread, timed, use_mitsuba_kernels)
from .suite import suite_summary

__all__ = ["DEFAULT_STRATEGIES", "DEFAULT_VARIANTS", "DEFAULT_RR_DEPTHS", "REFERENCE_KINDS", "render_benchmark",
           "render_config", "check_depths", "rr_label", "render_timed", "mitsuba_timed"]

#: our strategies in run order: the unbiased ones from ``mis`` (matched to Mitsuba's ``path``) down to the plainest,
#: then the biased ``light``.
DEFAULT_STRATEGIES = (tuple(reversed(UNBIASED_STRATEGIES))
                      + tuple(s for s in STRATEGIES if s not in UNBIASED_STRATEGIES))
#: Mitsuba variants compared against, the bar first.
DEFAULT_VARIANTS = ("llvm_ad_rgb", "scalar_rgb")
#: Russian-roulette configurations, in order: Mitsuba's default (from depth 5), then none.
DEFAULT_RR_DEPTHS = (5, None)
#: the error reference: a cached high-spp Mitsuba render (``benchmarks.references``) or ours (``mis``).
REFERENCE_KINDS = ("mitsuba", "ours")

#: the per-run figures summarised (median over rounds) in each summary row.
_SUMMARY_KEYS = ("paths_per_second", "paths_per_cpu_second", "rays_per_second", "ms_per_spp", "seconds",
                 "process_seconds", "cpu_over_wall", "mse", "mse_corrected", "rmse", "efficiency")


def render_benchmark(scenes=("cornell_box",), *, width: int = 128, height: int = 128, spp: int = 64,
                     threads: int = 2, repeats: int = 5, strategies=DEFAULT_STRATEGIES,
                     integrators=("wavefront",), variants=DEFAULT_VARIANTS, max_depth: int | None = None,
                     rr_depths=DEFAULT_RR_DEPTHS, reference: str = "mitsuba", reference_spp: int = 4096, seed: int = 0,
                     cache=None, log=None, externals=(), builds=None) -> dict:
    """Paired, interleaved render timings of ours vs Mitsuba, with error at equal spp.

    Parameters
    ----------
    scenes : sequence of str
        Scene names (``mitsuba_scenes.known_scenes()``).
    width, height, spp, threads, repeats, seed : int, keyword-only
        Image size, samples per pixel, threads (every renderer), timed rounds; round ``r`` uses seed ``seed + r``.
    strategies, integrators, variants : sequence of str or comma-separated str, keyword-only
        Ours: every strategy with every integrator, the first of each the headline's; Mitsuba's variants (one that
        does not work here is skipped).
    max_depth : int or None, keyword-only
        Override the scenes' ``max_depth`` (None keeps it).
    rr_depths : sequence of (int, None or 'scene'), keyword-only
        Russian-roulette configurations, each measured apart: the depth it starts at, None for none, 'scene' as is.
    reference, reference_spp : keyword-only
        Error reference (:data:`REFERENCE_KINDS`: the cached Mitsuba one, or a fresh ``mis`` render of ours) and its
        spp.
    cache, log : keyword-only
        Reference cache root; a callable taking progress lines.
    externals : sequence of benchmarks.external.ExternalRenderer, keyword-only
        External renderers timed in the same rounds (their wall clock includes process start and scene loading).
    builds : mapping of str to path, keyword-only
        Other builds of our core (name: module) rendering in worker processes in the same rounds, rows labelled ``ours
        <strategy>, <name> build``.

    Returns
    -------
    dict
        ``config``, ``environment``, ``mitsuba``, ``skipped_variants``, ``available_variants``, ``references``,
        ``mitsuba_targets`` (where Mitsuba also ran with kernels for a build's instruction set: ``{build: target}``)
        and ``mitsuba_targets_skipped`` (``{build: why}`` where it could not),
        ``runs`` (one record a timed render), ``summary`` (a row per scene, configuration and renderer: medians over
        rounds and, against each variant ``v``, ``ratio_v``, ``cpu_ratio_v``, ``efficiency_ratio_v``,
        ``round_ratios_v``, ``round_efficiency_ratios_v``), ``suite`` (:func:`.suite_summary`) and ``build_suites``
        (of each build).
    """
    config = render_config(scenes, width=width, height=height, spp=spp, threads=threads, repeats=repeats,
                            strategies=strategies, integrators=integrators, variants=variants, max_depth=max_depth,
                            rr_depths=rr_depths, reference=reference, reference_spp=reference_spp, seed=seed)
    builds = config["builds"] = {str(k): str(v) for k, v in (builds or {}).items()}
    config["externals"] = {e.name: e.template for e in externals}
    ok_variants, skipped = available_variants(config["variants"], log)
    result = {"config": config, "environment": environment(), "skipped_variants": skipped, "mitsuba": {},
              "references": {}, "runs": [], "summary": []}
    if ok_variants:
        result["mitsuba"]["versions"] = mitsuba_versions()
    elif reference == "mitsuba":
        reasons = "; ".join(f"{v}: {why}" for v, why in skipped.items())
        raise ValueError(f"no Mitsuba variant of {', '.join(config['variants'])} works here ({reasons}): give one "
                         f"that works (--variant), or time ours alone against a reference of ours "
                         f"(--reference-kind ours, reference='ours')")
    with contextlib.ExitStack() as stack:
        workers = {name: stack.enter_context(CoreWorker(module)) for name, module in builds.items()}
        llvm = next((v for v in ok_variants if v.startswith("llvm")), None)
        kernels, result["mitsuba_targets"], result["mitsuba_targets_skipped"] = mitsuba_kernel_workers(
            workers, llvm, log)
        for name in config["scenes"]:
            _bench_scene(result, name, config, ok_variants, cache=cache, log=log, externals=tuple(externals),
                         workers=workers, kernels=kernels)
    result["available_variants"] = ok_variants
    result["suite"] = suite_summary(result)
    result["build_suites"] = {b: suite_summary(result, build=b) for b in builds}
    result["environment_after"] = environment()
    return result


def render_config(scenes, *, spp, strategies, integrators, variants, max_depth, rr_depths, reference, reference_spp,
                  seed, **sizes) -> dict:
    """The validated settings of :func:`render_benchmark` (its keywords, ``sizes`` the integer ones such as
    ``width``), as stored under ``config``; ``ValueError`` names a bad one. Nothing is loaded or rendered."""
    spp, reference_spp = positive_int("spp", spp), positive_int("reference_spp", reference_spp, minimum=2)
    if reference not in REFERENCE_KINDS:
        raise ValueError(f"reference must be one of {REFERENCE_KINDS}, got {reference!r}")
    rr_depths = check_depths(spp=spp, reference_spp=reference_spp, max_depth=max_depth, rr_depths=rr_depths)
    return {"scenes": name_list("scenes", scenes, known_scenes()), **{k: positive_int(k, v) for k, v in sizes.items()},
            "spp": spp, "strategies": name_list("strategies", strategies, STRATEGIES),
            "integrators": name_list("integrators", integrators, INTEGRATORS),
            "variants": name_list("variants", variants), "max_depth": None if max_depth is None else int(max_depth),
            "rr_depths": rr_depths, "reference": reference, "reference_spp": reference_spp,
            "seed": positive_int("seed", seed, minimum=0)}


def check_depths(*, spp, reference_spp, max_depth, rr_depths, names=None) -> list:
    """Check the settings :func:`render_benchmark` and ``rtbench speed`` share beyond plain ranges: ``reference_spp``
    above ``spp``, ``max_depth`` None (the scenes' own), -1 or >= 1, and ``rr_depths`` distinct Russian-roulette
    configurations (a depth >= 1, None for none, ``'scene'`` for the scene's own). ``names`` maps a keyword to the
    word an error uses for it (``rtbench speed`` passes its options); ``ValueError`` names the first bad one.
    Returns ``rr_depths`` as a list, each depth an ``int``.

    >>> check_depths(spp=8, reference_spp=64, max_depth=None, rr_depths=[5, None])
    [5, None]
    >>> check_depths(spp=8, reference_spp=64, max_depth=None, rr_depths=[5, 5], names={"rr_depths": "--rr-depth"})
    Traceback (most recent call last):
    ...
    ValueError: --rr-depth: 5 given more than once
    """
    name = {"spp": "spp", "reference_spp": "reference_spp", "max_depth": "max_depth", "rr_depths": "rr_depths",
            **(names or {})}
    if reference_spp <= spp:
        raise ValueError(f"{name['reference_spp']} ({reference_spp}) must exceed {name['spp']} ({spp})")
    if max_depth is not None and not (int(max_depth) == -1 or int(max_depth) >= 1):
        raise ValueError(f"{name['max_depth']} must be >= 1 or -1, got {max_depth}")
    rr_depths = list(rr_depths)
    if not rr_depths:
        raise ValueError(f"{name['rr_depths']} must name at least one configuration")
    for v in rr_depths:
        if v in ("scene", None):
            continue
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
            raise ValueError(f"{name['rr_depths']}: a depth must be an integer, None or 'scene', got {v!r}")
        if v < 1:
            raise ValueError(f"{name['rr_depths']}: a depth must be >= 1, got {v}")
    labels = ["none" if v is None else str(v) for v in rr_depths]
    twice = sorted({v for v in labels if labels.count(v) > 1})
    if twice:
        raise ValueError(f"{name['rr_depths']}: {', '.join(twice)} given more than once")
    return [v if v in ("scene", None) else int(v) for v in rr_depths]


def rr_label(rr_depth) -> str:
    """A Russian-roulette setting as a table label: ``rr_depth 5``, ``no RR``."""
    return "no RR" if rr_depth is None else f"rr_depth {rr_depth}"


_KEPT = {}   # a worker's scenes, kept between calls: each tree is built once


def render_timed(scene, *, key=None, **render_args):
    """``(result, wall seconds, process CPU seconds)`` of ``rt.render(scene, **render_args)``.

    Called in a :class:`.builds.CoreWorker` too, which keeps ``scene`` under ``key``.
    """
    if key is not None:
        scene = _KEPT.setdefault(key, scene)
    return timed(lambda: rt.render(scene, **render_args))


def mitsuba_timed(scene, *, variant, isa, key, spp, seed, threads):
    """:func:`.common.mitsuba_render_timed` with kernels compiled for ``isa`` (:func:`.common.use_mitsuba_kernels`), in
    a :class:`.builds.CoreWorker` which keeps the loaded scene under ``key``."""
    use_mitsuba_kernels(variant, isa, threads)
    if key not in _KEPT:
        _KEPT[key] = load_mitsuba(variant, scene, threads)[0]
    return mitsuba_render_timed(variant, _KEPT[key], spp=spp, seed=seed, threads=threads)


def _mitsuba_label(variant, build=None) -> str:
    """The label of Mitsuba's rows: ``Mitsuba <variant>``, with ``, <isa> kernels`` for kernels compiled for the
    instruction set of our ``build``."""
    return f"Mitsuba {variant}" + ("" if build is None else f", {build} kernels")


def _bench_scene(result, name, config, ok_variants, *, cache, log, externals, workers, kernels):
    """Set up, time and summarise one scene in every Russian-roulette configuration."""
    width, height, spp, threads = config["width"], config["height"], config["spp"], config["threads"]
    base = scene_at(name, width, height)
    if config["max_depth"] is not None:
        base = dataclasses.replace(base, max_depth=config["max_depth"])
    _, build_wall, _ = timed(lambda: core_scene(base))   # our tree, untimed
    ref, result["references"][name] = _reference(base, kind=config["reference"], spp=config["reference_spp"],
                                                 variant=(ok_variants or [None])[0], threads=threads, cache=cache,
                                                 log=log)
    result.setdefault("ours", {})[name] = {"build_seconds": float(core_scene(base).build_seconds),
                                           "compile_and_build_seconds": build_wall}
    for rr in config["rr_depths"]:
        scene = dataclasses.replace(base, rr_depth=base.rr_depth if rr == "scene" else rr)
        label = rr_label(scene.rr_depth)
        if log:
            log(f"{name} {width}x{height}, {spp} spp, max_depth {scene.max_depth}, {label}, {threads} threads")
        bare = dataclasses.replace(scene)   # no tree: what a worker is sent
        cores = {None: functools.partial(render_timed, scene)}
        cores.update({b: functools.partial(w, "benchmarks.speed.render.render_timed", bare, key=(name, label))
                      for b, w in workers.items()})
        for core in cores.values():   # warm-up
            core(spp=max(1, spp // 8), strategy=config["strategies"][0], seed=0xA11CE, threads=threads)
        mscenes, infos = _warm_mitsuba(scene, ok_variants, spp=spp, threads=threads, log=log)
        same_isa = {(v, b): functools.partial(w, "benchmarks.speed.render.mitsuba_timed", bare, variant=v, isa=b,
                                              key=("mitsuba", v, name, label), threads=threads)
                    for b, w in kernels.items() for v in ok_variants if v.startswith("llvm")}
        for (v, b), run in same_isa.items():   # load and compile, untimed
            _, warm, _ = run(spp=spp, seed=0x5EED)
            if log:
                log(f"  {_mitsuba_label(v, b)} (in the {b} build's worker): warm-up render {warm:.2f} s")
        for ext in externals:   # a command that fails does so here, before any timing
            _, secs = render_external(ext, scene, spp=max(1, spp // 8), seed=0x5EED)
            if log:
                log(f"  {ext.name}: warm-up run {secs:.2f} s")
        seed = config["seed"]
        lanes = ([(_ours_label(s, i, b), {"renderer": "ours", "strategy": s, "integrator": i, "variant": None,
                                          "build": b},
                   functools.partial(_run_ours, core, spp=spp, strategy=s, integrator=i, seed=seed, threads=threads))
                  for b, core in cores.items() for s in config["strategies"] for i in config["integrators"]],
                 [(_mitsuba_label(v), {"renderer": "mitsuba", "strategy": MITSUBA_STRATEGY, "variant": v},
                   functools.partial(_run_mitsuba, functools.partial(mitsuba_render_timed, v, mscenes[v],
                                                                     threads=threads), spp=spp, seed=seed))
                  for v in ok_variants],
                 [(_mitsuba_label(v, b), {"renderer": "mitsuba", "strategy": MITSUBA_STRATEGY, "variant": v,
                                          "build": b},
                   functools.partial(_run_mitsuba, run, spp=spp, seed=seed))
                  for (v, b), run in same_isa.items()],
                 [(e.name, {"renderer": e.name, "strategy": EXTERNAL_STRATEGY, "variant": None},
                   functools.partial(_run_external, e, scene, spp=spp, seed=seed)) for e in externals])
        order = [x for group in itertools.zip_longest(*lanes) for x in group if x is not None]   # not grouped
        per = _timed_rounds(name, scene, config, order, ref=ref, runs=result["runs"], log=log)
        for v in ok_variants:   # JIT compile time: warm-up minus a typical timed render
            info = infos[v]
            typical = median([x["seconds"] for x in per[_mitsuba_label(v)]])
            info["compile_seconds"] = (max(0.0, info["warmup_seconds"] - typical)
                                       if v.startswith(("llvm", "cuda")) else 0.0)
            result["mitsuba"].setdefault(name, {}).setdefault(label, {})[v] = info
        result["summary"] += [dict(row, rr_depth=scene.rr_depth, max_depth=scene.max_depth, configuration=label)
                              for row in _summary_rows(name, per, ok_variants)]


def _reference(scene, *, kind, spp, variant, threads, cache, log):
    """The error reference (an ``ImageEstimate``) and its JSON record."""
    if kind == "mitsuba":
        ref, took, _ = timed(lambda: reference(scene, spp=spp, variant=variant, threads=threads, cache=cache,
                                               log=log))
        if log and not ref.cached:
            log(f"  reference: rendered Mitsuba {ref.variant} {spp} spp in {took:.1f} s (now cached)")
        return ref, {"spp": ref.spp, "kind": "mitsuba", "variant": ref.variant, "cached": bool(ref.cached),
                     "seconds": took,
                     "label": f"Mitsuba {ref.variant} {ref.spp} spp ({'cached' if ref.cached else 'rendered now'})"}
    r = rt.render(scene, spp=spp, strategy="mis", seed=0xC0FFEE, threads=threads)
    return r, {"spp": spp, "kind": "ours", "variant": None, "cached": False, "seconds": r.seconds,
               "label": f"ours (mis) {spp} spp, rendered now"}


def _warm_mitsuba(scene, variants, *, spp, threads, log):
    """Load ``scene`` in each variant and render it once untimed (JIT compile): ``({variant: Mitsuba scene}, {variant:
    {load_seconds, warmup_seconds}})``."""
    mscenes, infos = {}, {}
    for v in variants:
        mscenes[v], load = load_mitsuba(v, scene, threads)
        _, warm, _ = mitsuba_render_timed(v, mscenes[v], spp=spp, seed=0x5EED)
        infos[v] = {"load_seconds": load, "warmup_seconds": warm}
        if log:
            log(f"  Mitsuba {v}: load {load:.2f} s, warm-up render {warm:.2f} s")
    return mscenes, infos


def _ours_label(strategy, integrator, build) -> str:
    return (f"ours {strategy}" + ("" if integrator == "wavefront" else f" ({integrator})")
            + ("" if build is None else f", {build} build"))


# One timed render of round r by each kind of renderer: the image, the render's own seconds, the call's wall and CPU
# seconds, the rays cast (None where not counted), the seed.
def _run_ours(core, r, *, seed, **args):
    res, wall, cpu = core(seed=seed + r, **args)
    return {"mean": res.mean, "secs": res.seconds, "wall": wall, "cpu": cpu, "rays": res.rays, "seed": seed + r,
            "nonfinite": res.nonfinite_samples}


def _run_mitsuba(run, r, *, spp, seed):   # run: mitsuba_render_timed, or mitsuba_timed in a worker
    s = batch_seeds(seed + r, 1)[0]
    img, wall, cpu = run(spp=spp, seed=s)
    return {"mean": img, "secs": wall, "wall": wall, "cpu": cpu, "rays": None, "seed": s}


def _run_external(ext, scene, r, *, spp, seed):
    s = batch_seeds(seed + r, 1)[0] & 0x7FFFFFFF
    cpu0 = _children_cpu()   # the command's CPU time: its child processes'
    (img, secs), wall, _ = timed(lambda: render_external(ext, scene, spp=spp, seed=s))
    return {"mean": img, "secs": secs, "wall": wall, "cpu": _children_cpu() - cpu0, "rays": None, "seed": s}


def _timed_rounds(name, scene, config, order, *, ref, runs, log) -> dict:
    """``repeats`` rounds of every ``(label, fields, run)`` of ``order``, alternating who goes first: ``{label: [run
    record, ...]}``, each record appended to ``runs`` too."""
    c = config
    per = {}
    for r in range(c["repeats"]):
        for label, fields, run in (order if r % 2 == 0 else order[::-1]):
            out = run(r)
            if out["mean"].shape != (c["height"], c["width"], 3):
                raise RuntimeError(f"{label} returned an image of shape {out['mean'].shape}, expected "
                                   f"{(c['height'], c['width'], 3)}")
            rec = {**_run_record(**out, spp=c["spp"], ref=ref), **fields, "scene": name, "round": r,
                   "spp": c["spp"], "width": c["width"], "height": c["height"], "threads": c["threads"],
                   "max_depth": scene.max_depth, "rr_depth": scene.rr_depth}
            per.setdefault(label, []).append(rec)
            runs.append(rec)
            if log:
                log(f"  round {r + 1}/{c['repeats']} {label}: {rec['paths_per_second'] / 1e6:.3f} Mpaths/s, "
                    f"RMSE {rec['rmse']:.4g}, cpu/wall {rec['cpu_over_wall']:.2f}")
    return per


def _children_cpu() -> float:
    u = resource.getrusage(resource.RUSAGE_CHILDREN)
    return u.ru_utime + u.ru_stime


def _run_record(mean, secs, spp, *, wall, cpu, ref, rays, seed, nonfinite=None) -> dict:
    """The figures of one timed render of image ``mean`` against ``ref``: ``secs`` is the render's own time (ours: the
    core's), ``wall`` and ``cpu`` the call's."""
    paths = mean.shape[0] * mean.shape[1] * spp
    raw = mse(mean, ref.mean)
    corr = mse_corrected(mean, ref.mean, ref.variance, ref.spp)
    good = math.isfinite(corr) and corr > 0 and secs > 0   # else no efficiency (NaN)
    return {"seconds": secs, "call_seconds": wall, "process_seconds": cpu, "paths": paths,
            "paths_per_second": paths / secs, "paths_per_cpu_second": paths / cpu if cpu > 0 else float("nan"),
            "rays": rays, "rays_per_second": None if rays is None else rays / secs, "ms_per_spp": 1e3 * secs / spp,
            "cpu_over_wall": cpu / wall if wall > 0 else float("nan"), "mse": raw, "mse_corrected": corr,
            "rmse": math.sqrt(raw), "efficiency": efficiency(corr, secs) if good else float("nan"), "seed": seed,
            "nonfinite_samples": int(np.sum(~np.isfinite(mean))) if nonfinite is None else nonfinite}


def _summary_rows(name, per, variants) -> list:
    """One row per configuration of scene ``name``: medians over rounds and paired ratios."""
    rows = []
    for label, runs in per.items():
        first = runs[0]
        row = {"scene": name, "label": label, "renderer": first["renderer"], "strategy": first["strategy"],
               "integrator": first.get("integrator"), "variant": first["variant"], "build": first.get("build"),
               "runs": len(runs)}
        for key in _SUMMARY_KEYS:
            vals = [x[key] for x in runs if x[key] is not None]
            row[key] = median(vals) if vals else None
        row["rmse"] = math.sqrt(row["mse"])
        row["rmse_corrected"] = math.sqrt(row["mse_corrected"]) if row["mse_corrected"] > 0 else float("nan")
        row["paths_per_second_spread"] = spread([x["paths_per_second"] for x in runs])
        if row["renderer"] != "mitsuba":   # ours and external renderers, against each variant
            for v in variants:
                # a build for another ISA against Mitsuba's kernels for that ISA, where they ran
                against = next(x for x in (_mitsuba_label(v, row["build"]), _mitsuba_label(v)) if x in per)
                row[f"against_{v}"] = against
                pairs = list(zip(runs, per[against]))
                rounds = [a["paths_per_second"] / b["paths_per_second"] for a, b in pairs]
                # NaN in a round where an MSE was not positive: the median leaves it out
                eff = [a["efficiency"] / b["efficiency"] for a, b in pairs]
                row.update({f"ratio_{v}": median(rounds), f"round_ratios_{v}": rounds,
                            f"cpu_ratio_{v}": median([a["paths_per_cpu_second"] / b["paths_per_cpu_second"]
                                                      for a, b in pairs]),
                            f"efficiency_ratio_{v}": median(eff), f"round_efficiency_ratios_{v}": eff})
        rows.append(row)
    return rows
