"""``rtbench gate [SCENE...]``: fail when our tracer's renders drift from their references.

Renders each scene with our tracer (``mis``, plus any ``--strategies``), compares it with
its cached Mitsuba reference (rendered first when missing) by
:func:`benchmarks.gate.compare` with the tail diagnostics of the same estimator (a cached
high-spp run of ours: :mod:`benchmarks.tails`), prints a table with each comparison's
verdict (pass, fail or undetermined) and power, writes p-value images of failures into
``--out`` and exits 1 when any comparison fails (undetermined ones do not fail the run). Defaults: the quick suite at 32x32,
4096 spp against 16384-spp references, false-alarm rate 0.01 for the whole run
(:mod:`benchmarks.gate.suite`; the table is :func:`benchmarks.commands._gate_tables.gate_table`).
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from benchmarks.commands._scene_args import add_scene_path_args, resolve_scenes

HELP = ("regression gate: render the suite with our tracer, test it against the cached Mitsuba references "
        "(pixel, tile and image tests), exit 1 on a significant difference")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from benchmarks.constants import GATE_ALPHA, STRATEGIES
    from benchmarks.gate import DEFAULT_REF_SPP, DEFAULT_SEED, DEFAULT_SPP, DEFAULT_WIDTH
    from benchmarks.tails import DEFAULT_TAIL_SPP

    parser.add_argument("scenes", nargs="*", metavar="SCENE",
                        help="suite scenes (default: the whole quick suite; see `rtbench render --list`)")
    parser.add_argument("--spp", type=int, default=DEFAULT_SPP,
                        help=f"samples per pixel of our renders (default {DEFAULT_SPP})")
    parser.add_argument("--strategies", action="append", default=[], metavar="S[,S...]",
                        help=f"strategies to gate besides mis (always gated): {', '.join(STRATEGIES)}; "
                             "light is biased on purpose and fails")
    parser.add_argument("--width", type=int, default=DEFAULT_WIDTH,
                        help=f"image width (default {DEFAULT_WIDTH})")
    parser.add_argument("--height", type=int, default=None, help="image height (default: the width)")
    parser.add_argument("--ref-spp", type=int, default=DEFAULT_REF_SPP,
                        help=f"samples per pixel of the Mitsuba references (default {DEFAULT_REF_SPP}; "
                             "rendered into the cache when missing)")
    parser.add_argument("--alpha", type=float, default=GATE_ALPHA,
                        help=f"false-alarm rate of the whole run (default {GATE_ALPHA}); each of the k "
                             "comparisons is tested at alpha/k")
    parser.add_argument("--seed", type=int, default=DEFAULT_SEED, help=f"seed of our renders (default {DEFAULT_SEED})")
    parser.add_argument("--out", default="rtbench-gate", metavar="DIR",
                        help="folder for the p-value images of failures (default ./rtbench-gate)")
    parser.add_argument("--threads", type=int, default=None, help="rendering threads (default: all cores)")
    parser.add_argument("--cache", default=None, metavar="DIR",
                        help="reference cache root (default $RTBENCH_CACHE or ~/.cache/rtbench)")
    parser.add_argument("--tail-spp", type=int, default=DEFAULT_TAIL_SPP,
                        help=f"samples per pixel of the tail references: our estimator at a high budget, cached, "
                             f"whose variance and tail shape make the verdicts valid for heavy-tailed strategies "
                             f"(default {DEFAULT_TAIL_SPP}; 0: none, the older rule)")
    parser.add_argument("--calibrate", action="store_true",
                        help="measure the false-alarm rate instead: render every unbiased strategy (or "
                             "--strategies) with --seeds seeds at each of --spps and count pass / fail / "
                             "undetermined per (scene, strategy, spp); exit 1 if a rate exceeds --alpha")
    parser.add_argument("--spps", default="64,256,1024,4096", metavar="N[,N...]",
                        help="--calibrate: budgets of the renders (default 64,256,1024,4096)")
    parser.add_argument("--seeds", type=int, default=100,
                        help="--calibrate: renders per (scene, strategy, spp) (default 100)")
    add_scene_path_args(parser)
    parser.add_argument("--reference", default=None, metavar="STORE",
                        help="gate against our own images in results store STORE (written by --write-reference "
                             "with a trusted build) instead of Mitsuba: for features Mitsuba cannot render")
    parser.add_argument("--reference-build", default=None, metavar="BUILD",
                        help="with --reference: the build whose records to use (default: the latest)")
    parser.add_argument("--write-reference", default=None, metavar="STORE",
                        help="render the scenes with this build at --ref-spp (mis) into results store STORE, "
                             "for later --reference runs, and exit")
    parser.add_argument("--renderer", default=None, metavar="CMD",
                        help="gate an external renderer instead of ours: a command template with {scene_xml} "
                             "{spp} {seed} {width} {height} {out} (README: External renderers), run in 16 "
                             "batches for the per-pixel variance")
    parser.add_argument("--json", default=None, metavar="PATH",
                        help="also write one row per comparison (scene, strategy, spp, verdict, statistics, power)")


def _strategies(values) -> list:
    out = []
    for v in values:
        out.extend(s.strip() for s in v.split(",") if s.strip())
    return out


def run(args) -> int:
    if args.calibrate:
        return _calibrate(args)
    from rich.console import Console
    from rich.progress import BarColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

    from benchmarks.commands._gate_tables import gate_table
    from benchmarks.gate import resolve_strategies, run_gate, write_p_images
    from benchmarks.gate import resolve_scenes as resolve_gate_scenes

    console = Console()
    if not console.is_terminal:  # CI logs: keep one row per comparison
        console = Console(width=max(console.width, 160))
    err = Console(stderr=True)
    if args.threads is not None and args.threads < 1:
        raise ValueError(f"--threads must be >= 1, got {args.threads}")
    scenes = resolve_scenes(args, suite_names=args.scenes) or None
    if args.write_reference:
        return _write_reference(args, scenes)
    if scenes and args.reference is None and not _parity_first(scenes, args.out):
        return 1
    strategies = _strategies(args.strategies)
    external = None
    if args.renderer:
        from benchmarks.external import register_external

        external = register_external(args.renderer)
    # validate everything before the first (possibly long) render
    n_scenes = len(resolve_gate_scenes(scenes))
    n_strategies = 1 if external is not None else len(resolve_strategies(strategies))
    for name, v, lo in (("--spp", args.spp, 2), ("--ref-spp", args.ref_spp, 2), ("--width", args.width, 1),
                        ("--seed", args.seed, 0)):
        if v < lo:
            raise ValueError(f"{name} must be >= {lo}, got {v}")
    if args.height is not None and args.height < 1:
        raise ValueError(f"--height must be >= 1, got {args.height}")
    if not 0 < args.alpha < 1:
        raise ValueError(f"--alpha must be in (0, 1), got {args.alpha}")
    if args.tail_spp < 0 or args.tail_spp == 1:
        raise ValueError(f"--tail-spp must be 0 or >= 2, got {args.tail_spp}")

    progress = Progress(SpinnerColumn(), TextColumn("{task.description}"), BarColumn(),
                        TextColumn("{task.completed}/{task.total}"), TimeElapsedColumn(), console=err,
                        transient=True)
    state = {}

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
        state["refs"] = progress.add_task("references", total=n_scenes)
        state["cases"] = progress.add_task(f"our renders ({args.spp} spp)", total=n_scenes * n_strategies)
        report = run_gate(scenes, strategies=strategies, spp=args.spp, width=args.width, height=args.height,
                          ref_spp=args.ref_spp, alpha=args.alpha, seed=args.seed, threads=args.threads,
                          cache=args.cache, log=lambda line: progress.console.print(line, markup=False),
                          on_reference=on_reference, on_case=on_case, tail_spp=args.tail_spp,
                          reference_store=args.reference, reference_build=args.reference_build,
                          renderer=external)

    console.print(gate_table(report))
    console.print(f"references {report.reference_seconds:.1f} s, tail references {report.tail_seconds:.1f} s, "
                  f"our renders {report.render_seconds:.1f} s, total {report.seconds:.1f} s", highlight=False)
    for c in report.undetermined:
        console.print(f"undetermined: {c.scene} ({c.strategy}): {c.result.reason}", highlight=False, markup=False)
    if args.json:
        path = Path(args.json)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps({"alpha": report.alpha, "case_alpha": report.case_alpha,
                                    "passed": report.passed, "verdicts": {v: sum(c.verdict == v for c in report.cases)
                                                                          for v in ("pass", "fail", "undetermined")},
                                    "cases": [c.to_dict() for c in report.cases]},
                                   indent=1, default=float) + "\n")
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
    """``--write-reference STORE``: our renders at ``--ref-spp`` into a results store."""
    from benchmarks.gate import resolve_scenes as resolve_gate_scenes
    from benchmarks.gate.store_reference import write_reference_store

    names = resolve_gate_scenes(scenes)
    write_reference_store(names, args.write_reference, spp=args.ref_spp, width=args.width, height=args.height,
                          threads=args.threads, log=print)
    print(f"reference store: {Path(args.write_reference).resolve()} ({len(names)} scene(s), {args.ref_spp} spp)")
    return 0


def _parity_first(names, out) -> bool:
    """AOV parity of the scene files among ``names`` before any render; False (after printing
    the findings and writing the mismatch maps into ``out``) when one fails."""
    from benchmarks.commands.parity import check_user_scenes

    if check_user_scenes(names, out, say=lambda line: print(line, file=sys.stderr)):
        return True
    print("rtbench gate: the scene file(s) above translate differently in the two renderers; fix that first "
          "(no statistics were computed)", file=sys.stderr)
    return False


def _calibrate(args) -> int:
    """``rtbench gate --calibrate``: the false-alarm table (:func:`benchmarks.gate.calibrate`)."""
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from benchmarks.commands._gate_tables import calibration_table
    from benchmarks.constants import UNBIASED_STRATEGIES
    from benchmarks.gate import calibrate
    from benchmarks.gate import resolve_scenes as resolve_gate_scenes

    try:
        spps = [int(v) for v in args.spps.split(",") if v.strip()]
    except ValueError:
        raise ValueError(f"--spps must be a comma-separated list of integers, got {args.spps!r}") from None
    if not spps or min(spps) < 2:
        raise ValueError(f"--spps must list budgets >= 2, got {args.spps!r}")
    if args.seeds < 1:
        raise ValueError(f"--seeds must be >= 1, got {args.seeds}")
    if not 0 < args.alpha < 1:
        raise ValueError(f"--alpha must be in (0, 1), got {args.alpha}")
    strategies = _strategies(args.strategies) or list(UNBIASED_STRATEGIES)
    names = resolve_gate_scenes(resolve_scenes(args, suite_names=args.scenes) or None)
    console = Console()
    if not console.is_terminal:  # logs and files: keep one row per line
        console = Console(width=max(console.width, 160))
    progress = Progress(TextColumn("calibration"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                        console=Console(stderr=True), transient=True)
    rows = []

    def on_row(row):
        rows.append(row)
        progress.console.print(f"{row.scene} {row.strategy} {row.spp} spp: pass {row.passed}, fail {row.failed}, "
                               f"undetermined {row.undetermined}", highlight=False, markup=False)
        if args.json:  # written after every row: an interrupted calibration keeps what it measured
            _write_json(args.json, {"alpha": args.alpha, "rows": [r.to_dict() for r in rows]})

    with progress:
        task = progress.add_task("renders", total=len(names) * len(strategies) * len(spps) * args.seeds)
        calibrate(names, strategies=strategies, spps=spps, seeds=args.seeds, width=args.width, ref_spp=args.ref_spp,
                  tail_spp=args.tail_spp, alpha=args.alpha, threads=args.threads, cache=args.cache,
                  log=lambda line: progress.console.print(line, markup=False),
                  on_render=lambda: progress.advance(task), on_row=on_row)
    console.print(calibration_table(rows, alpha=args.alpha))
    bad = [r for r in rows if not r.consistent]
    if bad:
        for r in bad:
            print(f"rtbench gate --calibrate: false-alarm rate {r.false_alarm_rate:.3f} "
                  f"(95% CI {r.ci_low:.3f}-{r.ci_high:.3f}) exceeds alpha {args.alpha:g} on {r.scene} "
                  f"({r.strategy}, {r.spp} spp)", file=sys.stderr)
        return 1
    return 0


def _write_json(path, obj) -> None:
    from benchmarks.store import atomic_write_text

    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(p, json.dumps(obj, indent=1, default=float) + "\n")
