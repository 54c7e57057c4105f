"""``rtbench selftest``: does the gate catch real bugs? Seeded bugs, gate vs Mitsuba's rule.

Runs :func:`benchmarks.selftest.run_selftest` and prints one row per mutant (the gate's verdict
at ``--spp``, the smallest spp caught, the same for Mitsuba's rule, and the unmutated tracer's
verdicts as a control). Exit 0 when the gate catches at least 90% of the mutants and never
fewer than Mitsuba's rule, 1 otherwise, 2 on bad usage.
"""
from __future__ import annotations

import argparse
import sys

from benchmarks.text import markdown_table

HELP = ("self-test: render seeded bugs of the tracer (mutants) and report which the gate and Mitsuba's rule "
        "catch, and from how many spp; exit 1 if the gate catches fewer than 90% or fewer than Mitsuba's rule")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from benchmarks.commands import _args as A
    from benchmarks.gate import DEFAULT_REF_SPP, DEFAULT_SEED, DEFAULT_SPP, DEFAULT_WIDTH
    from benchmarks.selftest import CATALOGUE, DEFAULT_SPP_LADDER
    from benchmarks.tails import DEFAULT_TAIL_SPP

    parser.add_argument("--mutants", action="append", default=[], metavar="M[,M...]",
                        help=f"mutants to test (default: all): {', '.join(m.name for m in CATALOGUE)}")
    A.add_list_arg(parser)
    A.add_spp_args(parser, default=DEFAULT_SPP)
    parser.add_argument("--spp-ladder", default=",".join(map(str, DEFAULT_SPP_LADDER)), metavar="N[,N...]",
                        help="budgets below --spp at which each mutant is judged too, for the smallest spp "
                             "that catches it")
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


def _spp(n) -> str:
    return "-" if n is None else str(n)


def _control(row) -> str:
    if row.get("control_verdict") is None:
        return "-"
    return f"{row['control_verdict']} / {'fail' if row['control_caught_by_mitsuba_rule'] else 'pass'}"


COLUMNS = ("mutant", "scene", "strategy", "gate verdict", "caught", "smallest spp caught", "Mitsuba rule caught",
           "smallest spp (Mitsuba)", "image bias", "tracer: gate / Mitsuba")


def _cells(row) -> list:
    return [row["mutant"], row["scene"], row["strategy"], row["verdict"], "yes" if row["caught"] else "NO",
            _spp(row["smallest_spp_caught"]), "yes" if row["caught_by_mitsuba_rule"] else "no",
            _spp(row["smallest_spp_caught_by_mitsuba_rule"]),
            f"{row['relative_bias']:+.2%} +- {row['relative_bias_se']:.2%}", _control(row)]


def summary_line(report) -> str:
    return (f"gate caught {report.n_caught}/{report.n} ({report.catch_rate:.0%}), Mitsuba's rule "
            f"{report.n_caught_by_mitsuba_rule}/{report.n}, at {report.spp} spp")


def selftest_table(report):
    """The rich table of a :class:`benchmarks.selftest.SelftestReport`."""
    from rich.table import Table

    t = Table(title=f"self-test: seeded bugs at {report.spp} spp (gate level {report.alpha:.3g} per comparison)")
    for c in COLUMNS:
        t.add_column(c, justify="right" if "spp" in c or c == "image bias" else "left")
    for row in report.rows:
        cells = _cells(row)
        if not row["caught"]:
            cells[4] = "[bold red]NO[/]"
        t.add_row(*cells)
    return t


def markdown(report, command: str | None = None) -> str:
    """The table as Markdown (with the command that produced it, when given)."""
    lines = []
    if command:
        lines += [f"`{command}`", ""]
    lines += [markdown_table(COLUMNS, [_cells(r) for r in report.rows])]
    lines += ["", summary_line(report) + "; gate level per comparison "
              f"{report.alpha:.3g} (a default quick-suite run), Mitsuba's rule at its own alpha 0.01 per image. "
              "Last column: the unmutated tracer's verdicts on the same scene and strategy (gate / Mitsuba's rule)."]
    return "\n".join(lines) + "\n"


def _command_line() -> str | None:
    """This command as typed, when run from the console script (not from a test's main(argv))."""
    import shlex

    if sys.argv[1:2] != ["selftest"]:
        return None
    return "rtbench " + " ".join(shlex.quote(a) for a in sys.argv[1:])


def run(args) -> int:
    from benchmarks.commands._args import check, warn_tail_spp
    from benchmarks.commands._gate_tables import wide_console
    from benchmarks.gate.suite import names_of
    from benchmarks.selftest import CATALOGUE, run_selftest
    from benchmarks.store import write_json
    from reference_tracer.imageio import atomic_write

    if args.list:
        for m in CATALOGUE:
            print(f"{m.name} ({m.scene}, {m.strategy})\n  bug: {m.description}\n  breaks: {m.breaks}\n"
                  f"  why this scene: {m.why}")
        return 0
    check(args)
    names = names_of(",".join(args.mutants)) or None
    warn_tail_spp("selftest", args.tail_spp)
    if args.height is not None and args.height != args.width:
        raise ValueError("selftest renders square images: --height must equal --width")
    try:
        spp_ladder = [int(s) for s in args.spp_ladder.split(",") if s.strip()]
    except ValueError:
        raise ValueError(f"--spp-ladder must be comma-separated integers, got {args.spp_ladder!r}") from None

    def log(line):
        if not args.quiet:
            print(line, file=sys.stderr, flush=True)

    def on_row(row):
        log(f"{row['mutant']}: gate {row['verdict']}, Mitsuba's rule "
            f"{'caught' if row['caught_by_mitsuba_rule'] else 'passed'} it ({row['seconds']:.0f} s)")

    report = run_selftest(names, spp=args.spp, width=args.width, ref_spp=args.reference_spp, tail_spp=args.tail_spp,
                          spp_ladder=spp_ladder, seed=args.seed, controls=not args.no_controls,
                          threads=args.threads, cache=args.cache, on_row=on_row, log=log)
    console = wide_console(200)
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
        atomic_write(args.markdown, markdown(report, _command_line()))
    if report.passed:
        console.print(f"[green]self-test passed[/]: {summary_line(report)}")
        return 0
    print(f"rtbench selftest: FAIL {summary_line(report)} (needs >= 90% and no fewer than Mitsuba's rule)",
          file=sys.stderr)
    return 1
