"""``rtbench speed [SCENES] [--rays] [--scaling] ...``: ours vs Mitsuba 3, paths/s, rays/s, efficiency.

Default: the render benchmark (``benchmarks.speed.render_benchmark``) on the whole suite,
in Mitsuba's default Russian-roulette configuration (``rr_depth`` 5) and then the seed's
(none; ``--rr-depth`` picks), headed by the suite table (every scene and the geometric
mean of the ratios, per configuration). ``--rays`` runs
the ray-casting micro-benchmark instead, ``--scaling`` the scaling sweeps; give both
to run both, and ``--render`` as well to add the render benchmark to them.

The output ends with one verdict line per speed target the run bears on
(``benchmarks.speed.targets``: met, not met or not judged, with the median ratio and
its 90% interval over the rounds); ``--json`` carries them as ``verdicts``. A target
not met is a measurement, not a failed correctness verdict: the exit status is 0 unless
``--require-targets`` is given, then 1 when a judged target is not met (targets not
judged never fail it).
"""
from __future__ import annotations

import argparse
import json
import math

from benchmarks.commands._scene_args import add_scene_path_args, resolve_scenes
from benchmarks.errors import EXIT_FAIL

HELP = "time ours vs Mitsuba (paired, interleaved): paths/s, rays/s, ms/spp, RMSE, efficiency; --rays, --scaling"


def _list(text):
    return [x.strip() for x in text.split(",") if x.strip()]


def _rr_depths(text):
    """``--rr-depth``: comma-separated depths, ``none`` for no Russian roulette.

    >>> _rr_depths("5,none")
    [5, None]
    """
    out = []
    for x in _list(text):
        if x.lower() == "none":
            out.append(None)
            continue
        try:
            out.append(int(x))
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected depths or 'none', comma-separated, got {text!r}") from None
    if not out:
        raise argparse.ArgumentTypeError("expected at least one configuration")
    return out


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from benchmarks.commands import _args as A
    from benchmarks.speed import DEFAULT_RR_DEPTHS, DEFAULT_STRATEGIES, DEFAULT_VARIANTS, REFERENCE_KINDS

    rr_default = ",".join("none" if v is None else str(v) for v in DEFAULT_RR_DEPTHS)
    A.add_scene_args(parser, nargs="*", what="suite scene(s) of the render benchmark (default: the whole suite)")
    A.add_size_args(parser, width=128)
    A.add_spp_args(parser, default=64)
    A.add_threads_args(parser)
    parser.add_argument("--repeats", type=int, default=5, help="timed paired rounds")
    A.add_strategy_args(parser, default=DEFAULT_STRATEGIES)
    parser.add_argument("--integrators", action=A.ListAction, default=("wavefront",), metavar="I[,I...]",
                        help="our integrators, each strategy timed with each: wavefront (the default), scalar "
                             "(one path at a time, the reference implementation); rows of the others are "
                             "labelled with the integrator")
    A.add_variant_args(parser, default=DEFAULT_VARIANTS)
    parser.add_argument("--variants", dest="variant", help=argparse.SUPPRESS)  # older name
    parser.add_argument("--max-depth", type=int, default=None,
                        help="override the scene's max_depth (default: the scene's, 50 in the suite)")
    parser.add_argument("--rr-depth", type=_rr_depths, default=list(DEFAULT_RR_DEPTHS), metavar="DEPTHS",
                        help=f"Russian-roulette configurations, each measured as its own rows: depths roulette "
                             f"starts at, 'none' for no roulette (default {rr_default}: Mitsuba's default, "
                             f"then the seed's)")
    parser.add_argument("--reference", dest="reference_kind", choices=REFERENCE_KINDS,
                        default=argparse.SUPPRESS, help=argparse.SUPPRESS)  # older name of --reference-kind
    parser.add_argument("--reference-kind", choices=REFERENCE_KINDS, default="mitsuba",
                        help="error reference: cached high-spp Mitsuba (benchmarks.references; rendered once "
                             "if missing) or a high-spp render of ours")
    A.add_reference_spp_arg(parser, default=4096)
    A.add_cache_arg(parser)
    A.add_seed_args(parser)
    parser.add_argument("--render", action="store_true", help="run the render benchmark too with --rays/--scaling")
    parser.add_argument("--rays", action="store_true", help="ray-casting micro-benchmark (ours vs Mitsuba/Embree)")
    parser.add_argument("--triangles", default="100000,1000000",
                        help="mesh sizes of --rays")
    parser.add_argument("--ray-count", type=int, default=1 << 20, help="rays per kind for --rays")
    parser.add_argument("--scaling", action="store_true",
                        help="paths/s vs resolution and threads; cost per ray vs triangle count")
    parser.add_argument("--resolutions", default="32,64,128", help="--scaling sizes")
    parser.add_argument("--scaling-triangles", default="1000,10000,100000,1000000",
                        help="--scaling mesh sizes")
    parser.add_argument("--scaling-spp", type=int, default=16, help="--scaling spp")
    A.add_renderer_arg(parser)  # timed in the same paired rounds as ours and Mitsuba
    parser.add_argument("--require-targets", action="store_true",
                        help="exit 1 when a judged speed target is not met (its median ratio below the "
                             "threshold; benchmarks/PERFORMANCE.md, Targets and verdicts); without it a speed "
                             "target is reported, never a failure")
    A.add_json_arg(parser)
    A.add_quiet_arg(parser)
    add_scene_path_args(parser)


def _f(v, digits=3):
    """``v`` to about ``digits`` significant digits; ``-`` for None, NaN and inf.

    >>> _f(1234.5), _f(0.01234), _f(None), _f(float("nan"))
    ('1,234', '0.0123', '-', '-')
    """
    if v is None or isinstance(v, bool) or not math.isfinite(v):
        return "-"
    v = float(v)
    if v != 0 and (abs(v) >= 1e5 or abs(v) < 1e-3):
        return f"{v:.{digits}g}"
    return f"{v:.{digits}g}" if abs(v) < 1 else f"{v:,.{max(0, digits - len(str(int(abs(v)))))}f}"


def _m(v):
    """A rate in millions."""
    return "-" if v is None or not math.isfinite(v) else f"{v / 1e6:.3f}"


def _r(v):
    """A ratio to two decimals (two significant digits below 0.01); ``-`` for None and non-finite values.

    >>> _r(1.049), _r(0.00123), _r(None), _r(float("nan"))
    ('1.05', '0.0012', '-', '-')
    """
    if v is None or not math.isfinite(v):
        return "-"
    return f"{v:.2g}" if 0 < abs(v) < 0.01 else f"{v:.2f}"


def _round_range(ratios):
    """The lowest and highest of the rounds' ratios, ``1.25-1.73``; ``-`` for none."""
    if not ratios:
        return "-"
    return f"{_r(min(ratios))}-{_r(max(ratios))}"


def _short(variant):
    """``llvm_ad_rgb`` -> ``llvm``."""
    return variant.split("_")[0]


def suite_table(result):
    """The render benchmark's headline ``rich`` table: every scene and the geometric mean,
    per Russian-roulette configuration, for the headline strategy against each variant."""
    from rich.table import Table

    from benchmarks.speed import GEOMEAN

    c, suite = result["config"], result["suite"]
    variants = suite["variants"]
    ours = suite["strategy"] + ("" if suite.get("integrator", "wavefront") == "wavefront"
                                else f" ({suite['integrator']})")
    table = Table(title=f"rtbench speed, suite: ours {ours} vs Mitsuba, {c['width']}x{c['height']}, "
                        f"{c['spp']} spp, {c['threads']} threads, median of {c['repeats']} paired rounds")
    table.add_column("configuration", no_wrap=True)
    table.add_column("scene", no_wrap=True)
    table.add_column(f"ours {ours} Mpaths/s", justify="right")
    for v in variants:
        table.add_column(f"{_short(v)} Mpaths/s", justify="right")
        table.add_column(f"ratio {_short(v)} (cpu)", justify="right")
        table.add_column(f"rounds {_short(v)}", justify="right")
        table.add_column(f"eff. ratio {_short(v)}", justify="right")
    for r in suite["rows"]:
        cells = [r["configuration"], r["scene"] if r["scene"] != GEOMEAN else f"{GEOMEAN} ({r['scenes']})",
                 _m(r["ours_paths_per_second"])]
        for v in variants:
            x, cpu, eff = r[f"ratio_{v}"], r[f"cpu_ratio_{v}"], r[f"efficiency_ratio_{v}"]
            cells += [_m(r[f"mitsuba_paths_per_second_{v}"]), f"{_r(x)} ({_r(cpu)})",
                      _round_range(r.get(f"round_ratios_{v}")), _r(eff)]
        table.add_row(*cells, end_section=r["scene"] == GEOMEAN)
    return table


