"""``rtbench``: the command-line entry point.

Each subcommand lives in its own module under ``benchmarks.commands`` and defines
``HELP`` (one line), ``add_arguments(parser)`` and ``run(args) -> int`` (exit code).
"""
from __future__ import annotations

import os

# Idle OpenBLAS worker threads (numpy/scipy) spin for a while after each call and steal
# cycles from the renderers' own threads; the harness never needs parallel BLAS. Must be
# set before numpy is imported.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import importlib  # noqa: E402
import sys  # noqa: E402

from benchmarks.commands._args import HelpFormatter  # noqa: E402  (every default shown in --help)

#: subcommand -> module; listed in the order ``rtbench --help`` shows them.
COMMANDS = {
    "run": "benchmarks.commands.run",
    "render": "benchmarks.commands.render",
    "reference": "benchmarks.commands.reference",
    "curves": "benchmarks.commands.curves",
    "report": "benchmarks.commands.report",
    "gate": "benchmarks.commands.gate",
    "stress": "benchmarks.commands.stress",
    "speed": "benchmarks.commands.speed",
    "chi2": "benchmarks.commands.chi2",
    "selftest": "benchmarks.commands.selftest",
}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="rtbench", description="Validate and benchmark the reference path tracer against Mitsuba 3.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, module_name in COMMANDS.items():
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as exc:
            if exc.name != module_name:
                raise
            continue  # subcommand not part of this build
        p = sub.add_parser(name, help=module.HELP, description=module.HELP, formatter_class=HelpFormatter)
        module.add_arguments(p)
        p.set_defaults(_run=module.run)
    return parser


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "_run", None):
        parser.print_help()
        return 2
    try:
        return int(args._run(args) or 0)
    except KeyboardInterrupt:
        print("\ninterrupted", file=sys.stderr)
        return 130
    except ValueError as exc:  # bad user input: one clear line, no traceback
        print(f"rtbench {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
