"""The results store: an append-only folder of job records, images and run metadata.

Layout and field names are fixed by ``benchmarks/STORE.md``. This module is the only
code that knows the format: the harness writes through it and ``reports`` reads through
it (records, keys, dedupe, torn lines, images, ``meta.json`` and ``summary.json``). It
only reads and writes; it knows nothing about rendering, and it reads and writes EXR with
:mod:`reference_tracer.imageio` (pure Python: the tracer's C++ core is not loaded).

Durability
----------
* ``results.jsonl`` gets one line per finished job, written with a single ``write``
  followed by ``flush`` and ``fsync``: once :func:`append_record` returns, the record
  survives a crash or ``SIGKILL`` of the process.
* A process killed in the middle of a write can leave a truncated last line. Readers
  skip a final line that does not parse (:func:`result_lines` marks it ``last``);
  :func:`append_record` cuts such a fragment off before appending, so a resumed run never
  glues a new record onto it. A complete last line that merely lacks its newline is a
  record: it is kept, and the next append adds the newline first.
* Everything else (``meta.json``, ``summary.json``, EXR images) is written to a
  temporary file in the same folder and renamed into place
  (:func:`reference_tracer.imageio.atomic_write`).

Untrusted input
---------------
A store may come from anybody. Nothing read from it is executed; a path read from it is
opened only inside the store and only if it is a regular file (:func:`image_path`); an
image larger than its header allows is refused before decoding; JSON nested too deeply
is bad input, not a crash. The threat model is in ``SECURITY.md``.

Concurrency
-----------
* Appends lock ``results.jsonl`` (``flock``) for the check of its end and the write.
* A run holds the store's writer lock (:func:`writer_lock`) from start to end; a second
  run on the same store waits for it, then resumes. Never a duplicated or lost record.
* Readers take no lock and never wait: every file they read is either replaced
  atomically or only appended to, and a torn last line is skipped.

Examples
--------
>>> import tempfile
>>> from benchmarks.store import append_record, read_records, finished_keys
>>> d = tempfile.mkdtemp()
>>> append_record(d, {"scene": "s", "renderer": "ours", "strategy": "mis", "spp": 4,
...                   "seed": 0, "width": 8, "height": 8, "build": "ab12", "mse": 0.1})
>>> [r["mse"] for r in read_records(d)]
[0.1]
>>> sorted(finished_keys(d))
[('s', 'ours', 'mis', 4, 0, 8, 8, 'ab12')]
"""
from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import math
import os
import socket
import warnings
from pathlib import Path
from typing import NamedTuple

import numpy as np

from reference_tracer import imageio
from reference_tracer.imageio import atomic_write

from .errors import InputError
from .files import confined_file, open_regular

__all__ = ["KEY_FIELDS", "BUILD_FIELD", "curve_of", "latest_builds", "RESULTS", "META", "SUMMARY", "record_key",
           "store_path", "append_record", "writer_lock", "WRITER_LOCK", "ResultLine", "result_lines", "skipped_line",
           "job_records", "read_records", "dedupe_records",
           "finished_keys", "check_identity", "write_json", "read_json", "read_meta",
           "read_summary_rows", "read_headline", "update_meta", "write_image", "read_image", "image_path", "file_sha256"]

#: fields that identify a job (``STORE.md``): a resumed run skips records with these.
KEY_FIELDS = ("scene", "renderer", "strategy", "spp", "seed", "width", "height")
#: the build that rendered a record (ours: ``reference_tracer.build_id()``; Mitsuba: its
#: version and variant): the last part of a job's key, so that a run with another build
#: renders again instead of reusing the old build's records (``STORE.md``).
BUILD_FIELD = "build"
RESULTS = "results.jsonl"
META = "meta.json"
SUMMARY = "summary.json"
#: largest ``meta.json`` / ``summary.json`` read (a store's are kilobytes).
MAX_JSON_BYTES = 64 << 20
#: the lock file of :func:`writer_lock`.
WRITER_LOCK = ".writer.lock"


