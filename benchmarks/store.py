"""The results store: an append-only folder of job records, images and run metadata.

Layout and field names are fixed by ``benchmarks/STORE.md`` (the contract with
``reports``). This module only reads and writes; it knows nothing about rendering.

Durability
----------
* ``results.jsonl`` gets one line per finished job, written with a single ``write``
  followed by ``flush`` and ``fsync``: once :func:`append_record` returns, the record
  survives a crash or ``SIGKILL`` of the process.
* A process killed in the middle of a write can leave a truncated last line. Readers
  skip a final line that does not parse; :func:`append_record` cuts such a fragment off
  before appending, so a resumed run never glues a new record onto it.
* Everything else (``meta.json``, ``summary.json``, EXR images) is written to a
  temporary file in the same folder and renamed into place (atomic on POSIX).

Examples
--------
>>> import tempfile
>>> from benchmarks.store import append_record, read_records, finished_keys
>>> d = tempfile.mkdtemp()
>>> append_record(d, {"scene": "s", "renderer": "ours", "strategy": "mis", "spp": 4,
...                   "seed": 0, "width": 8, "height": 8, "mse": 0.1})
>>> [r["mse"] for r in read_records(d)]
[0.1]
>>> sorted(finished_keys(d))
[('s', 'ours', 'mis', 4, 0, 8, 8)]
"""
from __future__ import annotations

import json
import math
import os
import tempfile
import warnings
from pathlib import Path

import numpy as np

__all__ = ["KEY_FIELDS", "RESULTS", "META", "SUMMARY", "record_key", "store_path",
           "append_record", "read_records", "finished_keys", "write_json", "read_json",
           "update_meta", "write_image", "read_image"]

#: fields that identify a job (``STORE.md``): a resumed run skips records with these.
KEY_FIELDS = ("scene", "renderer", "strategy", "spp", "seed", "width", "height")
RESULTS = "results.jsonl"
META = "meta.json"
SUMMARY = "summary.json"


def record_key(record: dict) -> tuple:
    """The identity of a job record, ``(scene, renderer, strategy, spp, seed, width, height)``.

    Examples
    --------
    >>> record_key({"scene": "s", "renderer": "ours", "strategy": "mis", "spp": 4,
    ...             "seed": 0, "width": 8, "height": 8, "mse": 1.0})
    ('s', 'ours', 'mis', 4, 0, 8, 8)
    """
    missing = [k for k in KEY_FIELDS if k not in record]
    if missing:
        raise ValueError(f"record lacks key field(s) {missing}: {record!r:.200}")
    return tuple(record[k] for k in KEY_FIELDS)


def store_path(path) -> Path:
    """Validate a store folder path and create the folder (and parents) if needed.

    Raises ``ValueError`` if ``path`` exists and is not a folder.
    """
    p = Path(path).expanduser()
    if p.exists() and not p.is_dir():
        raise ValueError(f"results store {p} exists and is not a folder")
    p.mkdir(parents=True, exist_ok=True)
    return p


def _json_safe(value):
    """NaN/inf -> None and numpy scalars -> Python, recursively (JSON has no NaN)."""
    if isinstance(value, dict):
        return {str(k): _json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(v) for v in value]
    if isinstance(value, (np.bool_,)):
        return bool(value)
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, (float, np.floating)):
        v = float(value)
        return v if math.isfinite(v) else None
    if isinstance(value, Path):
        return str(value)
    return value


def _drop_partial_tail(path: Path) -> None:
    """Cut a final line that lacks its newline (a write killed half-way)."""
    size = path.stat().st_size
    if size == 0:
        return
    with open(path, "rb+") as f:
        f.seek(size - 1)
        if f.read(1) == b"\n":
            return
        # find the last newline; everything after it is a fragment
        block = 1 << 16
        pos = size
        cut = 0
        while pos > 0:
            start = max(0, pos - block)
            f.seek(start)
            chunk = f.read(pos - start)
            i = chunk.rfind(b"\n")
            if i >= 0:
                cut = start + i + 1
                break
            pos = start
        f.truncate(cut)
        f.flush()
        os.fsync(f.fileno())


