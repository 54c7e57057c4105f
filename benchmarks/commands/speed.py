"""``rtbench speed [SCENES] [--rays] [--scaling] [--isa ISA] ...``: ours vs Mitsuba 3, paths/s, rays/s, efficiency,
ending with one verdict line per speed target (benchmarks/PERFORMANCE.md, How to measure)."""
from __future__ import annotations

import argparse
import math
from pathlib import Path

from benchmarks.commands import _args as A
from benchmarks.errors import EXIT_FAIL

HELP = "time ours vs Mitsuba (paired, interleaved): paths/s, rays/s, ms/spp, RMSE, efficiency; --rays, --scaling"


def _rr_depth(text: str):
    """One value of ``--rr-depth`` (a list, :class:`benchmarks.commands._args.ListAction`): a depth, or None
    for ``none`` (no Russian roulette)."""
    if text.lower() == "none":
        return None
    try:
        return int(text)
    except ValueError:
        raise ValueError(f"--rr-depth: expected depths or 'none', comma-separated, got {text!r}") from None


def add_arguments(parser) -> None:
    from benchmarks.speed import DEFAULT_RR_DEPTHS, DEFAULT_STRATEGIES, DEFAULT_VARIANTS, REFERENCE_KINDS
    from benchmarks.speed.builds import ISAS

    rr_default = ",".join("none" if v is None else str(v) for v in DEFAULT_RR_DEPTHS)
    A.add_scene_args(parser, what="suite scene(s) of the render benchmark (default: the whole suite)")
    A.add_size_args(parser, width=128)
    A.add_spp_args(parser, default=64)
    A.add_threads_args(parser)
    parser.add_argument("--repeats", type=int, default=5, help="timed paired rounds")
    A.add_strategy_args(parser, default=DEFAULT_STRATEGIES)
    parser.add_argument("--integrators", action=A.ListAction, default=("wavefront",), metavar="I[,I...]",
                        help="our integrators (wavefront, scalar), each strategy timed with each")
    A.add_variant_args(parser, default=DEFAULT_VARIANTS)
    parser.add_argument("--variants", dest="variant", help=argparse.SUPPRESS)  # older name
    parser.add_argument("--max-depth", type=int, default=None,
                        help="override the scene's max_depth (default: the scene's, 50 in the suite)")
    parser.add_argument("--rr-depth", action=A.ListAction, item=_rr_depth, default=tuple(DEFAULT_RR_DEPTHS),
                        metavar="DEPTHS",
                        help=f"Russian-roulette configurations, each its own rows: depths roulette starts at, "
                             f"'none' for none (default {rr_default}: Mitsuba's default, then the seed's)")
    parser.add_argument("--reference", dest="reference_kind", choices=REFERENCE_KINDS,
                        default=argparse.SUPPRESS, help=argparse.SUPPRESS)  # older name of --reference-kind
    parser.add_argument("--reference-kind", choices=REFERENCE_KINDS, default="mitsuba",
                        help="error reference: a cached high-spp Mitsuba render, or a high-spp render of ours")
    A.add_reference_spp_arg(parser, default=4096)
    A.add_cache_arg(parser)
    A.add_seed_args(parser)
    parser.add_argument("--isa", choices=sorted(ISAS), default=None,
                        help="also time our core built for this instruction set, with its own rows, against Mitsuba's "
                             "kernels for that set where they are narrower than this CPU's (default: none)")
    parser.add_argument("--render", action="store_true", help="run the render benchmark too with --rays/--scaling")
    parser.add_argument("--rays", action="store_true", help="ray-casting micro-benchmark (ours vs Mitsuba/Embree)")
    parser.add_argument("--triangles", default="100000,1000000", help="mesh sizes of --rays")
    parser.add_argument("--ray-count", type=int, default=1 << 20, help="rays per kind for --rays")
    parser.add_argument("--scaling", action="store_true", help="paths/s against image size, depth, threads, triangles")
    parser.add_argument("--resolutions", default="32,64,128,256,512", help="--scaling image sizes")
    parser.add_argument("--scaling-depths", default="2,5,10,20,50", help="--scaling maximum depths")
    parser.add_argument("--scaling-triangles", default="1000,10000,100000,1000000", help="--scaling mesh sizes")
    parser.add_argument("--scaling-spp", type=int, default=16, help="--scaling spp")
    parser.add_argument("--svg", metavar="PATH", default=None, help="draw the --scaling curves (default: none)")
    A.add_renderer_arg(parser)  # timed in the same paired rounds as ours and Mitsuba
    parser.add_argument("--require-targets", action="store_true",
                        help="exit 1 when a judged speed target is not met (else a target is reported only)")
    A.add_json_arg(parser)
    A.add_quiet_arg(parser)
    A.add_scene_path_args(parser)


