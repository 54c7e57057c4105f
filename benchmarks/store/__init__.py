"""The results store: an append-only folder of job records, images and run metadata.

Layout and field names are fixed by ``benchmarks/STORE.md``. This package is the only
code that knows the format, one file a module: :mod:`~benchmarks.store.records`
(``results.jsonl``), :mod:`~benchmarks.store.meta` (``meta.json``, ``summary.json``),
:mod:`~benchmarks.store.images` (EXR images) and :mod:`~benchmarks.store.jsonio` (the
folder, JSON written atomically and read defensively). Import from the package: the harness writes through it and ``reports`` reads through
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

from .images import file_sha256, image_path, read_image, write_image
from .jsonio import read_json, store_path, write_json
from .meta import META, SUMMARY, read_headline, read_meta, read_summary_rows, update_meta
from .records import (BUILD_FIELD, KEY_FIELDS, RESULTS, WRITER_LOCK, ResultLine, append_record, check_identity,
                      curve_of, dedupe_records, finished_keys, job_records, latest_builds, read_records, record_key,
                      result_lines, skipped_line, writer_lock)

__all__ = ["KEY_FIELDS", "BUILD_FIELD", "curve_of", "latest_builds", "RESULTS", "META", "SUMMARY", "record_key",
           "store_path", "append_record", "writer_lock", "WRITER_LOCK", "ResultLine", "result_lines", "skipped_line",
           "job_records", "read_records", "dedupe_records",
           "finished_keys", "check_identity", "write_json", "read_json", "read_meta",
           "read_summary_rows", "read_headline", "update_meta", "write_image", "read_image", "image_path", "file_sha256"]