def append_record(store, record: dict) -> None:
    """Append one job record to ``results.jsonl`` durably (write, flush, fsync).

    NaN and infinite floats are written as ``null``. A truncated final line left by a
    killed writer is removed first.

    Parameters
    ----------
    store : str or Path
        The store folder (created if missing).
    record : dict
        Must hold :data:`KEY_FIELDS`.
    """
    record_key(record)
    path = store_path(store) / RESULTS
    line = json.dumps(_json_safe(record), sort_keys=False, allow_nan=False) + "\n"
    if path.exists():
        _drop_partial_tail(path)
    fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
    try:
        data = line.encode()
        written = 0
        while written < len(data):
            written += os.write(fd, data[written:])
        os.fsync(fd)
    finally:
        os.close(fd)


def read_records(store, *, dedupe: bool = True) -> list:
    """Job records of a store, in file order.

    A last line that does not parse (a killed writer) is skipped silently; an unreadable
    line elsewhere is skipped with a ``RuntimeWarning``. With ``dedupe`` (default), a
    key that occurs several times keeps its last record, at the position of its first.

    Returns
    -------
    list of dict
        Empty when the store or its ``results.jsonl`` does not exist.
    """
    path = Path(store) / RESULTS
    if not path.exists():
        return []
    lines = path.read_bytes().split(b"\n")
    out = []
    last = len(lines) - 1
    while last >= 0 and not lines[last].strip():
        last -= 1
    for i, raw in enumerate(lines[:last + 1]):
        if not raw.strip():
            continue
        try:
            rec = json.loads(raw)
            record_key(rec)
        except (ValueError, UnicodeDecodeError):
            if i != last:
                warnings.warn(f"{path}: line {i + 1} is not a job record; skipped", RuntimeWarning,
                              stacklevel=2)
            continue
        out.append(rec)
    if not dedupe:
        return out
    by_key: dict = {}
    for rec in out:
        by_key[record_key(rec)] = rec  # a dict keeps the first position, takes the last value
    return list(by_key.values())


def finished_keys(store) -> set:
    """Keys (:func:`record_key`) of the jobs already recorded in a store."""
    return {record_key(r) for r in read_records(store, dedupe=False)}


def atomic_write_text(path, text: str) -> Path:
    """Write ``text`` to ``path`` atomically: a temp file in the same folder, fsync, rename.

    A reader sees the old file or the new one, never a partial write (readable: 0644).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, 0o644)  # mkstemp makes 0600 files
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path


def write_json(path, obj) -> Path:
    """Write ``obj`` as indented JSON atomically (temp file in the same folder + rename)."""
    return atomic_write_text(path, json.dumps(_json_safe(obj), indent=1, allow_nan=False) + "\n")


def read_json(path, default=None):
    """Read a JSON file; ``default`` if it is missing or does not parse."""
    try:
        return json.loads(Path(path).read_text())
    except (OSError, ValueError):
        return default


def update_meta(store, **fields) -> dict:
    """Merge ``fields`` into ``meta.json`` (dict values are merged one level deep).

    Returns the new metadata.

    Examples
    --------
    >>> import tempfile
    >>> d = tempfile.mkdtemp()
    >>> _ = update_meta(d, preset="quick", references={"a": {"spp": 4}})
    >>> update_meta(d, references={"b": {"spp": 8}})["references"]
    {'a': {'spp': 4}, 'b': {'spp': 8}}
    """
    path = store_path(store) / META
    meta = read_json(path, default={})
    if not isinstance(meta, dict):
        meta = {}
    for k, v in fields.items():
        if isinstance(v, dict) and isinstance(meta.get(k), dict):
            meta[k] = {**meta[k], **v}
        else:
            meta[k] = v
    write_json(path, meta)
    return meta


def write_image(store, relpath, image) -> str:
    """Write an EXR image under the store atomically; return the store-relative path."""
    import reference_tracer as rt

    rel = Path(relpath)
    if rel.is_absolute() or ".." in rel.parts:
        raise ValueError(f"image path must be relative to the store, got {relpath}")
    path = Path(store) / rel
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem}.", suffix=".exr")
    os.close(fd)
    try:
        rt.write_exr(tmp, np.asarray(image, dtype=np.float32))
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return rel.as_posix()


def read_image(store, relpath) -> np.ndarray:
    """Read an EXR image stored under ``store`` as (H, W, C) float32."""
    import reference_tracer as rt

    return rt.read_exr(Path(store) / relpath)
