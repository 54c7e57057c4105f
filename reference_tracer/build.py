"""``build_id``: which build of the tracer produced a result.

Results and cached renders of our tracer are only comparable within one build: a changed
constant in the C++ core or in the scene compiler changes the estimator. The build id is
a short hash of the compiled core and the package's Python sources, so caches keyed by it
never hand a new build an old build's images.
"""
from __future__ import annotations

import functools
import hashlib
from pathlib import Path

__all__ = ["build_id"]


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