def render_table(result):
    """The render benchmark's detailed ``rich`` table (every configuration, every renderer)."""
    from rich.table import Table

    c = result["config"]
    variants = result.get("available_variants", [])
    table = Table(title=f"rtbench speed: {c['width']}x{c['height']}, {c['spp']} spp, {c['threads']} threads, "
                        f"median of {c['repeats']} paired rounds")
    for col, kw in (("configuration", {"no_wrap": True}), ("scene", {"no_wrap": True}),
                    ("renderer", {"no_wrap": True}), ("Mpaths/s", {}),
                    ("Mpaths/cpu-s", {}), ("Mrays/s", {}), ("ms/spp", {}), ("spread", {}), ("cpu/wall", {})):
        table.add_column(col, justify="left" if col in ("configuration", "scene", "renderer") else "right", **kw)
    for v in variants:
        table.add_column(f"ratio {_short(v)} (cpu)", justify="right")
    table.add_column("RMSE", justify="right")
    for v in variants:
        table.add_column(f"eff. ratio {_short(v)}", justify="right")
    for r in result["summary"]:
        cells = [r["configuration"], r["scene"], r["label"], _m(r["paths_per_second"]), _m(r["paths_per_cpu_second"]),
                 _m(r["rays_per_second"]), f"{r['ms_per_spp']:.3f}", f"{100 * r['paths_per_second_spread']:.0f}%"
                 if math.isfinite(r["paths_per_second_spread"]) else "-", f"{r['cpu_over_wall']:.2f}"]
        for v in variants:
            x = r.get(f"ratio_{v}")
            cells.append("-" if x is None else f"{_r(x)} ({_r(r[f'cpu_ratio_{v}'])})")
        cells.append(f"{r['rmse']:.4f}")
        for v in variants:
            x = r.get(f"efficiency_ratio_{v}")
            cells.append(_r(x))
        table.add_row(*cells)
    return table


def render_notes(result):
    lines = []
    for name, ref in result["references"].items():
        lines.append(f"{name}: RMSE (raw, at equal spp) against {ref['label']}; efficiency ratio = median over "
                     f"rounds of [1/(MSE*s) ours] / [1/(MSE*s) Mitsuba], MSE with the reference noise removed")
    for name, per in result["mitsuba"].items():
        if name == "versions":
            continue
        for label, per_variant in per.items():
            for v, info in per_variant.items():
                lines.append(f"{name}, {label}: Mitsuba {v} load {info['load_seconds']:.2f} s, warm-up "
                             f"{info['warmup_seconds']:.2f} s, JIT compile (warm-up minus timed render, excluded) "
                             f"{info['compile_seconds']:.2f} s")
    for name, info in result.get("ours", {}).items():
        lines.append(f"{name}: ours BVH build {1e3 * info['build_seconds']:.2f} ms (excluded)")
    if "versions" in result["mitsuba"]:
        vv = result["mitsuba"]["versions"]
        target = vv.get("llvm_target")
        kernels = (f"; llvm_ad_rgb kernels {target['vector_width']}-wide for {target['cpu']}"
                   f"{' (AVX-512)' if target['avx512'] else ''}" if target else "")
        lines.append(f"Mitsuba {vv['mitsuba']}, Dr.Jit {vv['drjit']}, libLLVM {vv['libllvm']}{kernels}")
    for v, why in result.get("skipped_variants", {}).items():
        lines.append(f"Mitsuba {v} skipped: {why}")
    for name, template in result["config"].get("externals", {}).items():
        lines.append(f"{name}: external renderer '{template}'; its seconds are the command's wall clock (process "
                     f"start and scene loading included), its CPU time that of its child processes")
    lines.append("ratio = paths/s ours / Mitsuba, paired per round (cpu: the same on process CPU time); rounds = "
                 "the lowest and highest round's ratio (the geometric mean's: of each round's geometric mean over "
                 "the scenes), the noise a median of few rounds carries; Mrays/s is ours only (Mitsuba does not "
                 "count rays); spread = (max-min)/median of paths/s")
    lines.append("configuration: 'rr_depth N' = Russian roulette from depth N in both renderers (5 is Mitsuba's "
                 "default), 'no RR' = none; geometric mean = of the per-scene ratios (each scene weighs the same)")
    return lines