def record_key(record: dict, *, partial: bool = False) -> tuple:
    """The identity of a job record, ``(scene, renderer, strategy, spp, seed, width, height, build)``.

    Raises ``ValueError`` if a field of :data:`KEY_FIELDS` is missing, unless ``partial``:
    then a missing field reads as ``None`` (a reader that tolerates incomplete records,
    like the report). The build (:data:`BUILD_FIELD`) may be missing (stores written
    before builds were recorded): it reads as ``None``.

    Examples
    --------
    >>> record_key({"scene": "s", "renderer": "ours", "strategy": "mis", "spp": 4,
    ...             "seed": 0, "width": 8, "height": 8, "build": "ab12", "mse": 1.0})
    ('s', 'ours', 'mis', 4, 0, 8, 8, 'ab12')
    >>> record_key({"scene": "s", "renderer": "ours", "strategy": "mis", "spp": 4}, partial=True)
    ('s', 'ours', 'mis', 4, None, None, None, None)
    """
    if partial:
        return tuple(record.get(k) for k in KEY_FIELDS) + (record.get(BUILD_FIELD),)
    missing = [k for k in KEY_FIELDS if k not in record]
    if missing:
        raise ValueError(f"record lacks key field(s) {missing}: {record!r:.200}")
    return tuple(record[k] for k in KEY_FIELDS) + (record.get(BUILD_FIELD),)


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


def _last_line_start(f, size: int) -> int:
    """Offset just after the last newline of an open file of ``size`` bytes (0 if none)."""
    block = 1 << 16
    pos = size
    while pos > 0:
        start = max(0, pos - block)
        f.seek(start)
        chunk = f.read(pos - start)
        i = chunk.rfind(b"\n")
        if i >= 0:
            return start + i + 1
        pos = start
    return 0


def _repair_tail(fd: int) -> bytes:
    """Make the end of ``results.jsonl`` ready for an append; return the bytes to write first.

    A final line without its newline is either a complete record (written by hand or by a
    tool that omits the last newline): it is kept and gets its newline (returned as
    ``b"\\n"``); or a fragment that does not parse (a writer killed half-way): it is cut
    off. Called with the file locked (:func:`append_record`), so no live writer is in the
    middle of that line.
    """
    size = os.fstat(fd).st_size
    if size == 0:
        return b""
    with open(fd, "rb", closefd=False) as f:
        f.seek(size - 1)
        if f.read(1) == b"\n":
            return b""
        cut = _last_line_start(f, size)
        f.seek(cut)
        tail = f.read()
    try:
        json.loads(tail)
    except (ValueError, UnicodeDecodeError):
        os.ftruncate(fd, cut)
        os.fsync(fd)
        return b""
    return b"\n"


@contextlib.contextmanager
def _flocked(fd: int):
    fcntl.flock(fd, fcntl.LOCK_EX)
    try:
        yield
    finally:
        fcntl.flock(fd, fcntl.LOCK_UN)


def append_record(store, record: dict) -> None:
    """Append one job record to ``results.jsonl`` durably (write, flush, fsync).

    NaN and infinite floats are written as ``null``. The file is locked (``flock``) while
    its end is checked and the line written, so appends of several processes never
    interleave. A final line left without its newline is kept if it is a complete JSON
    value (it gets its newline) and cut off if it does not parse (a killed writer).

    Parameters
    ----------
    store : str or Path
        The store folder (created if missing).
    record : dict
        Must hold :data:`KEY_FIELDS`.
    """
    record_key(record)
    path = store_path(store) / RESULTS
    data = (json.dumps(_json_safe(record), sort_keys=False, allow_nan=False) + "\n").encode()
    fd = os.open(path, os.O_RDWR | os.O_APPEND | os.O_CREAT, 0o666)  # 0o666 less the umask
    try:
        with _flocked(fd):
            data = _repair_tail(fd) + data
            written = 0
            while written < len(data):
                written += os.write(fd, data[written:])
            os.fsync(fd)
    finally:
        os.close(fd)


