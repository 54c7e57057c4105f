"""``rtbench report STORE [--out DIR] [--format html,svg,pdf,csv] [--metric M]``: the report of a results store."""
from __future__ import annotations

from benchmarks.commands import _args as A

HELP = ("turn a results store into a report: a self-contained index.html and summary.md (html), every plot as SVG "
        "and PDF (svg, pdf) and tidy CSVs of the curves and the summary (csv)")


def add_arguments(parser) -> None:
    parser.add_argument("store", metavar="STORE", help="results store folder (holds results.jsonl, summary.json)")
    A.add_out_arg(parser, default="STORE")
    A.add_format_arg(parser)
    A.add_metric_arg(parser)
    A.add_quiet_arg(parser)


def run(args) -> int:
    from reports import summary_table, write_report

    out = None if args.out == "STORE" else args.out
    written = write_report(args.store, out=out, formats=args.format, metric=args.metric)
    if not args.quiet:
        print(summary_table(args.store, metric=args.metric))
        print()
    for kind, path in written.items():
        print(f"{kind}: {path.resolve()}")
    return 0
