"""``build_id``: which build of the tracer produced a result.

Results and cached renders of our tracer are only comparable within one build: a changed
constant in the C++ core or in the scene compiler changes the estimator. The build id is
a short hash of the compiled core and the package's Python sources, so caches keyed by it
never hand a new build an old build's images.
"""
from __future__ import annotations

import functools
import hashlib
import subprocess
from pathlib import Path

__all__ = ["build_id", "git_describe", "build_info"]


@functools.lru_cache(maxsize=1)
def build_id() -> str:
    """A 16-hex-digit hash of the compiled ``_core`` extension and ``reference_tracer/*.py``.

    Examples
    --------
    >>> len(build_id())
    16
    """
    from . import _core

    h = hashlib.sha256()
    here = Path(__file__).resolve().parent
    for path in [Path(_core.__file__)] + sorted(here.glob("*.py")):
        h.update(path.name.encode())
        h.update(path.read_bytes())
    return h.hexdigest()[:16]


@functools.lru_cache(maxsize=1)
def git_describe() -> str | None:
    """``git describe --always --dirty --tags`` of the repository the package runs from, or None.

    None when the package is not inside a git work tree (an installed wheel) or git is
    missing. It names the source revision for people; :func:`build_id` is what keys
    results (a dirty tree's ``-dirty`` says nothing of *what* changed).
    """
    here = Path(__file__).resolve().parent
    try:
        out = subprocess.run(["git", "-C", str(here), "describe", "--always", "--dirty", "--tags"],
                             capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return None
    text = out.stdout.strip()
    return text if out.returncode == 0 and text else None


def build_info() -> dict:
    """``{"build": build_id(), "build_git": git_describe()}``: what a record says of the build.

    Examples
    --------
    >>> sorted(build_info())
    ['build', 'build_git']
    """
    return {"build": build_id(), "build_git": git_describe()}
