"""``rtbench stress [--quick] [--case NAME ...] [--json PATH]``: numerical stability on hard cases."""
from __future__ import annotations

import argparse
import json

HELP = "run the hard-case suite (watertight meshes, grazing rays, degenerate input, scale, ...) and print a table"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from benchmarks.stress import CASES

    parser.add_argument("--quick", action="store_true",
                        help="smaller settings (1e5 watertight rays instead of 4e6, fewer samples): ~30 s")
    parser.add_argument("--case", action="append", metavar="NAME", choices=list(CASES),
                        help=f"run only this case (repeatable; default: every case); one of: {', '.join(CASES)}")
    from benchmarks.commands import _args as A

    A.add_json_arg(parser)
    A.add_quiet_arg(parser)


def run(args) -> int:
    from rich.console import Console
    from rich.markup import escape
    from rich.table import Table

    from benchmarks.stress import run_cases

    console = Console()
    if not console.is_terminal:   # piped or captured: keep the figures on few lines
        console = Console(width=160)
    table = Table(title=f"rtbench stress ({'quick' if args.quick else 'full'})", show_lines=True)
    table.add_column("case", style="bold", no_wrap=True)
    table.add_column("figure")
    table.add_column("verdict", no_wrap=True)
    table.add_column("s", justify="right", no_wrap=True)

    def progress(rec):
        if not args.quiet:
            console.print(f"  {rec.case}: {rec.verdict} ({rec.seconds:.1f} s)", style="dim")

    records = run_cases(args.case, quick=args.quick, on_record=progress)
    for rec in records:
        style = "green" if rec.passed else "bold red"
        table.add_row(rec.case, escape(rec.figure), f"[{style}]{rec.verdict}[/{style}]", f"{rec.seconds:.1f}")
    if not args.quiet:
        console.print(table)
    else:
        print(f"rtbench stress: {sum(r.passed for r in records)} of {len(records)} case(s) passed")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump([{"case": r.case, "figure": r.figure, "verdict": r.verdict, "seconds": r.seconds,
                        "details": r.details} for r in records], fh, indent=1, default=str)
    failed = [r.case for r in records if not r.passed]
    if failed:
        console.print(f"[bold red]failed: {', '.join(failed)}[/bold red]")
        return 1
    return 0
