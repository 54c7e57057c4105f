"""Files named by data: the one slug for file names, and paths confined to their folder.

Everything read from disk is untrusted (a results store somebody sent, a cache, a scene
file): a name read from it becomes a file name only through :func:`slug`, and a path read
from it is opened only through :func:`confined_file`, which keeps it inside its folder and
refuses anything but a regular file (a FIFO would block a reader forever, a device would
feed it without end). The threat model is in ``benchmarks/STORE.md``.

Examples
--------
>>> slug("cornell_box", "32x32", "rmse")
'cornell_box_32x32_rmse'
>>> slug("../../etc/passwd")
'etc_passwd'
"""
from __future__ import annotations

import hashlib
import os
import re
import stat
from pathlib import Path

from .errors import InputError

__all__ = ["MAX_SLUG", "slug", "confined_file", "open_regular"]

#: longest slug: with a suffix and a temporary file's prefix it stays under the usual
#: 255-byte limit of a file name.
MAX_SLUG = 120

_UNSAFE = re.compile(r"[^A-Za-z0-9_.+=-]+")


def slug(*parts) -> str:
    """A file name (without extension) made of ``parts`` joined by ``_``, safe on any file system.

    Characters other than letters, digits and ``_ . + = -`` become ``_``; leading dots and
    separators are dropped (no hidden files, no ``..``); a name longer than
    :data:`MAX_SLUG` is cut and ends with 8 hex digits of a hash of the whole name, so
    distinct long names stay distinct. ``None`` parts are skipped; an empty result is ``"x"``.

    Examples
    --------
    >>> slug("a/b", None, 3)
    'a_b_3'
    >>> len(slug("s" * 300)) == MAX_SLUG
    True
    """
    text = "_".join(str(p) for p in parts if p is not None)
    name = _UNSAFE.sub("_", text).strip("._-") or "x"
    if len(name) > MAX_SLUG:
        digest = hashlib.sha256(text.encode("utf-8", "surrogatepass")).hexdigest()[:8]
        name = f"{name[:MAX_SLUG - 9].rstrip('._-')}-{digest}"
    return name


def confined_file(folder, relpath, *, what: str = "file") -> Path:
    """The path ``relpath`` read from data, checked to stay inside ``folder``.

    ``relpath`` must be a non-empty relative path string without ``..``; after symbolic
    links are resolved it must still lie inside ``folder`` (also resolved). The file need
    not exist (callers report a missing file as such); if it exists it must be a regular
    file.

    Raises
    ------
    benchmarks.errors.InputError
        The path is absolute, climbs out with ``..``, leaves the folder through a link,
        is not a string, or names something other than a regular file.

    Examples
    --------
    >>> import tempfile
    >>> d = tempfile.mkdtemp()
    >>> confined_file(d, "images/a.exr").name
    'a.exr'
    >>> confined_file(d, "/etc/passwd")
    Traceback (most recent call last):
    ...
    benchmarks.errors.InputError: file path '/etc/passwd' must be relative to its folder
    """
    if not isinstance(relpath, str) or not relpath or "\x00" in relpath:
        raise InputError(f"{what} path {relpath!r:.80} is not a file name")
    rel = Path(relpath)
    if rel.is_absolute():
        raise InputError(f"{what} path {relpath!r:.200} must be relative to its folder")
    if ".." in rel.parts:
        raise InputError(f"{what} path {relpath!r:.200} climbs out of its folder ('..')")
    root = Path(folder).resolve()
    path = (root / rel).resolve()
    if path != root and root not in path.parents:
        raise InputError(f"{what} path {relpath!r:.200} leaves its folder through a symbolic link")
    try:
        st = os.stat(path)
    except FileNotFoundError:
        return path
    except OSError as exc:
        raise InputError(f"{what} {relpath!r:.200}: {exc.strerror}") from exc
    if not stat.S_ISREG(st.st_mode):
        raise InputError(f"{what} {relpath!r:.200} is not a regular file")
    return path


def open_regular(path, *, max_bytes: int | None = None):
    """Open ``path`` for reading in binary mode, refusing anything but a regular file.

    The file is opened without blocking (a FIFO opens at once instead of waiting for a
    writer) and checked with ``fstat`` on the open descriptor, so the check and the read
    concern the same file. With ``max_bytes``, a larger file is refused.

    Raises
    ------
    benchmarks.errors.InputError
        Not a regular file, or larger than ``max_bytes``.
    OSError
        The file cannot be opened.
    """
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise InputError(f"{path}: not a regular file")
        if max_bytes is not None and st.st_size > max_bytes:
            raise InputError(f"{path}: {st.st_size} bytes, more than the {max_bytes} allowed")
        os.set_blocking(fd, True)
        return os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise
