"""``rtbench report STORE [--out DIR]``: write index.html and summary.md for a results store."""
from __future__ import annotations

import argparse

HELP = "turn a results store into a self-contained HTML report (index.html) and summary.md"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("store", metavar="STORE", help="results store folder (holds results.jsonl, summary.json)")
    parser.add_argument("--out", metavar="DIR", default=None,
                        help="folder to write index.html and summary.md into (default: STORE)")
    parser.add_argument("--quiet", action="store_true", help="print only the report's path, not the summary table")


def run(args) -> int:
    from reports import build_report, summary_table

    page = build_report(args.store, out=args.out)
    if not args.quiet:
        print(summary_table(args.store))
        print()
    print(f"report: {page.resolve()}")
    print(f"summary: {(page.parent / 'summary.md').resolve()}")
    return 0