def _m(v):
    return "-" if v is None or not math.isfinite(v) else f"{v / 1e6:.3f}"


def _r(v):
    """A ratio to two decimals (two significant digits below 0.01); ``-`` for None and non-finite values."""
    return "-" if v is None or not math.isfinite(v) else f"{v:.2g}" if 0 < abs(v) < 0.01 else f"{v:.2f}"


def _range(ratios):
    return f"{_r(min(ratios))}-{_r(max(ratios))}" if ratios else "-"


def _col(heading, key, fmt="{:.2f}"):
    """A column of :func:`_table`: each row's ``key`` through ``fmt`` (a format string or a function)."""
    return heading, lambda r: "-" if r.get(key) is None else fmt(r[key]) if callable(fmt) else fmt.format(r[key])


def _table(title, columns, rows, *, left=1, end_section=lambda r: False):
    """A ``rich`` table: ``columns`` are ``(heading, cell of a row)``, the first ``left`` left-aligned."""
    from rich.markup import escape
    from rich.table import Table

    table = Table(title=title)
    for k, (heading, _) in enumerate(columns):
        table.add_column(heading, justify="left" if k < left else "right", no_wrap=k < left)
    for r in rows:  # cells are text: a scene file's name may hold brackets
        table.add_row(*(escape(str(cell(r))) for _, cell in columns), end_section=end_section(r))
    return table


def _ratio_col(v, short):
    """Against variant ``v`` (named ``short``): the ratio of paths/s with the ratio on CPU time in brackets."""
    return (f"ratio {short} (cpu)",
            lambda r: "-" if r.get(f"ratio_{v}") is None else f"{_r(r[f'ratio_{v}'])} ({_r(r[f'cpu_ratio_{v}'])})")


def _efficiency_col(v, short):
    """Against variant ``v`` (named ``short``): the efficiency ratio."""
    return _col(f"eff. ratio {short}", f"efficiency_ratio_{v}", _r)


def suite_table(result, build=None):
    """The render benchmark's headline table: every scene and the geometric mean, per Russian-roulette configuration,
    for the headline strategy (of ``build``) against each variant."""
    from benchmarks.speed import GEOMEAN

    c, suite = result["config"], result["suite"] if build is None else result["build_suites"][build]
    ours = (suite["strategy"] + ("" if suite.get("integrator", "wavefront") == "wavefront"
                                 else f" ({suite['integrator']})") + ("" if build is None else f", {build} build"))
    columns = [_col("configuration", "configuration", str),
               ("scene", lambda r: r["scene"] if r["scene"] != GEOMEAN else f"{GEOMEAN} ({r['scenes']})"),
               _col(f"ours {ours} Mpaths/s", "ours_paths_per_second", _m)]
    for v in suite["variants"]:
        against = suite.get("against", {}).get(v, f"Mitsuba {v}")   # e.g. "Mitsuba llvm_ad_rgb, avx2 kernels"
        short = v.split("_")[0] + against[len(f"Mitsuba {v}"):]
        columns += [_col(f"{short} Mpaths/s", f"mitsuba_paths_per_second_{v}", _m), _ratio_col(v, short),
                    _col(f"rounds {short}", f"round_ratios_{v}", _range), _efficiency_col(v, short)]
    return _table(f"rtbench speed, suite: ours {ours} vs Mitsuba, {c['width']}x{c['height']}, {c['spp']} spp, "
                  f"{c['threads']} threads, median of {c['repeats']} paired rounds", columns, suite["rows"], left=2,
                  end_section=lambda r: r["scene"] == GEOMEAN)