def rays_tables(result):
    """The ray benchmark's two tables: speed (ours vs Mitsuba), then agreement and build."""
    from rich.table import Table

    c = result["config"]
    mi = bool(result.get("mitsuba", {}).get("variant"))
    speed_table = Table(title=f"ray casting: closest hit, {c['rays']} rays per kind, {c['threads']} threads, "
                              f"median of {c['repeats']}")
    cols = ["triangles", "rays", "ours Mrays/s", "ours Mrays/cpu-s"]
    if mi:
        cols += ["Mitsuba Mrays/s", "Mitsuba Mrays/cpu-s", "ratio", "ratio range"]
    cols += ["ours full Mrays/s"]
    if mi:
        cols += ["full ratio", "full range"]
    for col in cols:
        speed_table.add_column(col, justify="right" if col not in ("rays",) else "left", no_wrap=True)
    checks = Table(title="ray casting: agreement and build")
    cols = ["triangles", "rays"]
    if mi:
        cols += ["hit agree", "t agree", "t rel. median"]
    cols += ["hit frac.", "ours in packets", "our build s/Mtri", "BVH depth"]
    if mi:
        cols += ["Mitsuba load s"]
    for col in cols:
        checks.add_column(col, justify="right" if col not in ("rays",) else "left", no_wrap=True)
    for r in result["rows"]:
        first = [f"{r['triangles']:,}", r["kind"]]
        cells = first + [f"{r['ours_mrays_per_second']:.2f}", _f(r["ours_mrays_per_cpu_second"])]
        if mi:
            cells += [f"{r['mitsuba_mrays_per_second']:.2f}", _f(r["mitsuba_mrays_per_cpu_second"]),
                      f"{r['ratio']:.2f}", f"{r['ratio_min']:.2f}-{r['ratio_max']:.2f}"]
        cells += [f"{r['ours_full_mrays_per_second']:.2f}"]
        if mi:
            cells += [f"{r['ratio_full']:.2f}", f"{r['ratio_full_min']:.2f}-{r['ratio_full_max']:.2f}"]
        speed_table.add_row(*cells)
        cells = list(first)
        if mi:
            cells += [f"{100 * r['agree_hit_agreement']:.4f}%", f"{100 * r['agree_t_agreement']:.3f}%",
                      f"{r['agree_t_rel_median']:.1e}"]
        cells += [f"{r['hit_fraction']:.3f}", f"{100 * r.get('ours_packet_fraction', 0.0):.0f}%",
                  f"{r['build_seconds_per_mtri']:.3f}", str(r["bvh_depth"])]
        if mi:
            cells += [f"{r['mitsuba_load_seconds']:.2f}"]
        checks.add_row(*cells)
    return speed_table, checks