@contextlib.contextmanager
def writer_lock(store, *, say=None):
    """Hold the store's writer lock: one run writes to a store at a time.

    A second run on the same store waits here (``say`` is told once who holds it) until
    the first one ends, then resumes: it finds the first run's jobs in
    ``results.jsonl`` and renders only what is missing, so two runs never duplicate or
    lose a record. The lock is an ``flock`` on ``STORE/.writer.lock``, released by the
    kernel when its holder exits or is killed. Readers never take it.

    Raises ``OSError`` when the store is not writable (a read-only folder or file system).
    """
    path = store_path(store) / WRITER_LOCK
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            if say is not None:
                holder = os.pread(fd, 200, 0).decode(errors="replace").strip() or "?"
                say(f"waiting for the other run writing to {Path(store)} ({holder}) to finish")
            fcntl.flock(fd, fcntl.LOCK_EX)
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"pid {os.getpid()} on {socket.gethostname()}\n".encode(), 0)
        try:
            yield path
        finally:
            fcntl.flock(fd, fcntl.LOCK_UN)
    finally:
        os.close(fd)


class ResultLine(NamedTuple):
    """One non-blank line of ``results.jsonl`` as read, before any check of its fields."""

    #: 1-based line number in the file.
    number: int
    #: The parsed JSON value (``None`` when the line does not parse).
    value: object
    #: False: the line is not JSON (or not UTF-8).
    parsed: bool
    #: The file's last non-blank line: where a killed writer leaves a torn record, which
    #: readers skip without complaint.
    last: bool


def result_lines(store) -> list:
    """Every non-blank line of a store's ``results.jsonl`` as a :class:`ResultLine`.

    The raw view the readers build on: :func:`read_records` (the harness) and the
    report's loader (which lists bad lines instead of warning) decide what to do with a
    line that does not parse or is not a job record.

    Returns
    -------
    list of ResultLine
        Empty when the store or its ``results.jsonl`` does not exist.

    Examples
    --------
    >>> import tempfile
    >>> d = Path(tempfile.mkdtemp())
    >>> _ = (d / RESULTS).write_text('{"a": 1}\\n\\n{"a": 2')
    >>> [(ln.number, ln.value, ln.parsed, ln.last) for ln in result_lines(d)]
    [(1, {'a': 1}, True, False), (3, None, False, True)]
    """
    path = Path(store) / RESULTS
    if not path.exists():
        return []
    with open_regular(path) as f:
        lines = f.read().split(b"\n")
    last = len(lines) - 1
    while last >= 0 and not lines[last].strip():
        last -= 1
    out = []
    for i, raw in enumerate(lines[:last + 1]):
        if not raw.strip():
            continue
        try:
            value, parsed = json.loads(raw), True
        except (ValueError, UnicodeDecodeError, RecursionError):  # nested too deeply: not a record
            value, parsed = None, False
        out.append(ResultLine(i + 1, value, parsed, i == last))
    return out


def skipped_line(line: ResultLine, *, partial: bool = False) -> str | None:
    """Why a line of ``results.jsonl`` is not a job record (a sentence), or None if it is one.

    The one rule of every reader (the harness's :func:`read_records`, the report): a line
    that is not JSON, not a JSON object, lacks a key field (:data:`KEY_FIELDS`; with
    ``partial`` only ``scene``, ``renderer``, ``strategy`` and ``spp`` are needed) or
    fails :func:`check_identity` is skipped with this sentence. A torn last line (a killed
    writer) is "truncated".

    Examples
    --------
    >>> skipped_line(ResultLine(3, [1, 2], True, False))
    'line 3 is not a JSON object'
    >>> skipped_line(ResultLine(4, None, False, True))
    'last line 4 is truncated (interrupted run?)'
    """
    if not line.parsed:
        return (f"last line {line.number} is truncated (interrupted run?)" if line.last
                else f"line {line.number} is not valid JSON")
    if not isinstance(line.value, dict):
        return f"line {line.number} is not a JSON object"
    missing = [k for k in KEY_FIELDS if k not in line.value and not (partial and k in ("seed", "width", "height"))]
    if missing:
        return f"line {line.number} is not a job record (no {', '.join(missing)})"
    try:
        check_identity(line.value, f"line {line.number} is not a job record:")
    except ValueError as exc:
        return str(exc).replace(":: ", ": ")
    return None


def job_records(store, *, partial: bool = False) -> tuple:
    """``(records, skipped)``: the job records of ``results.jsonl`` in file order (not
    deduplicated) and one sentence per line skipped (:func:`skipped_line`).
    """
    records, skipped = [], []
    for line in result_lines(store):
        why = skipped_line(line, partial=partial)
        if why is None:
            records.append(line.value)
        else:
            skipped.append((line, why))
    return records, skipped