def render_table(result):
    """The render benchmark's detailed table (every configuration, every renderer)."""
    c, variants = result["config"], result.get("available_variants", [])
    columns = [_col("configuration", "configuration", str), _col("scene", "scene", str), _col("renderer", "label", str),
               _col("Mpaths/s", "paths_per_second", _m), _col("Mpaths/cpu-s", "paths_per_cpu_second", _m),
               _col("Mrays/s", "rays_per_second", _m), _col("ms/spp", "ms_per_spp", "{:.3f}"),
               _col("spread", "paths_per_second_spread", lambda x: f"{100 * x:.0f}%" if math.isfinite(x) else "-"),
               _col("cpu/wall", "cpu_over_wall")]
    columns += [_ratio_col(v, v.split("_")[0]) for v in variants]
    columns += [_col("RMSE", "rmse", "{:.4f}")]
    columns += [_efficiency_col(v, v.split("_")[0]) for v in variants]
    return _table(f"rtbench speed: {c['width']}x{c['height']}, {c['spp']} spp, {c['threads']} threads, median of "
                  f"{c['repeats']} paired rounds", columns, result["summary"], left=3)


def render_notes(result):
    """The lines under the render tables: references, Mitsuba's load and compile times, what the columns mean."""
    c, mitsuba = result["config"], result["mitsuba"]
    lines = [f"{name}: RMSE (raw, at equal spp) against {ref['label']}; efficiency ratio = median over rounds of "
             f"[1/(MSE*s) ours] / [1/(MSE*s) Mitsuba], MSE with the reference noise removed"
             for name, ref in result["references"].items()]
    lines += [f"{name}, {label}: Mitsuba {v} load {info['load_seconds']:.2f} s, warm-up {info['warmup_seconds']:.2f} "
              f"s, JIT compile (warm-up minus timed render, excluded) {info['compile_seconds']:.2f} s"
              for name, per in mitsuba.items() if name != "versions"
              for label, per_variant in per.items() for v, info in per_variant.items()]
    lines += [f"{name}: ours BVH build {1e3 * info['build_seconds']:.2f} ms (excluded)"
              for name, info in result.get("ours", {}).items()]
    if "versions" in mitsuba:
        vv, target = mitsuba["versions"], mitsuba["versions"].get("llvm_target")
        lines.append(f"Mitsuba {vv['mitsuba']}, Dr.Jit {vv['drjit']}, libLLVM {vv['libllvm']}" + (
            f"; llvm_ad_rgb kernels {target['vector_width']}-wide for {target['cpu']}"
            f"{' (AVX-512)' if target['avx512'] else ''}" if target else ""))
    lines += [f"Mitsuba {v} skipped: {why}" for v, why in result.get("skipped_variants", {}).items()]
    lines += [f"{name}: external renderer '{template}'; its seconds are the command's wall clock (process start and "
              f"scene loading included), its CPU time that of its child processes"
              for name, template in c.get("externals", {}).items()]
    lines += [f"ours ..., {name} build: our core built for {name} ({module}), in a worker process, in the same rounds"
              for name, module in c.get("builds", {}).items()]
    targets = result.get("mitsuba_targets", {})
    lines += [f"{row['label']}: Mitsuba in the {row['build']} build's worker, Dr.Jit's kernels compiled for "
              f"{targets.get(row['build'], row['build'])} (what a CPU of that instruction set runs; "
              f"Embree inside keeps this CPU's); the {row['build']} build's ratios pair with it"
              for row in {r["label"]: r for r in result["summary"]
                          if r["renderer"] == "mitsuba" and r.get("build")}.values()]
    lines += [f"Mitsuba with {b} kernels could not run here ({why}): the {b} build pairs with this CPU's kernels"
              for b, why in result.get("mitsuba_targets_skipped", {}).items()]
    return lines + ["ratio = paths/s ours / Mitsuba, the median of the paired rounds' ratios (cpu: on CPU time); "
                    "rounds = the lowest and highest round's; spread = (max-min)/median of paths/s; 'rr_depth N' = "
                    "roulette from depth N in both; benchmarks/PERFORMANCE.md, Reading the ratios"]


