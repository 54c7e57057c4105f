"""``rtbench``: the command-line entry point, one module per subcommand in ``benchmarks.commands``.

Here, once for every command: integer options are bounded before a value reaches the C++ core,
the shared options checked (:func:`benchmarks.commands._args.check`), and an exception becomes
its exit status (:func:`benchmarks.errors.exit_code`) and one line on stderr (``--debug``: the traceback).
"""
from __future__ import annotations

import os

# Idle OpenBLAS threads spin after each call and steal the renderers' cycles; the harness never
# needs parallel BLAS. Set before numpy is imported.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import functools  # noqa: E402
import importlib  # noqa: E402
import sys  # noqa: E402
import traceback  # noqa: E402
import warnings  # noqa: E402

from reference_tracer.imageio import check_writable  # noqa: E402
from reference_tracer.validation import INT_MAX, SEED_MAX  # noqa: E402

from benchmarks.commands._args import HelpFormatter, check  # noqa: E402
from benchmarks.errors import EXIT_CODES_HELP, EXIT_USAGE, exit_code, one_line  # noqa: E402
from benchmarks.text import terminal  # noqa: E402

#: the subcommands (modules of ``benchmarks.commands``) in the order ``rtbench --help`` shows them.
COMMANDS = ("run", "render", "reference", "curves", "report", "compare", "parity", "corpus", "gate", "stress", "speed",
            "chi2", "selftest")


def bounded_int(text: str, *, maximum: int = INT_MAX) -> int:
    """An integer option's value, refused (a usage error) beyond ``+-maximum``.

    >>> bounded_int("64")
    64
    >>> bounded_int(str(2**31))
    Traceback (most recent call last):
    ...
    argparse.ArgumentTypeError: 2147483648 is too large (at most 2147483647)
    """
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"invalid integer: {text!r}") from None
    if abs(value) > maximum:
        raise argparse.ArgumentTypeError(f"{value} is too large (at most {maximum})")
    return value


_seed_int = functools.partial(bounded_int, maximum=SEED_MAX)


class _Parser(argparse.ArgumentParser):
    """argparse with a usage error on one line (exit 2), the usage itself left to ``--help``."""

    def error(self, message):
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message} (see `{self.prog} --help`)\n")


class _CommandParser(_Parser):
    """A subcommand's parser (prog ``rtbench COMMAND``): an argument it does not know is its own usage error,
    ``rtbench COMMAND: error: unrecognized arguments: ...``. argparse would hand such arguments up to the
    top-level parser, whose error names no command."""

    def parse_known_args(self, args=None, namespace=None):
        namespace, extras = super().parse_known_args(args, namespace)
        if extras:
            self.error(f"unrecognized arguments: {' '.join(extras)}")
        return namespace, extras


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="rtbench", description="Validate and benchmark the reference path tracer against Mitsuba 3.",
        epilog=EXIT_CODES_HELP)
    parser.add_argument("--debug", action="store_true", help="show the traceback of an error")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_CommandParser)
    for name in COMMANDS:
        module = importlib.import_module(f"benchmarks.commands.{name}")
        # help is %-formatted by argparse, the description is not
        p = sub.add_parser(name, help=module.HELP.replace("%", "%%"), description=module.HELP,
                           epilog=EXIT_CODES_HELP, formatter_class=HelpFormatter)
        module.add_arguments(p)
        p.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                       help="show the traceback of an error (default: off; same as `rtbench --debug`)")
        for action in p._actions:  # every type=int option bounded (seeds: 64 bits)
            if action.type is int:
                action.type = _seed_int if "seed" in action.dest else bounded_int
        p.set_defaults(_run=module.run)
    return parser


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "_run", None):
        parser.print_help()
        return EXIT_USAGE
    try:
        with warnings.catch_warnings():
            if not args.debug:  # a warning is one line, as an error is (--debug: Python's, with its source line)
                warnings.showwarning = functools.partial(_warning_line, args.command)
            check(args)
            _probe_output_files(args)
            return int(args._run(args) or 0)
    except KeyboardInterrupt as exc:
        print("\ninterrupted", file=sys.stderr)
        return exit_code(exc)
    except Exception as exc:  # noqa: BLE001 - every error becomes one line and its exit status
        if args.debug:
            traceback.print_exception(exc)
        # the message may quote input (a store field, a file name): no terminal escapes from it
        print(terminal(f"rtbench {args.command}: error: {one_line(exc)}"), file=sys.stderr, flush=True)
        return exit_code(exc)


def _warning_line(command: str, message, category, filename, lineno, file=None, line=None) -> None:
    """``warnings.showwarning`` for a command: ``rtbench COMMAND: warning: ...`` on one line of stderr."""
    text = " ".join(str(message).split())
    print(terminal(f"rtbench {command}: warning: {text}"), file=file or sys.stderr, flush=True)


def _probe_output_files(args) -> None:
    """Refuse now, not after the run, an output file (``--json``, ``--markdown``, ``--svg``) that
    cannot be written as :func:`reference_tracer.imageio.atomic_write` writes it: ``OSError``
    (its folder cannot be made or written) or ``ValueError`` (a link, a folder or a special file
    there; ``-``, which names no file here), naming the option. The file itself is left as it is."""
    for option in ("json", "markdown", "svg"):
        value = getattr(args, option, None)
        if value == "-":
            example = {"json": "rows.json", "markdown": "report.md", "svg": "scaling.svg"}[option]
            raise ValueError(f"--{option} -: these outputs go to files, not to standard output (the command's "
                             f"tables go there); give a path, e.g. --{option} {example}")
        if isinstance(value, str) and value:
            try:
                check_writable(value)
            except OSError as exc:
                raise OSError(exc.errno, f"--{option} {value} cannot be written: {exc.strerror or exc}") from None
            except ValueError as exc:
                raise ValueError(f"--{option}: {exc}") from None


if __name__ == "__main__":
    sys.exit(main())
