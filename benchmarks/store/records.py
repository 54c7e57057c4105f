"""``results.jsonl``: one job record per line, appended durably, read with torn lines skipped;
readers deduplicate by the job key and keep each curve's latest build (``STORE.md``)."""
from __future__ import annotations

import contextlib
import fcntl
import json
import math
import os
import socket
import warnings
from pathlib import Path
from typing import NamedTuple

from ..files import open_regular
from .jsonio import json_safe, store_file, store_path

#: fields that identify a job; the build (:data:`BUILD_FIELD`) ends its key.
KEY_FIELDS = ("scene", "renderer", "strategy", "spp", "seed", "width", "height")
BUILD_FIELD = "build"
RESULTS = "results.jsonl"
WRITER_LOCK = ".writer.lock"


def record_key(record: dict, *, partial: bool = False) -> tuple:
    """The identity of a job record, ``(scene, renderer, strategy, spp, seed, width, height, build)``.

    ``ValueError`` for a missing field of :data:`KEY_FIELDS`, unless ``partial`` (it reads as
    None); a missing build reads as None.

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


def _repair_tail(fd: int) -> bytes:
    """Make the end of ``results.jsonl`` ready for an append (the file locked); return the bytes
    to write first: a newline after a complete last record, nothing after cutting off a torn one."""
    size = os.fstat(fd).st_size
    if size == 0 or os.pread(fd, 1, size - 1) == b"\n":
        return b""
    with open(fd, "rb", closefd=False) as f:
        data = f.read()  # only after a killed writer; every reader reads the whole file too
    cut = data.rfind(b"\n") + 1
    try:
        json.loads(data[cut:])
    except (ValueError, UnicodeDecodeError):
        os.ftruncate(fd, cut)
        os.fsync(fd)
        return b""
    return b"\n"


def append_record(store, record: dict) -> None:
    """Append one job record (holding :data:`KEY_FIELDS`) to ``results.jsonl`` durably: one
    locked write, then fsync; NaN and inf are written as null. The store is created if missing."""
    record_key(record)
    path = store_file(store_path(store), RESULTS)  # never written through a link that leaves the store
    data = (json.dumps(json_safe(record), sort_keys=False, allow_nan=False) + "\n").encode()
    fd = os.open(path, os.O_RDWR | os.O_APPEND | os.O_CREAT, 0o666)  # 0o666 less the umask
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        data = _repair_tail(fd) + data
        written = 0
        while written < len(data):
            written += os.write(fd, data[written:])
        os.fsync(fd)
    finally:
        os.close(fd)  # releases the lock


@contextlib.contextmanager
def writer_lock(store, *, say=None):
    """Hold the store's writer lock (``flock`` on :data:`WRITER_LOCK`): a second run waits here
    (``say`` is told who holds it), then resumes. ``OSError`` when the store is not writable."""
    path = store_file(store_path(store), WRITER_LOCK)
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
        yield path
    finally:
        os.close(fd)  # releases the lock


class ResultLine(NamedTuple):
    """One non-blank line of ``results.jsonl`` as read: its 1-based ``number``, its ``value``
    (None unless ``parsed``) and whether it is the ``last`` (where a killed writer leaves a torn one).
    A file the store may not read (:func:`benchmarks.store.jsonio.store_file`) is one line 0 whose
    ``refused`` says why."""

    number: int
    value: object
    parsed: bool
    last: bool
    refused: str | None = None


def result_lines(store) -> list:
    """Every non-blank line of a store's ``results.jsonl`` as a :class:`ResultLine` (none without the file).

    >>> import tempfile
    >>> d = Path(tempfile.mkdtemp())
    >>> _ = (d / RESULTS).write_text('{"a": 1}\\n\\n{"a": 2')
    >>> [(ln.number, ln.value, ln.parsed, ln.last) for ln in result_lines(d)]
    [(1, {'a': 1}, True, False), (3, None, False, True)]
    """
    try:
        path = store_file(store, RESULTS)
    except ValueError as exc:  # leaves the store, or no regular file: refused, never read
        return [ResultLine(0, None, False, False, f"the file is not read ({exc})")]
    if not path.exists():
        return []
    with open_regular(path) as f:
        lines = [(i + 1, raw) for i, raw in enumerate(f.read().split(b"\n")) if raw.strip()]
    out = []
    for number, raw in lines:
        try:
            value, parsed = json.loads(raw), True
        except (ValueError, UnicodeDecodeError, RecursionError):  # nested too deeply: not a record
            value, parsed = None, False
        out.append(ResultLine(number, value, parsed, number == lines[-1][0]))
    return out


def skipped_line(line: ResultLine, *, partial: bool = False) -> str | None:
    """Why a line of ``results.jsonl`` is not a job record (a sentence), or None: the one rule of
    every reader. With ``partial`` a record may lack ``seed``, ``width`` and ``height``.

    >>> skipped_line(ResultLine(3, [1, 2], True, False))
    'line 3 is not a JSON object'
    >>> skipped_line(ResultLine(4, None, False, True))
    'last line 4 is truncated (interrupted run?)'
    """
    if line.refused:
        return line.refused
    if not line.parsed:
        return (f"last line {line.number} is truncated (interrupted run?)" if line.last
                else f"line {line.number} is not valid JSON")
    if not isinstance(line.value, dict):
        return f"line {line.number} is not a JSON object"
    missing = [k for k in KEY_FIELDS if k not in line.value and not (partial and k in ("seed", "width", "height"))]
    if missing:
        return f"line {line.number} is not a job record (no {', '.join(missing)})"
    try:
        check_identity(line.value, f"line {line.number} is not a job record:", key=True)
    except ValueError as exc:
        return str(exc).replace(":: ", ": ")
    return None


def job_records(store, *, partial: bool = False) -> tuple:
    """``(records, skipped)``: the job records of ``results.jsonl`` in file order (not
    deduplicated) and ``(line, why)`` per line skipped (:func:`skipped_line`)."""
    lines = [(line, skipped_line(line, partial=partial)) for line in result_lines(store)]
    return [line.value for line, why in lines if why is None], [(line, why) for line, why in lines if why]


def read_records(store, *, dedupe: bool = True) -> list:
    """Job records of a store in file order, with :func:`dedupe_records` and :func:`latest_builds`
    unless not ``dedupe``. Lines that are not records are skipped with one ``RuntimeWarning``
    (a torn last line silently)."""
    out, skipped = job_records(store)
    loud = [why for line, why in skipped if not (line.last and not line.parsed)]
    if loud:
        warnings.warn(f"{Path(store) / RESULTS}: {len(loud)} line(s) skipped: {'; '.join(loud[:5])}"
                      f"{'; ...' if len(loud) > 5 else ''}", RuntimeWarning, stacklevel=2)
    return latest_builds(dedupe_records(out)) if dedupe else out


def curve_of(record: dict) -> tuple:
    """The curve a record belongs to: ``(scene, renderer, strategy, width, height)``."""
    return tuple(record.get(k) for k in ("scene", "renderer", "strategy", "width", "height"))


def curve_label(curve) -> str:
    """A curve (:func:`curve_of`) in words: our strategy alone, another renderer's after its name.

    >>> curve_label(("cornell_box", "ours", "mis", 32, 32)), curve_label(("furnace", "mitsuba", "path", 8, 4))
    ('cornell_box 32x32 mis', 'furnace 8x4 mitsuba path')
    """
    scene, renderer, strategy, width, height = curve
    return f"{scene} {width}x{height} {strategy if renderer == 'ours' else f'{renderer} {strategy}'}"


def latest_builds(records) -> list:
    """Per curve (:func:`curve_of`), only the records of the build of its last record in file order.

    >>> rs = [{"scene": "a", "spp": 1, "build": "old"}, {"scene": "a", "spp": 2, "build": "old"},
    ...       {"scene": "a", "spp": 1, "build": "new"}]
    >>> [(r["spp"], r["build"]) for r in latest_builds(rs)]
    [(1, 'new')]
    """
    records = list(records)
    last = {curve_of(r): r.get(BUILD_FIELD) for r in records}
    return [r for r in records if r.get(BUILD_FIELD) == last[curve_of(r)]]


def dedupe_records(records) -> list:
    """One record per job key, build included (:func:`record_key`, missing fields None): the last, at its own
    position, so the result keeps file order and a curve's last record stays last (:func:`latest_builds`). A
    record of one build never replaces one of another build: which build a curve shows is
    :func:`latest_builds`'s choice alone.

    >>> rs = [{"scene": "a", "spp": 1, "v": 1}, {"scene": "b", "spp": 1, "v": 2},
    ...       {"scene": "a", "spp": 1, "v": 3}, {"scene": "a", "spp": 1, "build": "x", "v": 4}]
    >>> [r["v"] for r in dedupe_records(rs)]
    [2, 3, 4]
    """
    records = list(records)
    last = {record_key(rec, partial=True): i for i, rec in enumerate(records)}
    return [rec for i, rec in enumerate(records) if last[record_key(rec, partial=True)] == i]


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def check_identity(record: dict, where: str, *, need_spp: bool = True, key: bool = False) -> None:
    """``ValueError`` (message starting with ``where``) unless ``scene``, ``renderer`` and
    ``strategy`` are non-empty strings and, with ``need_spp``, ``spp`` a finite positive number.
    With ``key`` (a job record), also ``seed``, ``width`` and ``height`` finite numbers or null
    where present and ``build`` a string or null: after this a record's key (:func:`record_key`)
    can be hashed and its numbers converted.

    >>> check_identity({"scene": "a", "renderer": "ours", "strategy": "mis", "spp": 0}, "line 1")
    Traceback (most recent call last):
    ...
    ValueError: line 1: 'spp' must be a positive number, got 0
    >>> check_identity({"scene": "a", "renderer": "ours", "strategy": "mis", "spp": 1, "width": [8]}, "line 2",
    ...                key=True)
    Traceback (most recent call last):
    ...
    ValueError: line 2: 'width' must be a number or null, got [8]
    """
    for k in ("scene", "renderer", "strategy"):
        if not isinstance(record.get(k), str) or not record[k]:
            raise ValueError(f"{where}: missing or non-string {k!r}")
    if need_spp:
        spp = record.get("spp")
        if not _is_number(spp) or not spp > 0:
            raise ValueError(f"{where}: 'spp' must be a positive number, got {spp!r:.80}")
    if key:
        for k in ("seed", "width", "height"):
            if record.get(k) is not None and not _is_number(record[k]):
                raise ValueError(f"{where}: {k!r} must be a number or null, got {record[k]!r:.80}")
        if record.get(BUILD_FIELD) is not None and not isinstance(record[BUILD_FIELD], str):
            raise ValueError(f"{where}: {BUILD_FIELD!r} must be a string or null, got {record[BUILD_FIELD]!r:.80}")


def finished_keys(store) -> set:
    """Keys (:func:`record_key`) of the jobs already recorded in a store."""
    return {record_key(r) for r in read_records(store, dedupe=False)}