def read_records(store, *, dedupe: bool = True) -> list:
    """Job records of a store, in file order.

    A last line that does not parse (a killed writer) is skipped silently; any other line
    that is not a job record (:func:`skipped_line`) is skipped with one ``RuntimeWarning``
    for the whole file, the report lists the same lines. With ``dedupe`` (default), a job
    that occurs several times keeps its last record, at the position of its first
    (:func:`dedupe_records`), and each curve keeps only the records of its latest build
    (:func:`latest_builds`): a store never mixes two builds in one curve.

    Returns
    -------
    list of dict
        Empty when the store or its ``results.jsonl`` does not exist.
    """
    out, skipped = job_records(store)
    loud = [why for line, why in skipped if not (line.last and not line.parsed)]
    if loud:
        warnings.warn(f"{Path(store) / RESULTS}: {len(loud)} line(s) skipped: {'; '.join(loud[:5])}"
                      f"{'; ...' if len(loud) > 5 else ''}", RuntimeWarning, stacklevel=2)
    return latest_builds(dedupe_records(out)) if dedupe else out


def curve_of(record: dict) -> tuple:
    """The curve a record belongs to: ``(scene, renderer, strategy, width, height)``."""
    return tuple(record.get(k) for k in ("scene", "renderer", "strategy", "width", "height"))


def latest_builds(records) -> list:
    """Per curve (:func:`curve_of`), only the records of the build of its last record.

    Records of older builds stay in ``results.jsonl`` (nothing is deleted) but are not
    read as part of the curve: a run with a new build renders every job again, and the
    curve is then the new build's alone, even while that run is incomplete.

    Examples
    --------
    >>> rs = [{"scene": "a", "spp": 1, "build": "old"}, {"scene": "a", "spp": 2, "build": "old"},
    ...       {"scene": "a", "spp": 1, "build": "new"}]
    >>> [(r["spp"], r["build"]) for r in latest_builds(rs)]
    [(1, 'new')]
    """
    records = list(records)
    last = {curve_of(r): r.get(BUILD_FIELD) for r in records}
    return [r for r in records if r.get(BUILD_FIELD) == last[curve_of(r)]]


def dedupe_records(records) -> list:
    """One record per job key (:func:`record_key`): the last one, at the position of the first.

    A resumed or repeated run may append a job again; the last write wins. Missing key
    fields read as ``None`` here, so incomplete records are deduplicated too.

    Examples
    --------
    >>> rs = [{"scene": "a", "spp": 1, "v": 1}, {"scene": "b", "spp": 1, "v": 2},
    ...       {"scene": "a", "spp": 1, "v": 3}]
    >>> [r["v"] for r in dedupe_records(rs)]
    [3, 2]
    """
    by_key: dict = {}
    for rec in records:
        # a dict keeps the first position, takes the last value; a later build replaces an earlier one
        by_key[record_key(rec, partial=True)[:len(KEY_FIELDS)]] = rec
    return list(by_key.values())


def check_identity(record: dict, where: str, *, need_spp: bool = True) -> None:
    """Raise ``ValueError`` unless a record (or summary row) says which curve it belongs to.

    ``scene``, ``renderer`` and ``strategy`` must be non-empty strings and, for a job
    record (``need_spp``), ``spp`` a positive number. ``where`` starts the message
    (e.g. ``"results.jsonl line 3"``). Other fields may be missing or ``null``.

    Examples
    --------
    >>> check_identity({"scene": "a", "renderer": "ours", "strategy": "mis", "spp": 0}, "line 1")
    Traceback (most recent call last):
    ...
    ValueError: line 1: 'spp' must be a positive number, got 0
    """
    for k in ("scene", "renderer", "strategy"):
        if not isinstance(record.get(k), str) or not record[k]:
            raise ValueError(f"{where}: missing or non-string {k!r}")
    if need_spp:
        spp = record.get("spp")
        if isinstance(spp, bool) or not isinstance(spp, (int, float)) or not spp > 0:
            raise ValueError(f"{where}: 'spp' must be a positive number, got {spp!r}")


def finished_keys(store) -> set:
    """Keys (:func:`record_key`) of the jobs already recorded in a store."""
    return {record_key(r) for r in read_records(store, dedupe=False)}


