"""``rtbench stress [--quick] [--case NAME ...] [--json PATH]``: numerical stability on hard cases."""
from __future__ import annotations

from benchmarks.commands import _args as A

HELP = "run the hard-case suite (watertight meshes, grazing rays, degenerate input, scale, ...) and print a table"


def add_arguments(parser) -> None:
    from benchmarks.stress import CASES

    parser.add_argument("--quick", action="store_true",
                        help="smaller settings (1e5 watertight rays instead of 4e6, fewer samples): ~30 s")
    parser.add_argument("--case", action="append", metavar="NAME", choices=list(CASES),
                        help=f"run only this case (repeatable; default: every case); one of: {', '.join(CASES)}")
    A.add_json_arg(parser)
    A.add_quiet_arg(parser)


def run(args) -> int:
    from benchmarks.store import write_json
    from benchmarks.stress import run_cases
    from benchmarks.text import terminal, text_table

    def progress(rec):
        if not args.quiet:
            print(terminal(f"  {rec.case}: {rec.verdict} ({rec.seconds:.1f} s)"), flush=True)

    records = run_cases(args.case, quick=args.quick, on_record=progress)
    if not args.quiet:
        print(f"rtbench stress ({'quick' if args.quick else 'full'})")
        print(text_table(["case", "verdict", "s", "figure"],
                         [[r.case, r.verdict, f"{r.seconds:.1f}", r.figure] for r in records]))
    print(f"rtbench stress: {sum(r.passed for r in records)} of {len(records)} case(s) passed")
    if args.json:
        write_json(args.json, [{"case": r.case, "figure": r.figure, "verdict": r.verdict, "seconds": r.seconds,
                                "details": r.details} for r in records])
    failed = [r.case for r in records if not r.passed]
    if failed:
        print(f"failed: {', '.join(failed)}")
    return 1 if failed else 0
