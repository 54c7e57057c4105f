"""``rtbench chi2 [--routine PREFIX ...] [--samples N] [--seed S] [--alpha A] [--out DIR] [--json PATH]``:
chi-square tests of every sampling routine (warps, BSDFs, glass lobes, light sampling)."""
from __future__ import annotations

import argparse
import json

HELP = "chi-square tests of every sampling routine against its pdf; observed-vs-expected images; exit 1 on a failure"

DEFAULT_SAMPLES = 1_000_000
DEFAULT_OUT = "rtbench-chi2"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from benchmarks.chi2.pearson import DEFAULT_ALPHA

    parser.add_argument("--routine", action="append", metavar="PREFIX", default=[],
                        help="run only routines whose name starts with PREFIX (repeatable), e.g. bsdf.rough_conductor, "
                             "light., warp.uniform_cone; --list shows them")
    parser.add_argument("--list", action="store_true", help="list the catalogue and exit")
    parser.add_argument("--samples", type=int, default=DEFAULT_SAMPLES,
                        help=f"samples per routine (default {DEFAULT_SAMPLES})")
    parser.add_argument("--seed", type=int, default=0, help="base seed; each routine derives its own (default 0)")
    parser.add_argument("--alpha", type=float, default=DEFAULT_ALPHA,
                        help=f"false-alarm rate of the whole run (default {DEFAULT_ALPHA}); each of the k routines "
                             "is tested at the Sidak level 1 - (1 - alpha)^(1/k)")
    parser.add_argument("--out", default=DEFAULT_OUT, metavar="DIR",
                        help=f"folder for the observed-vs-expected images (default ./{DEFAULT_OUT})")
    parser.add_argument("--images", choices=("all", "failures", "none"), default="all",
                        help="which routines get an image (default all)")
    parser.add_argument("--json", default=None, metavar="PATH", help="also write every row with its statistics")


def run(args) -> int:
    from rich.console import Console
    from rich.markup import escape
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
    from rich.table import Table

    from benchmarks.chi2.catalogue import run_routine, select
    from benchmarks.chi2.pearson import sidak

    routines = select(args.routine)        # ValueError (exit 2) for a prefix that matches nothing
    console = Console()
    if not console.is_terminal:   # piped or captured: keep the rows on one line each
        console = Console(width=160)
    if args.list:
        for r in routines:
            console.print(r.label, highlight=False, markup=False)
        return 0
    if args.samples < 1:
        raise ValueError(f"--samples must be >= 1, got {args.samples}")
    per_test = sidak(args.alpha, len(routines))   # ValueError for alpha outside (0, 1)

    rows = []
    with Progress(TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
                  TimeElapsedColumn(), console=console, transient=True) as progress:
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
    console.print(table)
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
