"""Loud validation of user input: every error names the offending field.

The tracer's constructors and :func:`reference_tracer.render` check their arguments with
these functions once, at the boundary; the harness (``benchmarks``) checks its own
options with the same functions, so a count or a seed is held to the same limits
everywhere (the C++ core's ``int`` and ``uint64_t``).

Examples
--------
>>> from reference_tracer.validation import positive_int, vector3
>>> positive_int("spp", 64)
64
>>> vector3("lookfrom", [0, 1, -4])
(0.0, 1.0, -4.0)
"""
from __future__ import annotations

import math
import os
import stat
from pathlib import Path

import numpy as np

__all__ = ["finite_scalar", "flag", "not_directions", "face_index_problem", "check_face_indices", "vector3", "colour", "positive_int", "integrator_depths",
           "open_regular_file", "FLOAT32_MAX", "INT_MAX", "SEED_MAX"]


def finite_scalar(name: str, value, *, lo: float | None = None, hi: float | None = None,
                  lo_open: bool = False) -> float:
    """Return ``value`` as a finite float within the given bounds.

    Parameters
    ----------
    name : str
        The field's name, quoted in the error.
    value : object
        Anything ``float()`` accepts.
    lo, hi : float, optional
        Inclusive lower and upper bounds (``lo`` exclusive with ``lo_open=True``).
    lo_open : bool, optional
        Make the lower bound exclusive.

    Returns
    -------
    float

    Raises
    ------
    ValueError
        When ``value`` is not a number, is NaN or infinite, or lies outside the bounds.

    Examples
    --------
    >>> finite_scalar("fuzz", "0.25", lo=0, hi=1)
    0.25
    >>> finite_scalar("ior", 0.0, lo=0, lo_open=True)
    Traceback (most recent call last):
    ...
    ValueError: ior must be > 0, got 0.0
    """
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(x):
        raise ValueError(f"{name} must be finite, got {x!r}")
    if lo is not None and (x < lo or (lo_open and x == lo)):
        raise ValueError(f"{name} must be {'>' if lo_open else '>='} {lo}, got {x!r}")
    if hi is not None and x > hi:
        raise ValueError(f"{name} must be <= {hi}, got {x!r}")
    return x


def flag(name: str, value) -> bool:
    """``value`` as a bool: True, False (or 1, 0); anything else (a string, None) is refused.

    Examples
    --------
    >>> flag("two_sided", 1)
    True
    >>> flag("two_sided", "false")
    Traceback (most recent call last):
    ...
    ValueError: two_sided must be True or False, got 'false'
    """
    if isinstance(value, (bool, np.bool_)) or (isinstance(value, (int, np.integer)) and value in (0, 1)):
        return bool(value)
    raise ValueError(f"{name} must be True or False, got {value!r}")


def face_index_problem(faces, n_vertices: int) -> str | None:
    """``"face i is [a, b, c], a vertex index out of range [0, n)"`` for the first row of
    ``faces`` (M, 3) with an index outside ``[0, n_vertices)`` (negative, not a number, or a
    fraction whose next integer is past the last vertex: a PLY list of floats), else None.
    The one test of every mesh's faces (``Mesh``, its files, the importer's meshes).

    >>> face_index_problem(np.array([[0, 1, 2], [0, 2, 7]]), 3)
    'face 1 is [0, 2, 7], a vertex index out of range [0, 3)'
    """
    faces = np.asarray(faces)
    bad = ~np.all((faces >= 0) & (np.ceil(faces) < n_vertices), axis=1)
    if not bad.any():
        return None
    i = int(np.argmax(bad))
    return f"face {i} is {faces[i].tolist()}, a vertex index out of range [0, {n_vertices})"


def check_face_indices(faces, n_vertices: int, where: str) -> None:
    """``ValueError`` ``"{where}: "`` and :func:`face_index_problem` where it finds one."""
    problem = face_index_problem(faces, n_vertices)
    if problem is not None:
        raise ValueError(f"{where}: {problem}")


def not_directions(rows) -> np.ndarray:
    """Which rows of an (N, 3) array are no direction: not finite, or zero (a normal that
    would shade as NaN).

    Examples
    --------
    >>> not_directions(np.array([[0.0, 0.0, 2.0], [0.0, 0.0, 0.0], [np.nan, 1.0, 0.0]])).tolist()
    [False, True, True]
    """
    return ~(np.all(np.isfinite(rows), axis=1) & np.any(rows != 0.0, axis=1))


def vector3(name: str, value) -> tuple:
    """Return a finite 3-vector as a tuple of floats.

    Parameters
    ----------
    name : str
        The field's name, quoted in the error.
    value : array_like
        Three numbers.

    Returns
    -------
    tuple of float

    Raises
    ------
    ValueError
        When ``value`` is not three finite numbers.

    Examples
    --------
    >>> vector3("vup", (0, 1, 0))
    (0.0, 1.0, 0.0)
    >>> vector3("vup", (0, 1))
    Traceback (most recent call last):
    ...
    ValueError: vup must be a 3-vector, got shape (2,)
    """
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a 3-vector of numbers, got {value!r}") from None
    if a.shape != (3,):
        raise ValueError(f"{name} must be a 3-vector, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite (no NaN/Inf), got {tuple(a.tolist())}")
    return tuple(float(x) for x in a)