def rays_tables(result):
    """The ray benchmark's two tables: speed (ours vs Mitsuba), then agreement and build."""
    c, mi = result["config"], bool(result.get("mitsuba", {}).get("variant"))
    first = [_col("triangles", "triangles", "{:,}"),
             ("rays", lambda r: r["kind"] + ("" if r.get("build") is None else f", {r['build']} build"))]
    speed = first + [_col("ours Mrays/s", "ours_mrays_per_second"),
                     _col("ours Mrays/cpu-s", "ours_mrays_per_cpu_second")]
    speed += [_col("Mitsuba Mrays/s", "mitsuba_mrays_per_second"), _col("Mitsuba Mrays/cpu-s",
              "mitsuba_mrays_per_cpu_second"), _col("ratio", "ratio"), _col("ratio range", "round_ratios", _range)
              ] if mi else []
    speed += [_col("ours full Mrays/s", "ours_full_mrays_per_second")]
    speed += [_col("full ratio", "ratio_full"), _col("full range", "round_ratios_full", _range)] if mi else []
    checks = first + ([_col("hit agree", "agree_hit_agreement", lambda x: f"{100 * x:.4f}%"),
                       _col("t agree", "agree_t_agreement", lambda x: f"{100 * x:.3f}%"),
                       _col("t rel. median", "agree_t_rel_median", "{:.1e}")] if mi else [])
    checks += [_col("hit frac.", "hit_fraction", "{:.3f}"), _col("ours in packets", "ours_packet_fraction",
               lambda x: f"{100 * x:.0f}%"), _col("our build s/Mtri", "build_seconds_per_mtri", _r),
               _col("BVH depth", "bvh_depth", str), _col("our tree B/tri", "bvh_bytes_per_triangle", "{:.0f}"),
               _col("our RSS +MiB", "ours_rss_growth_mib", "{:.0f}")]
    checks += [_col("Mitsuba load s", "mitsuba_load_seconds"),
               _col("Mitsuba RSS +MiB", "mitsuba_rss_growth_mib", "{:.0f}")] if mi else []
    checks += [_col("peak RSS MiB", "peak_rss_mib", "{:.0f}")]
    return (_table(f"ray casting: closest hit, {c['rays']} rays per kind, {c['threads']} threads, median of "
                   f"{c['repeats']}", speed, result["rows"], left=2),
            _table("ray casting: agreement and build", checks, result["rows"], left=2))


def rays_note(result) -> str:
    from reference_tracer import probe

    return ("ratio = ours / Mitsuba Mrays/s, median of the paired rounds (range: lowest, highest); both sides' "
            "distance and primitive (ray_intersect_preliminary; intersect(preliminary=True), packets of "
            f"{probe.PACKET_RAYS} in the installed core"
            + (", of their own width in the other builds" if result["config"].get("builds") else "")
            + "), timed from the Python call to its return; full: with our hit point and normal; "
            f"t agree: relative difference <= {result['rows'][0].get('agree_t_rtol', 1e-4):g}"
            + "".join(f"; the {b} build's rows pair with Mitsuba's kernels compiled for {target} in its worker "
                      f"(Embree inside keeps this CPU's instruction set)"
                      for b, target in result.get("mitsuba", {}).get("targets", {}).items())
            + "".join(f"; Mitsuba with {b} kernels could not run here ({why}): the {b} build's rows pair with this "
                      f"CPU's kernels" for b, why in result.get("mitsuba", {}).get("targets_skipped", {}).items()))


def scaling_tables(result):
    """The scaling tables: paths/s against each axis, then cost against triangle count."""
    from benchmarks.speed.scaling import AXES

    c, out = result["config"], []
    who = ("ours", "Mitsuba") if c["variant"] is not None else ("ours",)
    for key, field, label in AXES:
        columns = [_col(label, field, str)]
        for w in who:
            columns += [_col(f"{w} Mpaths/s", f"{w.lower()}_paths_per_second", _m),
                        _col(f"{w} Mpaths/cpu-s", f"{w.lower()}_paths_per_cpu_second", _m)]
            columns += [_col(f"{w} speed-up", f"{w.lower()}_speedup", _r)] if key == "threads" else []
        columns += [_col("ratio", "ratio", _r)] if len(who) > 1 else []
        out.append(_table(f"paths/s vs {label} ({c['scene']}, {c['strategy']}, {c['spp']} spp; else "
                          f"{result['threads'][0]['resolution']}^2, {c['threads']} threads)", columns, result[key]))
    columns = [_col("triangles", "triangles", "{:,}"), _col("ours build s", "build_seconds", "{:.3f}"),
               _col("ours ns/ray", "ours_ns_per_ray", "{:.0f}"), _col("BVH depth", "bvh_depth", str),
               _col("ours Mpaths/s", "ours_paths_per_second", _m)]
    columns += [_col("Mitsuba load s", "mitsuba_load_seconds", "{:.3f}"), _col("Mitsuba ns/ray", "mitsuba_ns_per_ray",
                "{:.0f}"), _col("Mitsuba Mpaths/s", "mitsuba_paths_per_second", _m),
                _col("paths/s ratio", "ratio", _r)] if len(who) > 1 else []
    return out + [_table(f"cost vs triangle count (random rays; lit torus render 64x64, {c['mesh_spp']} spp; build "
                         f"and load: our BVH, Mitsuba's whole scene)", columns, result["mesh"])]


