"""The paired render benchmark: ours vs Mitsuba's ``path`` integrator, paths/s and error.

Each scene is rendered by our tracer (each strategy) and by Mitsuba's ``path``
integrator (each available variant) at the same resolution, spp, ``max_depth``, Russian
roulette and thread count, once per Russian-roulette configuration (Mitsuba's default
``rr_depth`` 5 first, then none: :data:`DEFAULT_RR_DEPTHS`). Mitsuba gets one untimed warm-up render per variant first
(JIT kernels compile and are cached; the warm-up's extra time is reported as
``compile_seconds``); ours gets one small warm-up too. Then ``repeats`` rounds, each
running every configuration once, interleaved (ours, Mitsuba, ours, ...) so that a
change in machine load hits both sides of a pair alike. Ratios are medians over the
rounds of the per-round ratio (paired).

External renderers (``externals=``, ``rtbench speed --renderer 'CMD'``,
:mod:`benchmarks.external`) join the same rounds: each run writes the scene's Mitsuba XML
(with the configuration's ``max_depth`` and ``rr_depth``) and times the command's wall
clock, so their time includes process start and scene loading (they are not warmed up
beyond one untimed run); their CPU time is that of the child processes. Their rows carry
the same paired ratios against each Mitsuba variant as ours.

Examples
--------
>>> DEFAULT_STRATEGIES
('mis', 'mixture', 'cosine', 'uniform', 'light')
>>> out = render_benchmark(["cornell_box"], width=16, height=16, spp=4, repeats=1,
...                        strategies=("mis",), variants=("scalar_rgb",),
...                        reference="ours", reference_spp=64)  # doctest: +SKIP
>>> sorted(out["summary"][0])[:3]  # doctest: +SKIP
['cpu_over_wall', 'efficiency', 'label']
"""
from __future__ import annotations

import dataclasses
import math
import resource

import numpy as np

import reference_tracer as rt
from mitsuba_scenes import MitsubaRender, get_scene, known_scenes
from mitsuba_scenes.render import batch_seeds
from reference_tracer import INTEGRATORS
from reference_tracer.probe import core_scene
from reference_tracer.validation import positive_int

from ..constants import MITSUBA_STRATEGY, STRATEGIES, UNBIASED_STRATEGIES
from ..external import STRATEGY as EXTERNAL_STRATEGY
from ..external import render_external
from ..metrics import efficiency, mse, mse_corrected
from ..references import reference

from .common import (available_variants, environment, load_mitsuba, median, mitsuba_render_fn, mitsuba_versions,
                     name_list, spread, timed, use_variant)
from .suite import suite_summary

__all__ = ["DEFAULT_STRATEGIES", "DEFAULT_VARIANTS", "DEFAULT_RR_DEPTHS", "REFERENCE_KINDS", "render_benchmark",
           "rr_label"]

#: our strategies in the order the benchmark runs and lists them: the unbiased ones from
#: ``mis`` (the one matched to Mitsuba's ``path`` integrator) down to the plainest, then
#: the biased ``light``.
DEFAULT_STRATEGIES = (tuple(reversed(UNBIASED_STRATEGIES))
                      + tuple(s for s in STRATEGIES if s not in UNBIASED_STRATEGIES))
#: Mitsuba variants compared against, the bar first.
DEFAULT_VARIANTS = ("llvm_ad_rgb", "scalar_rgb")
#: Russian-roulette configurations measured, in order: Mitsuba's default ``path`` setting
#: (roulette from depth 5, what its users run) first, then the seed's (none).
DEFAULT_RR_DEPTHS = (5, None)
#: where the error reference comes from: a (cached) high-spp Mitsuba render via
#: ``benchmarks.references``, or a high-spp render of ours (``mis``).
REFERENCE_KINDS = ("mitsuba", "ours")

#: the per-run figures summarised (median over rounds) in each summary row.
_SUMMARY_KEYS = ("paths_per_second", "paths_per_cpu_second", "rays_per_second", "ms_per_spp", "seconds",
                 "process_seconds", "cpu_over_wall", "mse", "mse_corrected", "rmse", "efficiency")


