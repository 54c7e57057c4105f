"""``rtbench chi2 [--routine PREFIX ...] [--samples N] [--seed S] [--alpha A] [--out DIR] [--json PATH]``:
chi-square tests of every sampling routine (warps, BSDFs, glass lobes, light sampling)."""
from __future__ import annotations

import argparse
import json

HELP = "chi-square tests of every sampling routine against its pdf; observed-vs-expected images; exit 1 on a failure"

DEFAULT_SAMPLES = 1_000_000
DEFAULT_OUT = "rtbench-out/chi2"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from benchmarks.chi2.pearson import DEFAULT_ALPHA

    from benchmarks.commands import _args as A

    parser.add_argument("--routine", action="append", metavar="PREFIX", default=[],
                        help="run only routines whose name starts with PREFIX (repeatable), e.g. bsdf.rough_conductor, "
                             "light., warp.uniform_cone; --list shows them (default: every routine)")
    A.add_list_arg(parser)
    parser.add_argument("--samples", type=int, default=DEFAULT_SAMPLES, help="samples per routine")
    A.add_seed_args(parser)
    A.add_alpha_args(parser, default=DEFAULT_ALPHA)
    A.add_out_arg(parser, default=DEFAULT_OUT)
    parser.add_argument("--images", choices=("all", "failures", "none"), default="all",
                        help="which routines get an observed-vs-expected image")
    A.add_json_arg(parser)
    A.add_quiet_arg(parser)


def run(args) -> int:
    from rich.console import Console
    from rich.markup import escape
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
    from rich.table import Table

    from benchmarks.chi2.catalogue import select
    from benchmarks.chi2.runner import run_routine
    from benchmarks.chi2.pearson import sidak

    from benchmarks.commands._args import check

    check(args)
    routines = select(args.routine)        # ValueError (exit 2) for a prefix that matches nothing
    console = Console()
    if not console.is_terminal:   # piped or captured: keep the rows on one line each
        console = Console(width=160)
    quiet = Console(quiet=True) if args.quiet else console
    if args.list:
        for r in routines:
            console.print(r.label, highlight=False, markup=False)
        return 0
    per_test = sidak(args.alpha, len(routines))   # ValueError for alpha outside (0, 1)

    rows = []
    with Progress(TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
                  TimeElapsedColumn(), console=quiet, transient=True) as progress:
        task = progress.add_task("chi2", total=len(routines))
        for r in routines:
            progress.update(task, description=f"chi2 {r.label}")
            row = run_routine(r, n=args.samples, seed=args.seed, alpha=per_test)
            rows.append((r, row))
            if not row.passed:
                progress.console.print(f"  {r.label}: {row.verdict} - {row.message}", style="dim",
                                       highlight=False, markup=False)
            progress.advance(task)
    images = _write_images(rows, args)   # an OSError here: exit 3 (benchmarks.cli)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump([row.to_json() for _, row in rows], fh, indent=1, default=float)

    table = Table(title=f"rtbench chi2: {len(rows)} routines, {args.samples} samples each, "
                        f"alpha {args.alpha} for the run ({per_test:.2e} per routine)")
    table.add_column("routine", style="bold", no_wrap=True)
    table.add_column("params")
    table.add_column("n", justify="right")
    table.add_column("p-value", justify="right")
    table.add_column("verdict", no_wrap=True)
    table.add_column("s", justify="right")
    for _, row in rows:
        style = {"pass": "green", "fail": "bold red"}.get(row.verdict, "yellow")
        table.add_row(row.routine, row.params, str(row.n), f"{row.p_value:.3g}", f"[{style}]{row.verdict}[/{style}]",
                      f"{row.seconds:.1f}")
    quiet.print(table)
    if images:
        console.print(f"{images} images in {args.out}/")
    failed = [f"{r.label}: {row.message}" for r, row in rows if row.verdict == "fail"]
    undetermined = [f"{r.label}: {row.message}" for r, row in rows if row.verdict == "undetermined"]
    for line in undetermined:
        console.print(f"[yellow]undetermined[/yellow] {escape(line)}", highlight=False)
    for line in failed:
        console.print(f"[bold red]failed[/bold red] {escape(line)}", highlight=False)
    return 1 if failed else 0


def _write_images(rows, args) -> int:
    from benchmarks.chi2.plot import file_name, save_histograms

    if args.images == "none":
        return 0
    count = 0
    for r, row in rows:
        if args.images == "failures" and row.passed:
            continue
        if row.result is not None:
            save_histograms(row.result, f"{args.out}/{file_name(r.label)}", title=r.label)
            count += 1
    return count
