"""``rtbench selftest``: does the gate catch real bugs? Seeded bugs, gate vs Mitsuba's rule
(:func:`benchmarks.selftest.run_selftest`), one row per mutant with the unmutated tracer as a control."""
from __future__ import annotations

import shlex
import sys

from benchmarks.commands import _args as A
from benchmarks.text import markdown_table

HELP = ("self-test: render seeded bugs of the tracer (mutants) and report which the gate and Mitsuba's rule "
        "catch, and from how many spp; exit 1 if the gate catches fewer than 90% or fewer than Mitsuba's rule")


def add_arguments(parser) -> None:
    from benchmarks.gate import DEFAULT_REF_SPP, DEFAULT_SEED, DEFAULT_SPP, DEFAULT_WIDTH
    from benchmarks.selftest import CATALOGUE, DEFAULT_SPP_LADDER
    from benchmarks.tails import DEFAULT_TAIL_SPP

    parser.add_argument("--mutants", action=A.ListAction, default=(), metavar="M[,M...]",
                        help=f"mutants to test, comma-separated or repeated (default: all): "
                             f"{', '.join(m.name for m in CATALOGUE)}")
    A.add_list_arg(parser)
    A.add_spp_args(parser, default=DEFAULT_SPP)
    parser.add_argument("--spp-ladder", default=",".join(map(str, DEFAULT_SPP_LADDER)), metavar="N[,N...]",
                        help="budgets below --spp at which each mutant is judged too, for the smallest spp "
                             "that catches it; 'none': at --spp only")
    A.add_size_args(parser, width=DEFAULT_WIDTH)
    A.add_reference_spp_arg(parser, default=DEFAULT_REF_SPP)
    A.add_tail_spp_arg(parser, default=DEFAULT_TAIL_SPP)
    A.add_seed_args(parser, default=DEFAULT_SEED)
    parser.add_argument("--no-controls", action="store_true",
                        help="skip the control: the unmutated tracer judged the same way on each scene and strategy")
    A.add_threads_args(parser)
    A.add_cache_arg(parser)
    A.add_json_arg(parser)
    parser.add_argument("--markdown", default=None, metavar="PATH",
                        help="also write the table as Markdown (default: none)")
    A.add_quiet_arg(parser)


def _control(row) -> str:
    if row.get("control_verdict") is None:
        return "-"
    return f"{row['control_verdict']} / {'fail' if row['control_caught_by_mitsuba_rule'] else 'pass'}"


COLUMNS = ("mutant", "scene", "strategy", "gate verdict", "caught", "smallest spp caught", "Mitsuba rule caught",
           "smallest spp (Mitsuba)", "image bias", "tracer: gate / Mitsuba")


def _cells(row) -> list:
    return [row["mutant"], row["scene"], row["strategy"], row["verdict"], "yes" if row["caught"] else "NO",
            str(row["smallest_spp_caught"] or "-"), "yes" if row["caught_by_mitsuba_rule"] else "no",
            str(row["smallest_spp_caught_by_mitsuba_rule"] or "-"),
            f"{row['relative_bias']:+.2%} +- {row['relative_bias_se']:.2%}", _control(row)]


def summary_line(report) -> str:
    return (f"gate caught {report.n_caught}/{report.n} ({report.catch_rate:.0%}), Mitsuba's rule "
            f"{report.n_caught_by_mitsuba_rule}/{report.n}, at {report.spp} spp")


def selftest_table(report):
    """The rich table of a :class:`benchmarks.selftest.SelftestReport`."""
    from rich.markup import escape
    from rich.table import Table

    t = Table(title=f"self-test: seeded bugs at {report.spp} spp (gate level {report.alpha:.3g} per comparison)")
    for c in COLUMNS:
        t.add_column(c, justify="right" if "spp" in c or c == "image bias" else "left")
    for row in report.rows:
        cells = [escape(str(cell)) for cell in _cells(row)]  # brackets in a name are text, not markup
        if not row["caught"]:
            cells[4] = "[bold red]NO[/]"
        t.add_row(*cells)
    return t


def markdown(report) -> str:
    """The table as Markdown, after the command that produced it when run from the console script."""
    lines = []
    if sys.argv[1:2] == ["selftest"]:  # not a test's main(argv)
        lines += [f"`rtbench {shlex.join(sys.argv[1:])}`", ""]
    lines += [markdown_table(COLUMNS, [_cells(r) for r in report.rows])]
    lines += ["", summary_line(report) + "; gate level per comparison "
              f"{report.alpha:.3g} (a default quick-suite run), Mitsuba's rule at its own alpha 0.01 per image. "
              "Last column: the unmutated tracer's verdicts on the same scene and strategy (gate / Mitsuba's rule)."]
    return "\n".join(lines) + "\n"


def run(args) -> int:
    from benchmarks.gate.suite import names_of
    from benchmarks.selftest import CATALOGUE, run_selftest
    from benchmarks.store import write_json
    from reference_tracer.imageio import atomic_write

    if args.list:
        for m in CATALOGUE:
            print(f"{m.name} ({m.scene}, {m.strategy})\n  bug: {m.description}\n  breaks: {m.breaks}\n"
                  f"  why this scene: {m.why}")
        return 0
    names = names_of(",".join(args.mutants)) or None
    A.warn_tail_spp("selftest", args.tail_spp)
    if args.height != args.width:
        raise ValueError("selftest renders square images: --height must equal --width")
    spp_ladder = list(args.spp_ladder)  # parsed by A.check: () for 'none'
    log = A.stderr_log(args)

    def on_row(row):
        if log:
            log(f"{row['mutant']}: gate {row['verdict']}, Mitsuba's rule "
                f"{'caught' if row['caught_by_mitsuba_rule'] else 'passed'} it ({row['seconds']:.0f} s)")

    report = run_selftest(names, spp=args.spp, width=args.width, ref_spp=args.reference_spp, tail_spp=args.tail_spp,
                          spp_ladder=spp_ladder, seed=args.seed, controls=not args.no_controls,
                          threads=args.threads, cache=args.cache, on_row=on_row, log=log)
    console = A.wide_console(200)
    if not args.quiet:
        console.print(selftest_table(report))
    console.print(summary_line(report) + f"; {report.seconds:.0f} s", highlight=False)
    missed = [r for r in report.rows if not r["caught"]]
    for r in missed:
        console.print(f"missed: {r['mutant']} ({r['scene']}, {r['strategy']}): verdict {r['verdict']}, image bias "
                      f"{r['relative_bias']:+.2%} +- {r['relative_bias_se']:.2%}, minimum detectable bias "
                      f"{r['min_detectable_bias']:.2%} (image), {r['min_detectable_tile_bias']:.2%} (8x8 tile); "
                      f"{r['reason']}", highlight=False, markup=False)
    for r in report.rows:
        if r["caught_by_mitsuba_rule"] and not r["caught"]:
            console.print(f"caught by Mitsuba's rule only: {r['mutant']}", highlight=False, markup=False)
    if args.json:
        write_json(args.json, report.to_dict())
    if args.markdown:
        atomic_write(args.markdown, markdown(report))
    if report.passed:
        console.print(f"[green]self-test passed[/]: {summary_line(report)}")
        return 0
    print(f"rtbench selftest: FAIL {summary_line(report)} (needs >= 90% and no fewer than Mitsuba's rule)",
          file=sys.stderr)
    return 1