def render_benchmark(scenes=("cornell_box",), *, width: int = 128, height: int = 128, spp: int = 64,
                     threads: int = 2, repeats: int = 5, strategies=DEFAULT_STRATEGIES,
                     integrators=("wavefront",), variants=DEFAULT_VARIANTS, max_depth: int | None = None,
                     rr_depths=DEFAULT_RR_DEPTHS, reference: str = "mitsuba", reference_spp: int = 4096, seed: int = 0,
                     cache=None, log=None, externals=()) -> dict:
    """Paired, interleaved render timings of ours vs Mitsuba, with error at equal spp.

    Parameters
    ----------
    scenes : sequence of str
        Suite scene names (``mitsuba_scenes.list_scenes()``).
    width, height, spp, threads, repeats : int, keyword-only
        Image size, samples per pixel, worker threads (both renderers), timed rounds.
    strategies : sequence of str or comma-separated str, keyword-only
        Our strategies (``benchmarks.constants.STRATEGIES``).
    integrators : sequence of str or comma-separated str, keyword-only
        Our integrators (``reference_tracer.INTEGRATORS``), each strategy timed with each
        in every round; the first is the headline's. Rows of ``wavefront`` (the default)
        are labelled ``ours <strategy>``, the others ``ours <strategy> (<integrator>)``.
    variants : sequence of str or comma-separated str, keyword-only
        Mitsuba variants; one that does not work here is skipped (``skipped_variants``).
        An empty list is not allowed.
    max_depth : int or None, keyword-only
        Override the scene's ``max_depth`` (None keeps it; the suite's default is 50).
    rr_depths : sequence of (int, None or 'scene'), keyword-only
        The Russian-roulette configurations, each measured separately and in this order
        (summary rows carry ``rr_depth`` and ``configuration``): an int is the depth
        roulette starts at (Mitsuba's rule), ``None`` disables it, ``'scene'`` keeps the
        scene's own. Default :data:`DEFAULT_RR_DEPTHS`: Mitsuba's default (5), then none.
        Every configuration of a scene is scored against the same reference (roulette
        changes the noise, not the expectation).
    reference : {'mitsuba', 'ours'}, keyword-only
        Error reference: ``mitsuba`` is ``benchmarks.references.reference`` (cached in
        ``$RTBENCH_CACHE``; rendered once if missing, with the first working variant),
        ``ours`` a fresh ``mis`` render of ours. Both carry a per-sample variance, and
        the efficiency uses the MSE with the reference's own noise removed
        (``metrics.mse_corrected``).
    reference_spp : int, keyword-only
        Samples per pixel of the reference (> ``spp``).
    seed : int, keyword-only
        Round ``r`` renders ours with seed ``seed + r`` and Mitsuba with a seed hashed
        from it (``mitsuba_scenes.batch_seeds``).
    cache : path or None, keyword-only
        Reference cache root.
    log : callable or None, keyword-only
        Called with progress lines.
    externals : sequence of benchmarks.external.ExternalRenderer, keyword-only
        External renderers timed in the same rounds (module docstring); rows labelled
        with their names.

    Returns
    -------
    dict
        ``config``, ``environment``, ``mitsuba`` (versions, per-variant load and compile
        seconds, per scene and configuration label), ``skipped_variants``, ``references``
        (per scene), ``runs`` (one record per timed render) and ``summary`` (one row per
        scene, Russian-roulette configuration and renderer configuration: medians
        and, for ours, ``ratio`` / ``efficiency_ratio`` / ``cpu_ratio`` per variant, each
        the median over rounds of the paired per-round ratio, and ``round_ratios`` and
        ``round_efficiency_ratios`` per variant, each round's paths/s and efficiency
        ratio, NaN where an MSE was not positive), and ``suite``, the headline
        (:func:`benchmarks.speed.suite_summary`: every scene and the geometric mean per
        configuration).
    """
    config = _render_config(scenes, width=width, height=height, spp=spp, threads=threads, repeats=repeats,
                            strategies=strategies, integrators=integrators, variants=variants,
                            reference=reference, reference_spp=reference_spp, seed=seed)
    max_depth, rr_depths = _depth_overrides(max_depth, rr_depths)
    config["max_depth"], config["rr_depths"] = max_depth, list(rr_depths)
    config["externals"] = {e.name: e.template for e in externals}

    env_before = environment()
    ok_variants, skipped = available_variants(config["variants"], log)
    result = {"config": config, "environment": env_before, "skipped_variants": skipped, "mitsuba": {},
              "references": {}, "runs": [], "summary": []}
    if ok_variants:
        result["mitsuba"]["versions"] = mitsuba_versions()
    elif reference == "mitsuba":
        raise ValueError(f"no Mitsuba variant of {config['variants']} works here ({skipped}); "
                         f"use reference='ours'")
    for name in config["scenes"]:
        _bench_scene(result, name, config, ok_variants, max_depth=max_depth, rr_depths=rr_depths, cache=cache,
                     log=log, externals=tuple(externals))
    result["available_variants"] = ok_variants
    result["suite"] = suite_summary(result)
    result["environment_after"] = environment()
    return result