def scaling_tables(result):
    from rich.table import Table

    mi = result["config"]["variant"] is not None
    out = []
    for key, title, first in (("resolution", "paths/s vs resolution", "resolution"),
                              ("threads", "paths/s vs threads", "threads")):
        t = Table(title=f"{title} ({result['config']['scene']}, {result['config']['strategy']}, "
                        f"{result['config']['spp']} spp)")
        cols = [first, "ours Mpaths/s", "ours Mpaths/cpu-s"]
        if key == "threads":
            cols.append("ours speed-up")
        if mi:
            cols += ["Mitsuba Mpaths/s", "Mitsuba Mpaths/cpu-s"] + (["Mitsuba speed-up"] if key == "threads" else [])
            cols.append("ratio")
        for col in cols:
            t.add_column(col, justify="right")
        for r in result[key]:
            cells = [str(r[first]), _m(r["ours_paths_per_second"]), _m(r["ours_paths_per_cpu_second"])]
            if key == "threads":
                cells.append(_f(r.get("ours_speedup")))
            if mi:
                cells += [_m(r["mitsuba_paths_per_second"]), _m(r["mitsuba_paths_per_cpu_second"])]
                if key == "threads":
                    cells.append(_f(r.get("mitsuba_speedup")))
                cells.append(f"{r['ratio']:.2f}")
            t.add_row(*cells)
        out.append(t)
    t = Table(title="cost vs triangle count (random rays; lit torus render 64x64)")
    cols = ["triangles", "ours ns/ray", "BVH depth", "ours Mpaths/s"]
    if mi:
        cols += ["Mitsuba ns/ray", "Mitsuba Mpaths/s", "paths/s ratio"]
    for col in cols:
        t.add_column(col, justify="right")
    for r in result["mesh"]:
        cells = [f"{r['triangles']:,}", f"{r['ours_ns_per_ray']:.0f}", str(r["bvh_depth"]),
                 _m(r["ours_paths_per_second"])]
        if mi:
            cells += [f"{r['mitsuba_ns_per_ray']:.0f}", _m(r["mitsuba_paths_per_second"]), f"{r['ratio']:.2f}"]
        t.add_row(*cells)
    out.append(t)
    return out


def scaling_notes(result):
    lines = []
    for who, fit in result["fits"].items():
        lines.append(f"{who}: fit a + b ln n: b = {fit['b']:.1f} ns per e-fold ({fit['per_doubling']:.1f} ns per "
                     f"doubling of n), r^2 {fit['r2']:.3f}; log-log exponent {fit['loglog_exponent']:.3f} "
                     f"(1 = linear, ~0 = logarithmic)")
    return lines


