"""``rtbench gate [SCENE...]``: fail when our tracer's renders drift from their references
(:func:`benchmarks.gate.run_gate`); ``--calibrate`` measures the false-alarm rate instead."""
from __future__ import annotations

import json
import math
import sys
from pathlib import Path

from benchmarks.commands import _args as A
from benchmarks.constants import CLOSED_FORM

HELP = ("regression gate: render the suite with our tracer (mis always, plus any --strategies; light is biased "
        "on purpose and fails), test it against the cached Mitsuba references (pixel, tile, image and "
        "neighbour-correlation tests), exit 1 on a significant difference")

DEFAULT_OUT = "rtbench-out/gate"


def add_arguments(parser) -> None:
    from benchmarks.gate import DEFAULT_REF_SPP, DEFAULT_SEED, DEFAULT_SPP, DEFAULT_WIDTH
    from benchmarks.gate.calibration import DEFAULT_CALIBRATION_SEEDS, DEFAULT_CALIBRATION_SPPS
    from benchmarks.tails import DEFAULT_TAIL_SPP

    A.add_scene_args(parser, what="suite scenes (default: the whole quick suite)")
    A.add_spp_args(parser, default=DEFAULT_SPP)
    A.add_strategy_args(parser, default=(), none_means="mis only; with --calibrate every unbiased strategy")
    A.add_size_args(parser, width=DEFAULT_WIDTH)
    A.add_reference_spp_arg(parser, default=DEFAULT_REF_SPP)
    A.add_variant_args(parser)
    A.add_alpha_args(parser)
    A.add_seed_args(parser, default=DEFAULT_SEED)
    A.add_out_arg(parser, default=DEFAULT_OUT)
    A.add_threads_args(parser)
    A.add_cache_arg(parser)
    A.add_tail_spp_arg(parser, default=DEFAULT_TAIL_SPP)
    parser.add_argument("--calibrate", action="store_true",
                        help="measure the false-alarm rate instead: render every unbiased strategy (or "
                             "--strategies) with --seeds seeds at each of --spps and count pass / fail / "
                             "undetermined per (scene, strategy, spp); exit 1 if a rate exceeds --alpha (here "
                             "each comparison is tested at --alpha itself: the rate measured is one comparison's); "
                             "with --json PATH, written after every row, a rerun resumes where it stopped")
    parser.add_argument("--compare-pairs", action="store_true",
                        help="with --calibrate: measure rtbench compare's verdict instead, on --seeds pairs of "
                             "renders of this build (the second judged against the first with the tail "
                             "reference, as compare judges two stores of one build); no Mitsuba reference")
    A.add_spps_arg(parser, default=DEFAULT_CALIBRATION_SPPS)
    A.add_seeds_arg(parser, default=DEFAULT_CALIBRATION_SEEDS)
    A.add_scene_path_args(parser)
    parser.add_argument("--reference", default=None, metavar="STORE",
                        help="gate against our own images in results store STORE (written by --write-reference "
                             "with a trusted build) instead of Mitsuba: for features Mitsuba cannot render "
                             "(default: Mitsuba)")
    parser.add_argument("--reference-build", default=None, metavar="BUILD",
                        help="with --reference: the build whose records to use (default: the latest)")
    parser.add_argument("--write-reference", default=None, metavar="STORE",
                        help="render the scenes with this build at --reference-spp (mis) into results store "
                             "STORE, for later --reference runs, and exit (default: none)")
    A.add_renderer_arg(parser)  # gated instead of ours, run in 16 batches for the per-pixel variance
    A.add_json_arg(parser)
    A.add_quiet_arg(parser)