def write_json(path, obj) -> Path:
    """Write ``obj`` as indented JSON atomically (temp file in the same folder + rename)."""
    return atomic_write(path, json.dumps(_json_safe(obj), indent=1, allow_nan=False) + "\n")


def read_json(path, default=None, *, problems: list | None = None):
    """Read a JSON file; ``default`` if it is missing or does not parse.

    With a ``problems`` list, what went wrong is appended to it as a sentence (a reader
    that reports instead of failing, like the report).
    """
    path = Path(path)
    try:
        with open_regular(path, max_bytes=MAX_JSON_BYTES) as f:
            return json.loads(f.read())
    except FileNotFoundError:
        if problems is not None:
            problems.append(f"{path.name} is missing")
    except RecursionError:
        if problems is not None:
            problems.append(f"{path.name} could not be read: JSON nested too deeply")
    except (OSError, ValueError) as exc:
        if problems is not None:
            problems.append(f"{path.name} could not be read: {exc}")
    return default


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _is_scalar(v) -> bool:
    return v is None or isinstance(v, (str, int, float, bool))


#: the type of each field of a reference entry of ``meta.json`` (STORE.md).
_REFERENCE_FIELDS = {"path": str, "variance_path": str, "sha256": str, "variance_sha256": str, "variant": str,
                     "key": str, "scene_hash": str, "scene_source": str, "spp": "number", "seed": "number",
                     "width": "number", "height": "number", "render_seconds": "number"}
_SCENE_FILE_FIELDS = {"name": str, "source": str, "kind": str, "hash": str, "params": "scalars"}


def _fits(value, kind) -> bool:
    if value is None:
        return True
    if kind == "number":
        return _is_number(value)
    if kind == "scalars":
        return isinstance(value, dict) and all(_is_scalar(v) for v in value.values())
    return isinstance(value, kind)


def _clean_entry(entry, fields: dict):
    """A dict of known fields of the right type (others dropped), or None if ``entry`` is no dict."""
    if not isinstance(entry, dict):
        return None
    return {k: v for k, v in entry.items() if k in fields and _fits(v, fields[k])}


def _clean_meta(meta: dict, problems: list | None) -> dict:
    """``meta.json`` as its readers expect it (STORE.md): each known key with its type, entries of
    the wrong shape dropped (and said in ``problems``), unknown keys kept only as plain values.

    The one check of ``meta.json`` at the boundary: after it a reader may index what it reads.

    Examples
    --------
    >>> _clean_meta({"references": {"a": [1], "b": {"spp": 4, "path": 7}}, "threads": "x"}, None)
    {'references': {'b': {'spp': 4}}}
    """
    out, dropped = {}, []
    for key, value in meta.items():
        if key in ("date", "preset"):
            ok = isinstance(value, str)
        elif key in ("total_seconds", "threads"):
            ok = _is_number(value)
        elif key in ("machine", "versions"):
            ok = _fits(value, "scalars")
        elif key in ("references", "references_by_size", "scene_files"):
            ok = isinstance(value, dict)
            if ok:
                fields = _SCENE_FILE_FIELDS if key == "scene_files" else _REFERENCE_FIELDS
                entries = {str(k): _clean_entry(v, fields) for k, v in value.items()}
                dropped += [f"{key}.{k}" for k, v in entries.items() if v is None]
                value = {k: v for k, v in entries.items() if v is not None}
        elif key == "target_rmse":
            ok = isinstance(value, dict)
            if ok:
                dropped += [f"{key}.{k}" for k, v in value.items() if not _is_number(v)]
                value = {str(k): v for k, v in value.items() if _is_number(v)}
        elif key == "runs":
            ok = isinstance(value, list)
            if ok:
                value = [r for r in value if isinstance(r, dict) and all(_is_scalar(v) for v in r.values())]
        else:
            ok = _is_scalar(value)
        if ok:
            out[key] = value
        else:
            dropped.append(key)
    if dropped and problems is not None:
        problems.append(f"{META}: {len(dropped)} field(s) of the wrong type ignored: {', '.join(dropped[:8])}"
                        + (", ..." if len(dropped) > 8 else ""))
    return out