def _render_config(scenes, *, width, height, spp, threads, repeats, strategies, integrators, variants, reference,
                   reference_spp, seed) -> dict:
    """The validated settings, as stored under ``config``; ``ValueError`` names a bad one."""
    scenes = name_list("scenes", scenes, known_scenes())
    strategies = name_list("strategies", strategies, STRATEGIES)
    integrators = name_list("integrators", integrators, INTEGRATORS)
    variants = name_list("variants", variants)
    width, height = positive_int("width", width), positive_int("height", height)
    spp, threads = positive_int("spp", spp), positive_int("threads", threads)
    repeats = positive_int("repeats", repeats)
    reference_spp = positive_int("reference_spp", reference_spp, minimum=2)
    seed = positive_int("seed", seed, minimum=0)
    if reference not in REFERENCE_KINDS:
        raise ValueError(f"reference must be one of {REFERENCE_KINDS}, got {reference!r}")
    if reference_spp <= spp:
        raise ValueError(f"reference_spp ({reference_spp}) must exceed spp ({spp})")
    return {"scenes": scenes, "width": width, "height": height, "spp": spp, "threads": threads,
            "repeats": repeats, "strategies": strategies, "integrators": integrators, "variants": variants,
            "reference": reference, "reference_spp": reference_spp, "seed": seed}


def _depth_overrides(max_depth, rr_depths):
    """Validated ``(max_depth, rr_depths)`` overrides (None / ``'scene'`` keep the scene's).

    >>> _depth_overrides(None, (5, None))
    (None, [5, None])
    """
    if max_depth is not None:
        max_depth = int(max_depth)
        if not (max_depth == -1 or max_depth >= 1):
            raise ValueError(f"max_depth must be >= 1 or -1, got {max_depth}")
    rr_depths = [v if v in ("scene", None) else positive_int("rr_depth", v) for v in rr_depths]
    if not rr_depths:
        raise ValueError("rr_depths must name at least one configuration")
    if len(set(map(str, rr_depths))) != len(rr_depths):
        raise ValueError(f"rr_depths has duplicates: {rr_depths}")
    return max_depth, rr_depths


def rr_label(rr_depth) -> str:
    """A Russian-roulette setting as a table label.

    >>> rr_label(5), rr_label(None)
    ('rr_depth 5', 'no RR')
    """
    return "no RR" if rr_depth is None else f"rr_depth {rr_depth}"


def _with_depths(scene, max_depth, rr_depth):
    """``scene`` with ``max_depth`` (None keeps) and ``rr_depth`` (``'scene'`` keeps) set."""
    if max_depth is None and rr_depth == "scene":
        return scene
    return dataclasses.replace(scene, max_depth=scene.max_depth if max_depth is None else max_depth,
                               rr_depth=scene.rr_depth if rr_depth == "scene" else rr_depth)


