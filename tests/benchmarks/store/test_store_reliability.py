"""The results store under faults (issue 15, cases 1, 2, 6, 7): permissions of what it
creates, a complete last record without its newline, non-record lines, the checksum of
its copy of the reference, and the writer lock."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import warnings

import numpy as np
import pytest

from benchmarks.errors import InputError
from benchmarks.store import (RESULTS, WRITER_LOCK, append_record, file_sha256, job_records, read_image,
                              read_records, write_image, write_json, writer_lock)
from harness_util import ROOT


def rec(**kw):
    r = {"scene": "s", "renderer": "ours", "strategy": "mis", "spp": 4, "seed": 0, "width": 8, "height": 8,
         "mse": 0.5}
    r.update(kw)
    return r


# ------------------------------------------------------------------------- case 6: the last line

def test_complete_last_record_without_newline_is_kept(tmp_path):
    path = tmp_path / RESULTS
    path.write_text(json.dumps(rec(spp=1)) + "\n" + json.dumps(rec(spp=2)))  # no final newline
    assert [r["spp"] for r in read_records(tmp_path)] == [1, 2]
    append_record(tmp_path, rec(spp=3))
    assert [r["spp"] for r in read_records(tmp_path)] == [1, 2, 3]
    assert path.read_text().count("\n") == 3


def test_torn_last_line_is_still_cut(tmp_path):
    path = tmp_path / RESULTS
    path.write_text(json.dumps(rec(spp=1)) + "\n" + json.dumps(rec(spp=2))[:30])
    append_record(tmp_path, rec(spp=3))
    assert [r["spp"] for r in read_records(tmp_path)] == [1, 3]


# ------------------------------------------------------------------ case 7: non-record JSON lines

BAD_LINES = ['[1, 2, 3]', '{"hello": "world"}', '{"scene": "s", "renderer": "ours", "strategy": "mis", "spp": 0, '
             '"seed": 0, "width": 8, "height": 8}', '{not json']


def _store_with_bad_lines(tmp_path):
    append_record(tmp_path, rec(spp=1))
    with open(tmp_path / RESULTS, "a") as f:
        for line in BAD_LINES:
            f.write(line + "\n")
    append_record(tmp_path, rec(spp=2))
    return tmp_path


def test_run_skips_non_record_lines_with_one_warning(tmp_path):
    _store_with_bad_lines(tmp_path)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert [r["spp"] for r in read_records(tmp_path)] == [1, 2]
    assert len(caught) == 1 and "4 line(s) skipped" in str(caught[0].message)


def test_report_skips_the_same_lines_and_lists_them(tmp_path):
    from benchmarks.cli import main
    from reports.store import load_store

    _store_with_bad_lines(tmp_path)
    st = load_store(tmp_path)
    assert [r["spp"] for r in st.records] == [1, 2]
    skipped = [p for p in st.problems if p.startswith(RESULTS) and "skipped" in p]
    assert len(skipped) == 4, st.problems
    assert any("not a JSON object" in p for p in skipped) and any("'spp' must be a positive" in p for p in skipped)
    records, lines = job_records(tmp_path)
    assert len(records) == 2 and len(lines) == 4
    assert main(["report", str(tmp_path), "--quiet"]) == 0


# --------------------------------------------------------- case 7: the store's copy of the reference

def test_corrupt_store_reference_is_never_used(tmp_path):
    img = np.full((4, 4, 3), 0.156, dtype=np.float32)
    rel = write_image(tmp_path, "references/r.exr", img)
    digest = file_sha256(tmp_path / rel)
    assert np.allclose(read_image(tmp_path, rel, sha256=digest), img)
    data = bytearray((tmp_path / rel).read_bytes())
    data[-20:-8] = bytes(12)  # flipped pixel bytes: still decodes, to different values
    (tmp_path / rel).write_bytes(bytes(data))
    with pytest.raises(InputError, match="checksum mismatch"):
        read_image(tmp_path, rel, sha256=digest)


def test_a_missing_image_the_store_names_is_bad_input(tmp_path, capfd):
    """It re-raised the EXR library's RuntimeError (``internal error``, exit 3), after the library's own
    ``(EXR_ERR_FILE_ACCESS)`` line on stderr."""
    with pytest.raises(InputError, match=r"images/gone\.exr: missing, though the store names it"):
        read_image(tmp_path, "images/gone.exr")
    (tmp_path / "images").mkdir()
    (tmp_path / "images" / "png.exr").write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(32))
    with pytest.raises(ValueError, match="not an OpenEXR file"):
        read_image(tmp_path, "images/png.exr")
    assert capfd.readouterr().err == ""


def test_report_refuses_a_corrupt_reference_copy(tmp_path):
    import reports
    from report_store import make_store

    store = make_store(tmp_path / "st", scenes=("cornell_box",), strategies=("mis",), spps=(1, 4), seeds=(0,),
                       size=8)
    meta = json.loads((store / "meta.json").read_text())
    info = meta["references"]["cornell_box"]
    info["sha256"] = file_sha256(store / info["path"])
    (store / "meta.json").write_text(json.dumps(meta))
    data = bytearray((store / info["path"]).read_bytes())
    data[-20:-8] = bytes(12)
    (store / info["path"]).write_bytes(bytes(data))
    reports.build_report(store, out=tmp_path / "out")
    st_problems = (tmp_path / "out" / "summary.md").read_text() + (tmp_path / "out" / "index.html").read_text()
    assert "checksum mismatch" in st_problems


def test_sweep_rewrites_a_corrupt_reference_copy(tmp_path):
    from benchmarks.references import closed_form_reference_of
    from benchmarks.sweep.run import _store_copy

    ref = closed_form_reference_of("furnace", 4, 4)
    first = _store_copy(tmp_path, "references/furnace_4x4", ref, {})
    assert first["sha256"] == file_sha256(tmp_path / first["path"])
    old = {"furnace@4x4": {**first, "key": ref.key}}
    data = bytearray((tmp_path / first["path"]).read_bytes())
    data[-20:-8] = bytes(12)
    (tmp_path / first["path"]).write_bytes(bytes(data))
    again = _store_copy(tmp_path, "references/furnace_4x4", ref, old)
    assert again["sha256"] == first["sha256"] == file_sha256(tmp_path / first["path"])
    assert np.allclose(read_image(tmp_path, first["path"], sha256=again["sha256"]), ref.mean)


# ------------------------------------------------------------------------- case 1: permissions

def test_store_files_are_created_with_the_umask_not_0600(tmp_path):
    old = os.umask(0o022)
    try:
        write_image(tmp_path, "images/a.exr", np.zeros((2, 2, 3), np.float32))
        write_json(tmp_path / "meta.json", {"a": 1})
        append_record(tmp_path, rec())
    finally:
        os.umask(old)
    for p in (tmp_path / "images" / "a.exr", tmp_path / "meta.json", tmp_path / RESULTS):
        assert oct(p.stat().st_mode & 0o777) == "0o644", p


# ------------------------------------------------------------------------- case 2: the writer lock

def test_writer_lock_makes_a_second_writer_wait(tmp_path):
    """A second writer says it waits (naming the holder), takes the lock only once the first
    lets go, and then holds it: an order of events read from the child's output and the lock
    file, with no sleep and no clock."""
    code = ("import os, sys; from benchmarks.store import writer_lock\n"
            "with writer_lock(sys.argv[1], say=lambda t: print(t, flush=True)):\n"
            "    print('got', os.getpid(), flush=True)\n")
    lock_file = tmp_path / WRITER_LOCK
    with writer_lock(tmp_path):
        assert WRITER_LOCK in os.listdir(tmp_path)
        proc = subprocess.Popen([sys.executable, "-c", code, str(tmp_path)], cwd=ROOT, stdout=subprocess.PIPE,
                                text=True)
        # Blocks until the child has met the lock: it prints this only when it must wait.
        first = proc.stdout.readline()
        assert first.startswith("waiting for the other run writing to") and f"pid {os.getpid()}" in first, first
        assert proc.poll() is None and lock_file.read_text().startswith(f"pid {os.getpid()} ")  # still ours
    rest, _ = proc.communicate(timeout=60)
    assert proc.returncode == 0 and rest.split() == ["got", str(proc.pid)], rest
    assert lock_file.read_text().startswith(f"pid {proc.pid} ")   # the child wrote it once it held the lock