def read_meta(store, *, problems: list | None = None) -> dict:
    """A store's ``meta.json`` as a dict (empty when missing or not a JSON object).

    Any key may be missing after an interrupted run (``STORE.md``). The file is checked
    here, once, against the fields STORE.md gives (:func:`_clean_meta`): a field of the
    wrong type is dropped, so readers may rely on the types. Problems are appended to
    ``problems`` when given.
    """
    meta = read_json(Path(store) / META, problems=problems)
    if meta is not None and not isinstance(meta, dict):
        if problems is not None:
            problems.append(f"{META} is not a JSON object; ignored")
        meta = None
    return _clean_meta(meta or {}, problems)


def read_summary_rows(store, *, problems: list | None = None) -> list:
    """The ``rows`` of a store's ``summary.json`` (empty when missing or without a list).

    Problems are appended to ``problems`` when given; a row that is not a JSON object
    raises ``ValueError`` (the file is not a summary this code wrote).
    """
    path = Path(store) / SUMMARY
    summ = read_json(path, problems=problems)
    if summ is None:
        return []
    rows = summ.get("rows") if isinstance(summ, dict) else None
    if not isinstance(rows, list):
        if problems is not None:
            problems.append(f"{SUMMARY} has no 'rows' list; ignored")
        return []
    for i, row in enumerate(rows):
        if not isinstance(row, dict):
            raise ValueError(f"{path}: row {i} is not a JSON object")
    return rows


def read_headline(store, *, problems: list | None = None) -> list:
    """The ``headline`` entries of a store's ``summary.json`` (one per scene and size; empty
    when missing): each a JSON object with a string ``scene``; others are dropped and said."""
    summ = read_json(Path(store) / SUMMARY)
    entries = summ.get("headline") if isinstance(summ, dict) else None
    if not isinstance(entries, list):
        return []
    good = [e for e in entries if isinstance(e, dict) and isinstance(e.get("scene"), str)
            and isinstance(e.get("curves", []), list)]
    for e in good:
        e["curves"] = [c for c in e.get("curves") or [] if isinstance(c, dict)]
    if len(good) < len(entries) and problems is not None:
        problems.append(f"{SUMMARY}: {len(entries) - len(good)} headline entr(ies) that are not scene entries ignored")
    return good


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
    rel = Path(relpath)
    if rel.is_absolute() or ".." in rel.parts:
        raise ValueError(f"image path must be relative to the store, got {relpath}")
    imageio.write_exr(Path(store) / rel, np.asarray(image, dtype=np.float32))
    return rel.as_posix()


def file_sha256(path) -> str:
    """Hex SHA-256 of a regular file's bytes (the checksum ``meta.json`` keeps of the store's references)."""
    h = hashlib.sha256()
    with open_regular(path) as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def image_path(store, relpath) -> Path:
    """The file a record's image field names, confined to the store (:func:`benchmarks.files.confined_file`).

    Raises :class:`benchmarks.errors.InputError` for an absolute path, a ``..``, a link
    out of the store or anything but a regular file; the file need not exist.
    """
    return confined_file(store, relpath, what="image")


def read_image(store, relpath, *, rgb: bool = False, sha256: str | None = None) -> np.ndarray:
    """Read an EXR image stored under ``store`` as (H, W, C) float32.

    ``relpath`` is confined to the store (:func:`image_path`): a path read from a store
    never reads a file outside it. With ``rgb``, the result is (H, W, 3): a grey image is
    repeated to RGB, alpha dropped. With ``sha256`` (the checksum recorded when it was
    written), a file whose bytes do not match raises :class:`benchmarks.errors.InputError`
    instead of being decoded: flipped bytes in an EXR can decode to finite garbage.
    """
    path = image_path(store, relpath)
    if sha256 is not None and file_sha256(path) != sha256:
        raise InputError(f"{path}: checksum mismatch, the file is corrupt (not used)")
    try:
        a = imageio.read_exr(path)
    except (OSError, RuntimeError) as exc:
        if not path.exists():
            raise
        raise InputError(f"{path}: not a readable EXR image ({exc})") from exc
    if rgb:
        if a.shape[2] == 1:
            a = np.repeat(a, 3, axis=2)
        a = np.asarray(a[..., :3], dtype=np.float32)
    return a
