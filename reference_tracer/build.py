"""``build_id``: which build of the tracer produced a result.

Results and cached renders of our tracer are only comparable within one build: a changed
constant in the C++ core or in the scene compiler changes the estimator. The build id is
a short hash of the compiled core and the package's Python sources, so caches keyed by it
never hand a new build an old build's images.
"""
from __future__ import annotations

import functools
import hashlib
import importlib.util
import subprocess
import sys
from pathlib import Path

__all__ = ["build_id", "git_describe", "build_info", "core_path", "use_core"]


def core_path() -> Path:
    """The file of the compiled core this interpreter runs (loading it).

    Examples
    --------
    >>> core_path().suffix
    '.so'
    """
    from . import _core  # the C++ core loads on first use: the package's pure-Python parts work without it

    return Path(_core.__file__)


def use_core(path) -> None:
    """Make the compiled core at ``path`` the one this interpreter runs.

    For comparing builds of the core (``benchmarks.speed.builds``): call it first thing
    in a fresh interpreter, before anything loads the core; the installed core is then
    never loaded.

    Parameters
    ----------
    path : str or os.PathLike
        A compiled ``_core`` extension module (another build of the same sources).

    Raises
    ------
    RuntimeError
        When this interpreter has already loaded a core.
    ImportError
        When ``path`` is not a loadable core module.
    """
    name = f"{__package__}._core"
    if name in sys.modules:
        raise RuntimeError(f"a core is already loaded ({sys.modules[name].__file__}); call use_core first thing "
                           "in a fresh interpreter")
    spec = importlib.util.spec_from_file_location(name, str(path))
    if spec is None or spec.loader is None:
        raise ImportError(f"no core module at {path}")
    core = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(core)
    sys.modules[name] = core
    setattr(sys.modules[__package__], "_core", core)


@functools.lru_cache(maxsize=1)
def build_id() -> str:
    """A 16-hex-digit hash of the compiled ``_core`` extension and ``reference_tracer/**/*.py``.

    Examples
    --------
    >>> len(build_id())
    16
    """
    h = hashlib.sha256()
    here = Path(__file__).resolve().parent
    core = core_path()
    h.update(core.name.encode())
    h.update(core.read_bytes())
    # the sub-packages' sources too (meshfile/), each by its path in the package: a
    # sub-package has an __init__.py as the package has
    for path in sorted(here.rglob("*.py")):
        h.update(path.relative_to(here).as_posix().encode())
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
