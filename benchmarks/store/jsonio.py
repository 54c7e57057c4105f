"""The store's folder and its JSON files: created on demand, written atomically (NaN as null), read defensively;
the one way the harness and the report write the time (:func:`timestamp`)."""
from __future__ import annotations

import datetime as _dt
import json
import math
from pathlib import Path

import numpy as np

from reference_tracer.imageio import atomic_write

from ..files import confined_file, open_regular

#: largest ``meta.json`` / ``summary.json`` read (a store's are kilobytes).
MAX_JSON_BYTES = 64 << 20


def store_path(path) -> Path:
    """The store folder, created if needed; ``ValueError`` if ``path`` is something else."""
    p = Path(path).expanduser()
    if p.exists() and not p.is_dir():
        raise ValueError(f"results store {p} exists and is not a folder")
    p.mkdir(parents=True, exist_ok=True)
    return p


def timestamp(*, utc: bool = False, offset: bool = True) -> str:
    """Now as ISO 8601 to the second: local time with its UTC offset (the store's dates), in UTC with ``utc``,
    the local wall time alone without ``offset``.

    >>> len(timestamp()), timestamp(utc=True).endswith("+00:00"), len(timestamp(offset=False))
    (25, True, 19)
    """
    now = _dt.datetime.now(_dt.timezone.utc) if utc else _dt.datetime.now().astimezone()
    return (now if offset else now.replace(tzinfo=None)).isoformat(timespec="seconds")


def json_safe(value):
    """NaN/inf -> None and numpy scalars and arrays -> Python, recursively (JSON has no NaN)."""
    if isinstance(value, dict):
        return {str(k): json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    if isinstance(value, np.ndarray):
        return json_safe(value.tolist())
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, (float, np.floating)):
        v = float(value)
        return v if math.isfinite(v) else None
    if isinstance(value, Path):
        return str(value)
    return value


def write_json(path, obj) -> Path:
    """Write ``obj`` as indented, strict JSON (:func:`json_safe`: NaN and infinity as null)
    atomically (temp file in the same folder + rename; the folder created if needed)."""
    return atomic_write(path, json.dumps(json_safe(obj), indent=1, allow_nan=False) + "\n")


def store_file(store, name: str) -> Path:
    """The file ``name`` of a store, confined to the store folder (:func:`benchmarks.files.confined_file`, the one
    rule of every file a store reads, images too): a symbolic link may point elsewhere in the store, never out of
    it (``SECURITY.md``); :class:`~benchmarks.errors.InputError` otherwise."""
    return confined_file(store, name, what="store file")


def read_json(path, default=None, *, problems: list | None = None, store=None):
    """A JSON file's value; ``default`` if it is missing or does not parse (said in ``problems``).
    With ``store``, ``path`` is a file name in that store, refused alike when it leaves it (:func:`store_file`).

    >>> import os, tempfile
    >>> d, out = tempfile.mkdtemp(), tempfile.mkdtemp()
    >>> _ = write_json(os.path.join(out, "x.json"), {"a": 1})
    >>> os.symlink(os.path.join(out, "x.json"), os.path.join(d, "meta.json"))
    >>> problems = []
    >>> read_json("meta.json", {}, problems=problems, store=d), problems
    ({}, ["meta.json could not be read: store file path 'meta.json' leaves its folder through a symbolic link"])
    """
    name = Path(path).name
    try:
        path = store_file(store, str(path)) if store is not None else Path(path)
        with open_regular(path, max_bytes=MAX_JSON_BYTES) as f:
            return json.loads(f.read())
    except FileNotFoundError:
        why = "is missing"
    except RecursionError:
        why = "could not be read: JSON nested too deeply"
    except (OSError, ValueError) as exc:  # InputError too: not confined, not a regular file
        why = f"could not be read: {exc}"
    if problems is not None:
        problems.append(f"{name} {why}")
    return default
