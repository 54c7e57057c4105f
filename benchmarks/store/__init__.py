"""The results store: an append-only folder of job records, images and run metadata.

The only code that knows the format (``benchmarks/STORE.md``: layout, durability,
concurrency); the harness writes and ``reports`` reads through it. A store may come from
anybody: what is read is checked here, once (``SECURITY.md``). EXR goes through
:mod:`reference_tracer.imageio`, so the tracer's C++ core is never loaded.

Examples
--------
>>> import tempfile
>>> d = tempfile.mkdtemp()
>>> append_record(d, {"scene": "s", "renderer": "ours", "strategy": "mis", "spp": 4,
...                   "seed": 0, "width": 8, "height": 8, "build": "ab12", "mse": 0.1})
>>> [r["mse"] for r in read_records(d)], sorted(finished_keys(d))
([0.1], [('s', 'ours', 'mis', 4, 0, 8, 8, 'ab12')])
"""
from __future__ import annotations

from .images import file_sha256, image_path, read_image, write_image
from .jsonio import read_json, store_path, timestamp, write_json
from .meta import META, SUMMARY, read_headline, read_meta, read_summary_rows, update_meta
from .records import (BUILD_FIELD, KEY_FIELDS, RESULTS, WRITER_LOCK, append_record, check_identity, curve_label,
                      curve_of, dedupe_records, finished_keys, job_records, latest_builds, read_records, record_key,
                      result_lines, skipped_line, writer_lock)

__all__ = ["BUILD_FIELD", "KEY_FIELDS", "META", "RESULTS", "SUMMARY", "WRITER_LOCK", "append_record",
           "check_identity", "curve_label", "curve_of", "dedupe_records", "file_sha256", "finished_keys", "image_path",
           "job_records", "latest_builds", "read_headline", "read_image", "read_json", "read_meta", "read_records",
           "read_summary_rows", "record_key", "result_lines", "skipped_line", "store_path", "timestamp",
           "update_meta", "write_image", "write_json"]