def run(args) -> int:
    from rich.console import Console

    from benchmarks import speed
    from benchmarks.commands._args import check, resolve_height, resolve_threads

    check(args)
    height, threads = resolve_height(args), resolve_threads(args.threads)
    variants = list(args.variant)
    console = Console(quiet=args.quiet)
    if not console.is_terminal:   # piped or captured: keep each table row on one line
        console = Console(width=220, quiet=args.quiet)
    log = None if args.quiet else (lambda line: console.print(line, style="dim", markup=False, highlight=False))
    do_render = args.render or not (args.rays or args.scaling)
    if (args.scenes or args.scene_files) and not do_render:
        raise ValueError("scenes are only used by the render benchmark: add --render")
    if args.renderer and not do_render:
        raise ValueError("--renderer is only timed by the render benchmark: add --render")
    from benchmarks.external import register_external

    externals = [register_external(cmd) for cmd in args.renderer]
    from mitsuba_scenes import list_scenes

    scenes = resolve_scenes(args, suite_names=args.scenes or [], default=list(list_scenes()))
    jit = [v for v in variants if not v.startswith("scalar")]
    out = {}
    if do_render:
        res = speed.render_benchmark(scenes, width=args.width, height=height,
                                     spp=args.spp, threads=threads, repeats=args.repeats,
                                     strategies=list(args.strategies), integrators=list(args.integrators),
                                     variants=variants, max_depth=args.max_depth,
                                     rr_depths=args.rr_depth,
                                     reference=args.reference_kind, reference_spp=args.reference_spp, seed=args.seed,
                                     cache=args.cache, log=log, externals=externals)
        out["render"] = res
        console.print(suite_table(res))
        console.print(render_table(res))
        for line in render_notes(res):
            console.print(f"  {line}", markup=False, highlight=False)
    if args.rays:
        res = speed.ray_benchmark(triangles=list(args.triangles), rays=args.ray_count, threads=threads,
                                  repeats=args.repeats, variant=jit[0] if jit else None, seed=args.seed, log=log)
        out["rays"] = res
        for table in rays_tables(res):
            console.print(table)
        from reference_tracer import probe

        console.print("  ratio = ours Mrays/s / Mitsuba Mrays/s (median of the rounds' paired ratios; range: the "
                      "lowest and highest round); Mitsuba: "
                      "ray_intersect_preliminary + dr.eval + dr.sync_thread (distance and primitive), kernel compiled "
                      "before timing; ours: core_scene(...).intersect(preliminary=True), the same outputs, timed from "
                      "the Python call to its return as Mitsuba's (chunks of "
                      f"{probe.RAY_CHUNK} rays handed to the threads; in each, rows of camera rays gathered into tiles of 4 x "
                      f"{probe.PACKET_RAYS // 4}, coherent tiles or runs of {probe.PACKET_RAYS} rays traced as packets, the others 8 at a "
                      "time interleaved; float64 copies of the same float32 rays); ours full / full ratio: the same query with our hit point and normal filled "
                      "in, timed in the same rounds; "
                      f"t agree: relative difference <= {res['rows'][0].get('agree_t_rtol', 1e-4):g}",
                      markup=False, highlight=False)
    if args.scaling:
        res = speed.scaling_benchmark(resolutions=list(args.resolutions), spp=args.scaling_spp,
                                      thread_counts=sorted({1, threads}), triangles=list(args.scaling_triangles),
                                      variant=jit[0] if jit else None, threads=threads,
                                      repeats=min(args.repeats, 3), seed=args.seed, log=log)
        out["scaling"] = res
        for t in scaling_tables(res):
            console.print(t)
        for line in scaling_notes(res):
            console.print(f"  {line}", markup=False, highlight=False)
    first = next(iter(out.values()))
    load = first["environment"]["loadavg"]
    console.print(f"  note: {speed.WALL_CLOCK_NOTE}. Load average at start "
                  f"{'/'.join(f'{x:.1f}' for x in load) if load else '?'} on {first['environment']['cpu_count']} "
                  f"cores.", markup=False, highlight=False)
    verdicts = speed.speed_verdicts(out)
    for line in verdict_lines(verdicts):   # final lines: printed with --quiet too
        print(line, flush=True)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(_finite({**out, "verdicts": verdicts}), fh, indent=1, default=_json_default, allow_nan=False)
        print(f"  JSON: {args.json}", flush=True)
    missed = any(v["status"] == "not met" for v in verdicts)
    return EXIT_FAIL if args.require_targets and missed else 0


def verdict_lines(verdicts) -> list:
    """The closing lines of ``rtbench speed``: a heading, then one line per verdict.

    Examples
    --------
    >>> from benchmarks.speed.targets import SCENE_PATHS, judge
    >>> verdict_lines([judge(SCENE_PATHS, "a", [1.6] * 5)])[1]
    '  a paths/s vs Mitsuba llvm_ad_rgb >= 1.5x: met, clearly (1.60x, 90% interval 1.60-1.60, 5 rounds)'
    >>> verdict_lines([])
    ['speed targets: none applies to --scaling']
    """
    if not verdicts:
        return ["speed targets: none applies to --scaling"]
    counts = {s: sum(v["status"] == s for v in verdicts) for s in ("met", "not met", "not judged")}
    renders = "; renders at rr_depth 5" if any(v["benchmark"] == "render" for v in verdicts) else ""
    head = (f"speed targets (median of the paired rounds' ratios, its 90% interval from order statistics{renders}; "
            f"benchmarks/PERFORMANCE.md, Targets and verdicts): " + ", ".join(f"{n} {s}" for s, n in counts.items()))
    return [head] + [f"  {v['line']}" for v in verdicts]


def _finite(x):
    """``x`` with NaN/Inf floats replaced by None (strict JSON)."""
    if isinstance(x, dict):
        return {k: _finite(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_finite(v) for v in x]
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def _json_default(x):
    import numpy as np

    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    return str(x)
