"""``rtbench gate [SCENE...]``: fail when our tracer's renders drift from their references.

Renders each scene with our tracer (``mis``, plus any ``--strategies``), compares it with
its cached Mitsuba reference (rendered first when missing) by
:func:`benchmarks.gate.compare`, prints a table, writes p-value images of failures into
``--out`` and exits 1 when any comparison fails. Defaults: the quick suite at 32x32,
4096 spp against 16384-spp references, false-alarm rate 0.01 for the whole run
(``benchmarks.gate_run``).
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

HELP = ("regression gate: render the suite with our tracer, test it against the cached Mitsuba references "
        "(pixel, tile and image tests), exit 1 on a significant difference")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from benchmarks.gate_run import (DEFAULT_ALPHA, DEFAULT_REF_SPP, DEFAULT_SEED, DEFAULT_SPP, DEFAULT_WIDTH,
                                     STRATEGIES)

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
    parser.add_argument("--alpha", type=float, default=DEFAULT_ALPHA,
                        help=f"false-alarm rate of the whole run (default {DEFAULT_ALPHA}); each of the k "
                             "comparisons is tested at alpha/k")
    parser.add_argument("--seed", type=int, default=DEFAULT_SEED, help=f"seed of our renders (default {DEFAULT_SEED})")
    parser.add_argument("--out", default="rtbench-gate", metavar="DIR",
                        help="folder for the p-value images of failures (default ./rtbench-gate)")
    parser.add_argument("--threads", type=int, default=None, help="rendering threads (default: all cores)")
    parser.add_argument("--cache", default=None, metavar="DIR",
                        help="reference cache root (default $RTBENCH_CACHE or ~/.cache/rtbench)")
    parser.add_argument("--json", default=None, metavar="PATH", help="also write every comparison's statistics")


def _strategies(values) -> list:
    out = []
    for v in values:
        out.extend(s.strip() for s in v.split(",") if s.strip())
    return out


def run(args) -> int:
    from rich.console import Console
    from rich.markup import escape
    from rich.progress import BarColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn
    from rich.table import Table

    from benchmarks.gate_run import run_gate, write_p_images

    console = Console()
    if not console.is_terminal:  # CI logs: keep one row per comparison
        console = Console(width=max(console.width, 160))
    err = Console(stderr=True)
    if args.threads is not None and args.threads < 1:
        raise ValueError(f"--threads must be >= 1, got {args.threads}")
    scenes = args.scenes or None
    strategies = _strategies(args.strategies)
    # validate everything before the first (possibly long) render
    from benchmarks.gate_run import resolve_scenes, resolve_strategies

    n_scenes, n_strategies = len(resolve_scenes(scenes)), len(resolve_strategies(strategies))
    for name, v, lo in (("--spp", args.spp, 2), ("--ref-spp", args.ref_spp, 2), ("--width", args.width, 1),
                        ("--seed", args.seed, 0)):
        if v < lo:
            raise ValueError(f"{name} must be >= {lo}, got {v}")
    if args.height is not None and args.height < 1:
        raise ValueError(f"--height must be >= 1, got {args.height}")
    if not 0 < args.alpha < 1:
        raise ValueError(f"--alpha must be in (0, 1), got {args.alpha}")

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
                          on_reference=on_reference, on_case=on_case)

    c0 = report.cases[0]
    table = Table(title=f"rtbench gate: {c0.width}x{c0.height}, {c0.spp} spp, seed {c0.seed}; alpha {report.alpha:g} "
                        f"for the run = {report.case_alpha:.3g} per comparison")
    for col in ("scene", "strategy", "reference", "verdict", "p-value", "failed levels", "relative bias +- se",
                "where (strongest evidence)"):
        table.add_column(col, overflow="fold")
    for c in report.cases:
        r = c.result
        verdict = "[green]pass[/]" if c.passed else "[bold red]FAIL[/]"
        ref = "closed form" if c.reference.kind == "closed form" else f"Mitsuba {c.reference.spp} spp"
        table.add_row(c.scene, c.strategy, ref, verdict, f"{r.p_value:.3g}", ", ".join(r.failed_levels) or "-",
                      f"{r.relative_bias:+.2%} +- {r.relative_bias_se:.2%}", escape(c.where()) if not c.passed else "-")
    console.print(table)
    console.print(f"references {report.reference_seconds:.1f} s, our renders {report.render_seconds:.1f} s, "
                  f"total {report.seconds:.1f} s", highlight=False)
    if args.json:
        path = Path(args.json)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps({"alpha": report.alpha, "case_alpha": report.case_alpha,
                                    "passed": report.passed, "cases": [c.to_dict() for c in report.cases]},
                                   indent=1, default=float) + "\n")
    if report.passed:
        console.print(f"[green]gate passed[/]: {len(report.cases)} comparison(s)")
        return 0
    for c in report.failures:
        paths = write_p_images(c, args.out)
        print(f"rtbench gate: FAIL {c.message()}", file=sys.stderr)
        print(f"  p-value images: {paths[1]} (false colour), {paths[0]} (-log10 p)", file=sys.stderr)
    print(f"rtbench gate: {len(report.failures)} of {len(report.cases)} comparison(s) failed", file=sys.stderr)
    return 1