def run(args) -> int:
    # --renderer and --write-reference use no tail references; 1 is refused (run_gate)
    if args.tail_spp != 1 and not args.renderer and not args.write_reference:
        A.warn_tail_spp("gate", args.tail_spp)
    if args.compare_pairs and not args.calibrate:
        raise ValueError("--compare-pairs goes with --calibrate (it measures compare's false-alarm rate)")
    if args.calibrate:
        return _calibrate(args)
    from benchmarks.commands.parity import check_user_scenes
    from benchmarks.external import register_external
    from benchmarks.gate import run_gate, write_p_images
    from benchmarks.store import write_json

    console = A.wide_console(160)
    scenes = A.resolve_scenes(args, suite_names=args.scenes) or None
    if args.write_reference:
        return _write_reference(args, scenes)
    if scenes and args.reference is None and not check_user_scenes(
            scenes, args.out, command="gate", skipped="no statistics were computed", width=args.width,
            height=args.height):
        return 1
    variant = A.single_variant(args)
    if len(args.renderer) > 1:
        raise ValueError("gate takes one --renderer at a time")
    external = register_external(args.renderer[0]) if args.renderer else None
    progress = A.progress_bar(args)
    state = {}

    def on_start(names, strategies):  # run_gate has checked its inputs: nothing is rendered yet
        state["refs"] = progress.add_task("references", total=len(names))
        state["cases"] = progress.add_task(f"our renders ({args.spp} spp)", total=len(names) * len(strategies))

    def on_reference(name, phase, ref):
        if phase == "start":
            progress.update(state["refs"], description=f"reference {name} (rendered with Mitsuba if not cached)")
            return
        progress.advance(state["refs"])
        how = "cached" if ref.cached else f"rendered in {ref.seconds:.1f} s"
        progress.console.print(f"reference {name}: {ref.description} ({how})", highlight=False, markup=False)

    def on_case(case):
        progress.advance(state["cases"])
        progress.update(state["cases"], description=f"rendered {case.scene} / {case.strategy}")

    with progress:
        report = run_gate(scenes, strategies=list(args.strategies), spp=args.spp, width=args.width,
                          height=args.height, ref_spp=args.reference_spp, alpha=args.alpha, seed=args.seed,
                          threads=args.threads,
                          cache=args.cache, log=lambda line: progress.console.print(line, markup=False),
                          on_start=on_start, on_reference=on_reference, on_case=on_case, tail_spp=args.tail_spp,
                          reference_store=args.reference, reference_build=args.reference_build,
                          renderer=external, variant=variant)

    if not args.quiet:
        console.print(gate_table(report))
    console.print(f"references {report.reference_seconds:.1f} s, tail references {report.tail_seconds:.1f} s, "
                  f"our renders {report.render_seconds:.1f} s, total {report.seconds:.1f} s", highlight=False)
    for c in report.undetermined:
        console.print(f"undetermined: {c.scene} ({c.strategy}): {c.result.reason}", highlight=False, markup=False)
    if args.json:
        verdicts = {v: sum(c.verdict == v for c in report.cases) for v in ("pass", "fail", "undetermined")}
        write_json(args.json, {"alpha": report.alpha, "case_alpha": report.case_alpha, "passed": report.passed,
                                "verdicts": verdicts, "cases": [c.to_dict() for c in report.cases]})
    if report.passed:
        n_und = len(report.undetermined)
        if n_und:
            console.print(f"[green]gate: no comparison failed[/]: {len(report.cases) - n_und} pass, {n_und} "
                          "undetermined (not a failure; see above)")
        else:
            console.print(f"[green]gate passed[/]: {len(report.cases)} comparison(s)")
        return 0
    for c in report.failures:
        paths = write_p_images(c, args.out)
        print(f"rtbench gate: FAIL {c.message()}", file=sys.stderr)
        print(f"  p-value images: {paths[1]} (false colour), {paths[0]} (-log10 p)", file=sys.stderr)
    print(f"rtbench gate: {len(report.failures)} of {len(report.cases)} comparison(s) failed", file=sys.stderr)
    return 1