def _bench_scene(result, name, config, ok_variants, *, max_depth, rr_depths, cache, log, externals=()):
    """Set up, time and summarise one scene in every Russian-roulette configuration."""
    width, height, spp, threads = config["width"], config["height"], config["spp"], config["threads"]
    base = _with_depths(get_scene(name).with_camera_size(width, height), max_depth, "scene")
    # set-up, untimed: our BVH build, the reference (one per scene: roulette keeps the expectation)
    _, build_wall, _ = timed(lambda: core_scene(base))
    ref, record = _reference(base, kind=config["reference"], spp=config["reference_spp"],
                             variant=ok_variants[0] if ok_variants else None, threads=threads, cache=cache,
                             log=log)
    result["references"][name] = record
    result.setdefault("ours", {})[name] = {"build_seconds": float(core_scene(base).build_seconds),
                                           "compile_and_build_seconds": build_wall}
    for rr in rr_depths:
        scene = _with_depths(base, None, rr)
        label = rr_label(scene.rr_depth)
        if log:
            log(f"{name} {width}x{height}, {spp} spp, max_depth {scene.max_depth}, {label}, {threads} threads")
        rt.render(scene, spp=max(1, spp // 8), strategy=config["strategies"][0], seed=0xA11CE, threads=threads)
        mscenes, infos = _warm_mitsuba(scene, ok_variants, spp=spp, threads=threads, log=log)
        _warm_externals(scene, externals, spp=spp, log=log)
        per = _timed_rounds(name, scene, config, ok_variants, mscenes=mscenes, ref=ref, runs=result["runs"],
                            log=log, externals=externals)
        for v in ok_variants:   # JIT compile time: warm-up minus a typical timed render
            info = infos[v]
            typical = median([x["seconds"] for x in per[f"Mitsuba {v}"]])
            info["compile_seconds"] = (max(0.0, info["warmup_seconds"] - typical)
                                       if v.startswith(("llvm", "cuda")) else 0.0)
            result["mitsuba"].setdefault(name, {}).setdefault(label, {})[v] = info
        rows = _summary_rows(name, per, ok_variants)
        for row in rows:
            row.update(rr_depth=scene.rr_depth, max_depth=scene.max_depth, configuration=label)
        result["summary"] += rows


def _reference(scene, *, kind, spp, variant, threads, cache, log):
    """The error reference, an ``ImageEstimate``, and its JSON record.

    Returns
    -------
    ref : benchmarks.references.Reference or reference_tracer.RenderResult
    record : dict
        ``spp``, ``kind``, ``variant``, ``cached``, ``seconds`` (of this call), ``label``.
    """
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
    """Load ``scene`` in each variant and render it once untimed (JIT compile).

    Returns ``({variant: mitsuba scene}, {variant: info})``, info holding
    ``load_seconds`` and ``warmup_seconds``.
    """
    mscenes, infos = {}, {}
    for v in variants:
        mscenes[v], load = load_mitsuba(v, scene, threads)
        mi, _ = use_variant(v)
        _, warm, _ = timed(mitsuba_render_fn(mi, mscenes[v], spp, 0x5EED))
        infos[v] = {"load_seconds": load, "warmup_seconds": warm}
        if log:
            log(f"  Mitsuba {v}: load {load:.2f} s, warm-up render {warm:.2f} s")
    return mscenes, infos


def _warm_externals(scene, externals, *, spp, log):
    """One small untimed run of each external renderer: a command that fails does so here,
    before any timing, with its own message."""
    for ext in externals:
        _, secs = render_external(ext, scene, spp=max(1, spp // 8), seed=0x5EED)
        if log:
            log(f"  {ext.name}: warm-up run {secs:.2f} s")


def _timed_rounds(name, scene, config, variants, *, mscenes, ref, runs, log, externals=()) -> dict:
    """``repeats`` interleaved rounds of every configuration; ``{label: [run, ...]}``.

    Each run record is appended to ``runs`` as well.
    """
    spp, threads, seed = config["spp"], config["threads"], config["seed"]
    ours = [(s, i) for s in config["strategies"] for i in config.get("integrators", ["wavefront"])]
    width, height, repeats = config["width"], config["height"], config["repeats"]
    settings = {"max_depth": scene.max_depth, "rr_depth": scene.rr_depth}
    per = {}   # label -> list of run dicts, one per round
    for r in range(repeats):
        s_ours = seed + r
        s_mi = batch_seeds(seed + r, 1)[0]
        # interleave: ours strategy, Mitsuba variant, ours strategy, ...
        order = []
        for k in range(max(len(ours), len(variants), len(externals))):
            if k < len(ours):
                order.append(("ours", ours[k]))
            if k < len(variants):
                order.append(("mitsuba", variants[k]))
            if k < len(externals):
                order.append(("external", externals[k]))
        if r % 2 == 1:
            order.reverse()   # alternate who goes first
        for renderer, what in order:
            if renderer == "ours":
                strategy, integrator = what
                rec = _ours_run(scene, spp=spp, strategy=strategy, integrator=integrator, seed=s_ours,
                                threads=threads, ref=ref)
                rec.update(strategy=strategy, integrator=integrator, variant=None, seed=s_ours)
                what = strategy if integrator == "wavefront" else f"{strategy} ({integrator})"
            elif renderer == "external":
                rec = _external_run(what, scene, spp=spp, seed=s_mi & 0x7FFFFFFF, ref=ref)
                rec.update(strategy=EXTERNAL_STRATEGY, variant=None, seed=s_mi & 0x7FFFFFFF)
                renderer, what = what.name, what.name
            else:
                rec = _mitsuba_run(what, mscenes[what], spp=spp, seed=s_mi, threads=threads, ref=ref,
                                   shape=(height, width, 3))
                rec.update(strategy=MITSUBA_STRATEGY, variant=what, seed=s_mi)
            rec.update(scene=name, renderer=renderer, round=r, spp=spp, width=width, height=height,
                       threads=threads, **settings)
            label = f"ours {what}" if renderer == "ours" else f"Mitsuba {what}" if renderer == "mitsuba" else what
            per.setdefault(label, []).append(rec)
            runs.append(rec)
            if log:
                log(f"  round {r + 1}/{repeats} {label}: {rec['paths_per_second'] / 1e6:.3f} Mpaths/s, "
                    f"RMSE {rec['rmse']:.4g}, cpu/wall {rec['cpu_over_wall']:.2f}")
    return per


def _ours_run(scene, *, spp, strategy, integrator="wavefront", seed, threads, ref):
    """One timed render of ours; its run record (:func:`_run_record`)."""
    r, wall, cpu = timed(lambda: rt.render(scene, spp=spp, strategy=strategy, seed=seed, threads=threads,
                                           integrator=integrator))
    return _run_record(r, wall=wall, cpu=cpu, ref=ref, rays=r.rays, nonfinite=r.nonfinite_samples)


def _mitsuba_run(variant, mscene, *, spp, seed, threads, ref, shape):
    """One timed render of Mitsuba (wall time of the call); its run record."""
    mi, _ = use_variant(variant, threads)
    img, wall, cpu = timed(mitsuba_render_fn(mi, mscene, spp, seed))
    if img.shape != shape:
        raise RuntimeError(f"Mitsuba returned an image of shape {img.shape}, expected {shape}")
    # one batch: no per-sample variance (NaN, as MitsubaRender documents for one batch)
    est = MitsubaRender(mean=img, variance=np.full_like(img, np.nan), spp=spp, seconds=wall, variant=variant,
                        seed=seed, threads=threads, batch_spp=[spp], batch_seeds=[seed])
    return _run_record(est, wall=wall, cpu=cpu, ref=ref, rays=None, nonfinite=int(np.sum(~np.isfinite(img))))


def _external_run(ext, scene, *, spp, seed, ref):
    """One timed run of an external renderer (wall time of the command); its run record.

    The CPU time is the child processes' (``RUSAGE_CHILDREN``), not this process's."""
    def children_cpu():
        u = resource.getrusage(resource.RUSAGE_CHILDREN)
        return u.ru_utime + u.ru_stime

    cpu0 = children_cpu()
    (img, secs), wall, _ = timed(lambda: render_external(ext, scene, spp=spp, seed=seed))
    est = rt.ImageEstimate(mean=img, variance=np.full_like(img, np.nan), spp=spp, seconds=secs, source=ext.name)
    return _run_record(est, wall=wall, cpu=children_cpu() - cpu0, ref=ref, rays=None,
                       nonfinite=int(np.sum(~np.isfinite(img))))


def _run_record(est, *, wall, cpu, ref, rays, nonfinite) -> dict:
    """The figures of one timed render ``est`` (an ``ImageEstimate``) against ``ref``.

    ``est.seconds`` is the render's own time (ours: the core's; Mitsuba's: the call's),
    ``wall`` and ``cpu`` the call's wall and process CPU time, ``rays`` the rays cast
    (None when not counted).
    """
    secs = est.seconds
    paths = est.height * est.width * est.spp
    raw = mse(est.mean, ref.mean)
    corr = mse_corrected(est.mean, ref.mean, ref.variance, ref.spp)
    return {"seconds": secs, "call_seconds": wall, "process_seconds": cpu, "paths": paths,
            "paths_per_second": paths / secs, "paths_per_cpu_second": paths / cpu if cpu > 0 else float("nan"),
            "rays": rays, "rays_per_second": None if rays is None else rays / secs,
            "ms_per_spp": 1e3 * secs / est.spp,
            "cpu_over_wall": cpu / wall if wall > 0 else float("nan"), "mse": raw, "mse_corrected": corr,
            "rmse": math.sqrt(raw), "efficiency": _efficiency(corr, secs), "nonfinite_samples": nonfinite}


def _efficiency(mse_value, seconds):
    """1 / (MSE * seconds); NaN when the (noise-corrected) MSE is not positive."""
    if not (math.isfinite(mse_value) and mse_value > 0 and seconds > 0):
        return float("nan")
    return efficiency(mse_value, seconds)


def _summary_rows(name, per, variants) -> list:
    """One row per configuration of scene ``name``: medians over rounds and paired ratios."""
    rows = []
    for label, runs in per.items():
        row = {"scene": name, "label": label, "renderer": runs[0]["renderer"],
               "strategy": runs[0]["strategy"], "integrator": runs[0].get("integrator"),
               "variant": runs[0]["variant"], "runs": len(runs)}
        for key in _SUMMARY_KEYS:
            vals = [x[key] for x in runs if x[key] is not None]
            row[key] = median(vals) if vals else None
        row["rmse"] = math.sqrt(row["mse"])
        row["rmse_corrected"] = math.sqrt(row["mse_corrected"]) if row["mse_corrected"] > 0 else float("nan")
        row["paths_per_second_spread"] = spread([x["paths_per_second"] for x in runs])
        if row["renderer"] != "mitsuba":   # ours and external renderers, against each variant
            for v in variants:
                pairs = list(zip(runs, per[f"Mitsuba {v}"]))
                rounds = [a["paths_per_second"] / b["paths_per_second"] for a, b in pairs]
                row[f"ratio_{v}"] = median(rounds)
                row[f"round_ratios_{v}"] = rounds  # per round, in round order: their spread is the noise
                row[f"cpu_ratio_{v}"] = median([a["paths_per_cpu_second"] / b["paths_per_cpu_second"]
                                                for a, b in pairs])
                # NaN in a round where an MSE was not positive; the median leaves it out
                efficiency = [a["efficiency"] / b["efficiency"] for a, b in pairs]
                row[f"efficiency_ratio_{v}"] = median(efficiency)
                row[f"round_efficiency_ratios_{v}"] = efficiency
        rows.append(row)
    return rows