def scaling_notes(result):
    return [f"{who}: fit a + b ln n: b = {fit['b']:.1f} ns per e-fold ({fit['per_doubling']:.1f} ns per doubling of "
            f"n), r^2 {fit['r2']:.3f}; log-log exponent {fit['loglog_exponent']:.3f} (1 = linear, ~0 = logarithmic)"
            for who, fit in result["fits"].items()]


def scaling_svg(result) -> bytes:
    """The scaling curves as an SVG: paths/s against each axis and against triangle count, ours beside Mitsuba."""
    from matplotlib.figure import Figure

    from benchmarks.speed.scaling import AXES
    from reports.plots import figure_bytes

    fig = Figure(figsize=(9, 7))
    fig.subplots_adjust(hspace=0.4, wspace=0.3)
    for k, (key, field, label) in enumerate([*AXES, ("mesh", "triangles", "triangles (lit torus)")]):
        ax = fig.add_subplot(2, 2, k + 1)
        for who, style in (("ours", {"marker": "o"}), ("mitsuba", {"marker": "s", "linestyle": "--"})):
            points = [(r[field], r[f"{who}_paths_per_second"] / 1e6) for r in result[key]
                      if f"{who}_paths_per_second" in r]
            if points:
                ax.plot(*zip(*points), label="ours" if who == "ours" else f"Mitsuba {result['config']['variant']}",
                        gid=f"{key}-{who}", **style)
        ax.set_xscale("log" if key != "threads" else "linear")
        ax.minorticks_off()
        ax.set_xticks([r[field] for r in result[key]], [f"{r[field]:,}" for r in result[key]])
        ax.set(xlabel=label, ylabel="Mpaths/s", title=f"paths/s vs {label}")
        ax.grid(True, alpha=0.35)
        ax.legend(fontsize=8)
    fig.suptitle(f"rtbench speed --scaling ({result['config']['scene']}, {result['config']['strategy']})")
    return figure_bytes(fig, "svg")


def run(args) -> int:
    from benchmarks import speed
    from benchmarks.external import register_external
    from benchmarks.store.jsonio import write_json
    from mitsuba_scenes import list_scenes
    from reference_tracer.imageio import atomic_write

    threads = A.resolve_threads(args.threads)
    console = A.wide_console(220, quiet=args.quiet)
    log = None if args.quiet else (lambda line: console.print(line, style="dim", markup=False, highlight=False))
    do_render = args.render or not (args.rays or args.scaling)
    for given, what in ((args.scenes or args.scene_files, "scenes are only used by the render benchmark"),
                        (args.renderer, "--renderer is only timed by the render benchmark")):
        if given and not do_render:
            raise ValueError(f"{what}: add --render")
    if args.isa and not (do_render or args.rays):
        raise ValueError("--isa times the render and ray benchmarks: add --render or --rays")
    if args.svg and not args.scaling:
        raise ValueError("--svg draws the --scaling curves: add --scaling")
    externals = [register_external(cmd) for cmd in args.renderer]
    scenes = A.resolve_scenes(args, suite_names=args.scenes, default=list_scenes())
    if do_render:
        _check_render_options(args, scenes, threads)
    _check_mesh_sizes(args)
    builds = _build_isa(args.isa, log) if args.isa else {}
    jit = next((v for v in args.variant if not v.startswith("scalar")), None)

    def show(tables, lines):
        for table in tables:
            console.print(table)
        for line in lines:
            console.print(f"  {line}", markup=False, highlight=False)

    out = {}
    if do_render:
        out["render"] = res = speed.render_benchmark(
            scenes, width=args.width, height=args.height, spp=args.spp, threads=threads, repeats=args.repeats,
            strategies=list(args.strategies), integrators=list(args.integrators), variants=list(args.variant),
            max_depth=args.max_depth, rr_depths=args.rr_depth, reference=args.reference_kind,
            reference_spp=args.reference_spp, seed=args.seed, cache=args.cache, log=log, externals=externals,
            builds=builds)
        show([*(suite_table(res, build) for build in (None, *builds)), render_table(res)], render_notes(res))
    if args.rays:
        out["rays"] = res = speed.ray_benchmark(triangles=list(args.triangles), rays=args.ray_count, threads=threads,
                                                repeats=args.repeats, variant=jit, seed=args.seed, log=log,
                                                builds=builds)
        show(rays_tables(res), [rays_note(res)])
    if args.scaling:
        out["scaling"] = res = speed.scaling_benchmark(
            resolutions=list(args.resolutions), depths=list(args.scaling_depths), spp=args.scaling_spp,
            thread_counts=sorted({1, threads}), triangles=list(args.scaling_triangles), variant=jit, threads=threads,
            repeats=min(args.repeats, 3), seed=args.seed, log=log)
        if args.svg:
            atomic_write(args.svg, scaling_svg(res))
        show(scaling_tables(res), scaling_notes(res) + ([f"SVG: {args.svg}"] if args.svg else []))
    env = next(iter(out.values()))["environment"]
    load = "/".join(f"{x:.1f}" for x in env["loadavg"]) if env["loadavg"] else "?"
    show([], [f"note: {speed.WALL_CLOCK_NOTE}. Load average at start {load} on {env['cpu_count']} cores."])
    verdicts = speed.speed_verdicts(out)
    for line in speed.verdict_lines(verdicts):   # final lines: printed with --quiet too
        print(line, flush=True)
    if args.json:
        write_json(args.json, {**out, "verdicts": verdicts})
        print(f"  JSON: {args.json}", flush=True)
    missed = any(v["status"] == "not met" for v in verdicts)
    return EXIT_FAIL if args.require_targets and missed else 0


#: how :func:`benchmarks.speed.check_depths` names the settings it refuses: by this command's options
_DEPTH_OPTIONS = {"spp": "--spp", "reference_spp": "--reference-spp", "max_depth": "--max-depth",
                  "rr_depths": "--rr-depth"}


def _check_render_options(args, scenes, threads: int) -> None:
    """Refuse a bad option of the render benchmark before anything is built (an ``--isa`` build takes
    minutes) or rendered, in the command's words (``ValueError`` naming the option); the rest as
    :func:`benchmarks.speed.render_config` checks it (names of scenes, strategies, integrators)."""
    from benchmarks import speed

    speed.check_depths(spp=args.spp, reference_spp=args.reference_spp, max_depth=args.max_depth,
                       rr_depths=args.rr_depth, names=_DEPTH_OPTIONS)
    speed.render_config(scenes, width=args.width, height=args.height, spp=args.spp, threads=threads,
                        repeats=args.repeats, strategies=list(args.strategies), integrators=list(args.integrators),
                        variants=list(args.variant), max_depth=args.max_depth, rr_depths=args.rr_depth,
                        reference=args.reference_kind, reference_spp=args.reference_spp, seed=args.seed)


def _check_mesh_sizes(args) -> None:
    """Refuse the mesh sizes of ``--rays`` (``--triangles``) and ``--scaling`` (``--scaling-triangles``, two
    sizes at least) before any benchmark runs, naming the option (``ValueError``)."""
    from benchmarks.speed.rays import MIN_TRIANGLES

    for given, option in ((args.rays, "--triangles"), (args.scaling, "--scaling-triangles")):
        sizes = getattr(args, option[2:].replace("-", "_"))
        small = [n for n in sizes if n < MIN_TRIANGLES]
        if given and small:
            raise ValueError(f"{option}: a mesh has at least {MIN_TRIANGLES} triangles, got {small[0]}")
    if args.scaling and len(set(args.scaling_triangles)) < 2:
        raise ValueError(f"--scaling-triangles: the mesh sweep needs two different sizes at least, got "
                         f"{','.join(map(str, args.scaling_triangles))}")


def _build_isa(isa, log) -> dict:
    """``{isa: module}``: our core built for ``isa`` in a private temporary folder, removed when the process ends.
    Never a build kept on disk: a build folder (its CMake cache, its module) runs code, so it is made afresh."""
    import tempfile

    from benchmarks.speed.builds import build_isa, build_target

    tmp = tempfile.TemporaryDirectory(prefix=f"rtbench-core-{isa}-")
    _BUILD_FOLDERS.append(tmp)          # kept until exit: the workers load the module from it
    folder, log = Path(tmp.name), log or (lambda line: None)
    log(f"building our core for {isa} in {folder} (a minute or more)")
    try:
        module = build_isa(isa, folder)
    except (RuntimeError, FileNotFoundError) as e:
        raise RuntimeError(f"the {isa} build of our core failed: {e}") from None
    log(f"{isa} build: {build_target(folder)}")
    return {isa: module}


#: the temporary folders of this process's --isa builds (removed at exit by their finalizers)
_BUILD_FOLDERS = []