def _write_reference(args, scenes) -> int:
    """``--write-reference STORE``: our renders at ``--reference-spp`` into a results store."""
    from benchmarks.gate import resolve_scenes as resolve_gate_scenes
    from benchmarks.gate.store_reference import write_reference_store

    names = resolve_gate_scenes(scenes)
    write_reference_store(names, args.write_reference, spp=args.reference_spp, width=args.width, height=args.height,
                          threads=args.threads, log=print)
    print(f"reference store: {Path(args.write_reference).resolve()} ({len(names)} scene(s), {args.reference_spp} spp)")
    return 0


def _calibrate(args) -> int:
    """``rtbench gate --calibrate``: the false-alarm table (:func:`benchmarks.gate.calibrate`)."""
    from benchmarks.constants import UNBIASED_STRATEGIES
    from benchmarks.gate import calibrate
    from benchmarks.gate import resolve_scenes as resolve_gate_scenes
    from benchmarks.store import write_json
    from reference_tracer.build import build_id as rt_build_id

    spps = list(args.spps)
    strategies = list(args.strategies) or list(UNBIASED_STRATEGIES)
    names = resolve_gate_scenes(A.resolve_scenes(args, suite_names=args.scenes) or None)
    console = A.wide_console(160)
    progress = A.progress_bar(args, "calibration")
    config = {"scenes": list(names), "strategies": strategies, "spps": spps, "seeds": args.seeds,
              "width": args.width, "height": args.height, "reference_spp": args.reference_spp,
              "tail_spp": args.tail_spp, "variant": A.single_variant(args), "build": rt_build_id(),
              "compare_pairs": bool(args.compare_pairs)}
    rows = _resumed_rows(args.json, config, alpha=args.alpha) if args.json else []
    if rows:
        print(f"rtbench gate --calibrate: resuming {args.json}: {len(rows)} row(s) measured already",
              file=sys.stderr, flush=True)
    skip = {(r.scene, r.strategy, r.spp) for r in rows}
    todo = len({(n, st, spp) for n in names for st in strategies for spp in spps} - skip)

    def on_row(row):
        rows.append(row)
        progress.console.print(f"{row.scene} {row.strategy} {row.spp} spp: pass {row.passed}, fail {row.failed}, "
                               f"undetermined {row.undetermined}", highlight=False, markup=False)
        if args.json:  # written after every row: an interrupted calibration keeps what it measured
            write_json(args.json, {"alpha": args.alpha, "config": config, "rows": [r.to_dict() for r in rows]})

    with progress:
        task = progress.add_task("renders", total=todo * args.seeds)
        calibrate(names, strategies=strategies, spps=spps, seeds=args.seeds, width=args.width,
                  height=args.height, ref_spp=args.reference_spp, tail_spp=args.tail_spp, alpha=args.alpha,
                  threads=args.threads, cache=args.cache, variant=config["variant"],
                  log=lambda line: progress.console.print(line, markup=False),
                  on_render=lambda: progress.advance(task), on_row=on_row, skip=skip, pairs=args.compare_pairs)
    if not args.quiet:
        console.print(calibration_table(rows, alpha=args.alpha, pairs=args.compare_pairs))
    bad = [r for r in rows if not r.consistent]
    for r in bad:
        print(f"rtbench gate --calibrate: false-alarm rate {r.false_alarm_rate:.3f} "
              f"(95% CI {r.ci_low:.3f}-{r.ci_high:.3f}) exceeds alpha {args.alpha:g} on {r.scene} "
              f"({r.strategy}, {r.spp} spp)", file=sys.stderr)
    return 1 if bad else 0


