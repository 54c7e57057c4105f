"""Files named by data (untrusted, ``SECURITY.md``): a name read from disk becomes a file name only through
:func:`slug`, a path read from it is opened only through :func:`confined_file` and :func:`open_regular`
(a regular file, nothing else: a FIFO would block a reader, a device feed it without end)."""
from __future__ import annotations

import hashlib
import os
import re
import stat
from pathlib import Path

from reference_tracer.validation import open_regular_file

from .errors import InputError

__all__ = ["MAX_SLUG", "slug", "confined_file", "open_regular"]

#: longest slug: with a suffix and a temporary file's prefix it stays under a file name's 255 bytes.
MAX_SLUG = 120

_UNSAFE = re.compile(r"[^A-Za-z0-9_.+=-]+")


def slug(*parts) -> str:
    """A file name (without extension) of ``parts`` (None skipped) joined by ``_``, safe anywhere.

    Characters but letters, digits and ``_ . + = -`` become ``_``; leading dots and separators
    go (no hidden files, no ``..``); a name over :data:`MAX_SLUG` is cut and ends with 8 hex
    digits of a hash of the whole; an empty result is ``"x"``.

    >>> slug("a/b", None, 3), slug("../../etc/passwd"), len(slug("s" * 300)) == MAX_SLUG
    ('a_b_3', 'etc_passwd', True)
    """
    text = "_".join(str(p) for p in parts if p is not None)
    name = _UNSAFE.sub("_", text).strip("._-") or "x"
    if len(name) > MAX_SLUG:
        digest = hashlib.sha256(text.encode("utf-8", "surrogatepass")).hexdigest()[:8]
        name = f"{name[:MAX_SLUG - 9].rstrip('._-')}-{digest}"
    return name


def confined_file(folder, relpath, *, what: str = "file") -> Path:
    """The path ``relpath`` read from data, checked to stay inside ``folder`` (links resolved).

    :class:`~benchmarks.errors.InputError` for a path that is no relative file name, climbs
    out with ``..`` or a link, or names anything but a regular file; it need not exist.

    >>> import tempfile
    >>> confined_file(tempfile.mkdtemp(), "/etc/passwd")
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
    """:func:`reference_tracer.validation.open_regular_file` (binary, a regular file or
    ``ValueError``), refusing a file over ``max_bytes`` too."""
    f = open_regular_file(path, "a file to read")
    size = os.fstat(f.fileno()).st_size
    if max_bytes is not None and size > max_bytes:
        f.close()
        raise InputError(f"{path}: {size} bytes, more than the {max_bytes} allowed")
    return f
