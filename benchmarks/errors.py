"""The harness's error class and the exit status of each kind of failure (docs/rtbench.md, Exit status and
errors; :data:`EXIT_CODES_HELP`): usage or bad input (``ValueError``, ``OverflowError``) is 2, any other error 3.

>>> exit_code(ValueError("--spp must be >= 1")), exit_code(OSError(28, "No space left on device"))
(2, 3)
>>> one_line(FileNotFoundError(2, "No such file or directory", "/nope/x.exr"))
'/nope/x.exr: No such file or directory'
"""
from __future__ import annotations

import errno

EXIT_FAIL = 1
EXIT_USAGE = 2
EXIT_ERROR = 3
#: Ctrl-C (128 + SIGINT), as a shell reports it.
EXIT_INTERRUPTED = 130

#: the epilog of every ``--help``.
EXIT_CODES_HELP = ("exit status: 0 pass; 1 a verdict failed (gate drift, stress case, chi-square test, self-test); "
                   "2 usage or bad input; 3 internal or I/O error (unreadable or unwritable file, full disk, "
                   "out of memory); 130 interrupted. Errors are one line on stderr; `rtbench --debug COMMAND ...` "
                   "adds the traceback.")


class InputError(ValueError):
    """Input data that is not what it should be: a corrupt store, a file that is not a mesh (exit 2)."""


def exit_code(exc: BaseException) -> int:
    """The exit status for an exception that ended a command."""
    if isinstance(exc, KeyboardInterrupt):
        return EXIT_INTERRUPTED
    return EXIT_USAGE if isinstance(exc, (ValueError, OverflowError)) else EXIT_ERROR


def one_line(exc: BaseException) -> str:
    """One line of text for an error message: what went wrong, with the file it concerns."""
    if isinstance(exc, MemoryError):
        return f"out of memory{': ' + str(exc) if str(exc) else ''} (use a smaller image, fewer spp or threads)"
    if isinstance(exc, OSError) and exc.strerror:
        where = f"{exc.filename}: " if exc.filename is not None else ""
        if exc.filename2 is not None:
            where = f"{exc.filename} -> {exc.filename2}: "
        hint = {errno.ENOSPC: " (disk full)", errno.EROFS: " (read-only file system)",
                errno.EEXIST: " (a folder was expected there)",
                errno.ENOTDIR: " (a folder was expected, not a file)"}.get(exc.errno, "")
        return f"{where}{exc.strerror}{hint}"
    if isinstance(exc, OverflowError):
        return f"number out of range: {exc}"
    text = " ".join(str(exc).split())
    if not isinstance(exc, (ValueError, OSError)):
        return f"internal error: {type(exc).__name__}: {text}" if text else f"internal error: {type(exc).__name__}"
    return text or type(exc).__name__