def _resumed_rows(path, config: dict, *, alpha: float) -> list:
    """The rows an interrupted calibration wrote to ``path`` (all of them: the file grows into the
    whole table); a file of other settings or another build is refused, a missing one is a fresh start."""
    from benchmarks.gate import CalibrationRow

    p = Path(path)
    if not p.is_file():
        return []
    try:
        data = json.loads(p.read_text())
        old = data["config"]
        # an undetermined power is null in the file (strict JSON), NaN in a row
        rows = [CalibrationRow(**{**r, "min_detectable_bias": math.nan if r["min_detectable_bias"] is None
                                  else r["min_detectable_bias"]}) for r in data["rows"]]
    except (ValueError, KeyError, TypeError) as exc:
        raise ValueError(f"--json {path} exists but is not a calibration this command can resume ({exc}); "
                         f"give another path") from None
    same = {k: old.get(k) for k in ("seeds", "width", "height", "reference_spp", "tail_spp", "variant", "build")}
    same["compare_pairs"] = bool(old.get("compare_pairs", False))  # files before the option: the gate's
    same["alpha"] = data.get("alpha")
    want = {**config, "alpha": alpha}
    diff = ", ".join(f"{k} {same[k]} (now {want[k]})" for k in same if same[k] != want[k])
    if diff:
        raise ValueError(f"--json {path} holds a calibration with other settings: {diff}; give another path")
    return rows


def gate_table(report):
    """The verdict of every comparison of a :class:`benchmarks.gate.GateReport`, as a rich table."""
    from rich.markup import escape
    from rich.table import Table

    c0 = report.cases[0]
    table = Table(title=f"rtbench gate: {c0.width}x{c0.height}, {c0.spp} spp, seed {c0.seed}; alpha {report.alpha:g} "
                        f"for the run = {report.case_alpha:.3g} per comparison")
    for col in ("scene", "strategy", "reference", "verdict", "p-value", "failed levels", "relative bias +- se",
                "catches (global / 8x8 tile)", "where (strongest evidence)"):
        table.add_column(col, overflow="fold")
    for c in report.cases:
        r = c.result
        verdict = {"pass": "[green]pass[/]", "fail": "[bold red]FAIL[/]",
                   "undetermined": f"[yellow]undetermined[/] (needs ~{r.spp_needed} spp)"}[r.verdict]
        ref = (CLOSED_FORM if c.reference.source == CLOSED_FORM else
               f"{c.reference.variant} {c.reference.spp} spp" if c.reference.source == "store" else
               f"Mitsuba {c.reference.spp} spp")
        table.add_row(escape(c.scene), escape(c.strategy), escape(ref), verdict, f"{r.p_value:.3g}",
                      ", ".join(r.failed_levels) or "-",
                      f"{r.relative_bias:+.2%} +- {r.relative_bias_se:.2%}",
                      f"{_pct(r.min_detectable_bias)} / {_pct(r.min_detectable_tile_bias)}",
                      escape(c.where()) if c.failed else "-")
    return table


def _pct(v: float) -> str:
    """A relative bias as a percentage; '-' where the level tests nothing."""
    return f"{v:.2%}" if v == v else "-"


def calibration_table(rows, *, alpha: float, pairs: bool = False):
    """The false-alarm table of :func:`benchmarks.gate.calibrate`'s rows, as a rich table
    (``pairs``: of ``rtbench compare``'s verdict on pairs of renders)."""
    from rich.markup import escape
    from rich.table import Table

    what = "rtbench compare's verdicts on pairs of renders of this build" if pairs else "verdicts on unbiased renders"
    table = Table(title=f"rtbench gate --calibrate: {what}, alpha {alpha:g} per comparison")
    for col in ("scene", "strategy", "spp", "seeds", "pass", "fail", "undetermined", "false alarms (95% CI)",
                "consistent", "undetermined needs ~spp", "catches (global)"):
        table.add_column(col)
    for r in rows:
        table.add_row(escape(r.scene), escape(r.strategy), str(r.spp), str(r.seeds), str(r.passed), str(r.failed),
                      str(r.undetermined),
                      f"{r.false_alarm_rate:.3f} ({r.ci_low:.3f}-{r.ci_high:.3f})",
                      "[green]yes[/]" if r.consistent else "[bold red]NO[/]",
                      "-" if r.spp_needed is None else str(r.spp_needed), _pct(r.min_detectable_bias))
    return table