#: the largest value of the float32 images both renderers write: radiance above it is infinite there.
FLOAT32_MAX = float(np.finfo(np.float32).max)


def colour(name: str, value, *, upper: float | None) -> tuple:
    """Return an RGB triple with components in ``[0, upper]``; a scalar is broadcast.

    Parameters
    ----------
    name : str
        The field's name, quoted in the error.
    value : float or array_like
        A number or three numbers.
    upper : float or None
        The largest component (1 for a reflectance). ``None`` (radiance) means
        :data:`FLOAT32_MAX`: a radiance the image cannot hold would turn every pixel it
        reaches infinite.

    Returns
    -------
    tuple of float

    Raises
    ------
    ValueError
        When ``value`` is not one or three finite numbers in range.

    Examples
    --------
    >>> colour("albedo", 0.5, upper=1.0)
    (0.5, 0.5, 0.5)
    >>> colour("albedo", (0.2, 1.5, 0.1), upper=1.0)
    Traceback (most recent call last):
    ...
    ValueError: albedo must lie in [0, 1.0], got (0.2, 1.5, 0.1)
    """
    a = np.asarray(value, dtype=np.float64) if not isinstance(value, (str, bytes)) else None
    if a is None or a.ndim > 1 or (a.ndim == 1 and a.shape != (3,)):
        raise ValueError(f"{name} must be a number or an RGB triple, got {value!r}")
    a = np.broadcast_to(a, (3,))
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite (no NaN/Inf), got {tuple(a.tolist())}")
    if np.any(a < 0):
        raise ValueError(f"{name} must be >= 0, got {tuple(a.tolist())}")
    if upper is not None and np.any(a > upper):
        raise ValueError(f"{name} must lie in [0, {upper}], got {tuple(a.tolist())}")
    if upper is None and np.any(a > FLOAT32_MAX):
        raise ValueError(f"{name} must be at most {FLOAT32_MAX:.7g} (the largest value of a float32 image), "
                         f"got {tuple(a.tolist())}")
    return tuple(float(x) for x in a)


#: the largest count the C++ core takes (its ``int``: spp, threads, image size, depth).
INT_MAX = 2**31 - 1
#: the largest seed (the core's ``uint64_t``).
SEED_MAX = 2**64 - 1


def positive_int(name: str, value, *, minimum: int = 1, maximum: int = INT_MAX) -> int:
    """Return ``value`` as an int in ``[minimum, maximum]``.

    Parameters
    ----------
    name : str
        The field's name, quoted in the error.
    value : int
        A Python or numpy integer (``bool`` is refused).
    minimum : int, optional
        The smallest value accepted (default 1).
    maximum : int, optional
        The largest value accepted. The default, :data:`INT_MAX`, is the C++ core's
        ``int``: a larger value would reach the binding and fail there with a message
        naming no field. Seeds pass ``maximum=SEED_MAX``.

    Returns
    -------
    int

    Raises
    ------
    ValueError
        When ``value`` is not an integer or lies outside the bounds.

    Examples
    --------
    >>> positive_int("seed", 0, minimum=0, maximum=SEED_MAX)
    0
    >>> positive_int("spp", 2**31)
    Traceback (most recent call last):
    ...
    ValueError: spp must be <= 2147483647, got 2147483648
    """
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{name} must be an integer, got {value!r}")
    if value < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {value}")
    if value > maximum:
        raise ValueError(f"{name} must be <= {maximum}, got {value}")
    return int(value)


def integrator_depths(max_depth, rr_depth) -> tuple:
    """``(max_depth, rr_depth)`` as :class:`Scene` holds them: ``max_depth`` an integer >= 1 or
    -1 (unlimited), ``rr_depth`` None (no Russian roulette) or an integer >= 1; else
    ``ValueError`` naming the field. The scene's own check, for a reader of the integrator's
    settings (the Mitsuba importer) to apply where they are written.

    Examples
    --------
    >>> integrator_depths(8, 5)
    (8, 5)
    >>> integrator_depths(-5, None)
    Traceback (most recent call last):
    ...
    ValueError: Scene.max_depth must be an integer >= 1 or -1 (unlimited), got -5
    """
    md = max_depth
    if isinstance(md, bool) or not isinstance(md, (int, np.integer)) or not (md == -1 or md >= 1):
        raise ValueError(f"Scene.max_depth must be an integer >= 1 or -1 (unlimited), got {md!r}")
    return int(md), None if rr_depth is None else positive_int("Scene.rr_depth", rr_depth)


def open_regular_file(path, what: str):
    """Open ``path`` for binary reading, after checking it is a regular file.

    The file is opened without blocking and checked on its descriptor (no race between the
    check and the open): a FIFO would block the reader and a device such as ``/dev/zero``
    never end, so each is refused as bad input before a byte is read.

    Parameters
    ----------
    path : str or os.PathLike
    what : str
        What the file should be, for the message ("a mesh file", "an image file").

    Raises
    ------
    ValueError
        Not a regular file (a FIFO, a device, a folder).
    OSError
        The file cannot be opened.

    Examples
    --------
    >>> open_regular_file("/dev/null", "a mesh file")
    Traceback (most recent call last):
    ...
    ValueError: /dev/null is not a mesh file: not a regular file
    """
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            raise ValueError(f"{Path(path)} is not {what}: not a regular file")
        os.set_blocking(fd, True)
        return os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise
