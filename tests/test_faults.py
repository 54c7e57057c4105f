"""Fault injection (issue 15): runs killed at random points, two runs on one store,
read-only and corrupt caches and stores, a full disk.

Each case asserts: nothing lost, nothing duplicated, nothing corrupt used, and (where the
process lives to say it) one clear line on stderr with exit status 3. Small jobs (8x8
images, our ``mis`` only, Mitsuba only for the cached reference): the whole file takes
about a minute.
"""
from __future__ import annotations

import contextlib
import errno
import json
import os
import random
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from benchmarks.store import META, RESULTS, SUMMARY, WRITER_LOCK, read_records, record_key, result_lines
from harness_util import ROOT, default_sigint, rtbench

N_JOBS = 3 * 2  # spp 1, 2, 4 x 2 seeds


def _args(out) -> tuple:
    return ("curves", "cornell_box", "--strategies", "mis", "--spp", "1,2,4", "--seeds", "2", "--width", "8",
            "--height", "8", "--reference-spp", "256", "--threads", "1", "--no-mitsuba", "--quiet", "--out", out)


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    """A reference cache with this sweep's reference and tail reference, and a complete store."""
    root = tmp_path_factory.mktemp("fault-cache")
    store = tmp_path_factory.mktemp("warm") / "s"
    rtbench(*_args(store), cache=root)
    _assert_complete(store)
    return root, store


def _copy_store(src: Path, dst: Path) -> Path:
    shutil.copytree(src, dst, ignore=shutil.ignore_patterns(".writer.lock"))
    return dst


def _popen(args, cache_root) -> subprocess.Popen:
    env = dict(os.environ, RTBENCH_CACHE=str(cache_root), PYTHONUNBUFFERED="1")
    # SIGINT at its default in the child whatever this process inherited (harness_util):
    # without it the Ctrl-C test's run ignored the interrupt in every full-suite run.
    return subprocess.Popen([sys.executable, "-m", "benchmarks.cli", *map(str, args)], cwd=ROOT, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=default_sigint)


def _assert_complete(store: Path, n_jobs: int = N_JOBS) -> None:
    """Every job exactly once, every line a record, the JSON files whole."""
    lines = result_lines(store)
    assert all(ln.parsed for ln in lines), [ln.number for ln in lines if not ln.parsed]
    keys = [record_key(r) for r in read_records(store, dedupe=False)]
    assert len(keys) == len(set(keys)) == n_jobs, keys
    json.loads((store / META).read_text())
    assert json.loads((store / SUMMARY).read_text())["rows"]


def _one_line(stderr: str) -> str:
    lines = [ln for ln in stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in stderr, stderr
    return lines[0]


# ------------------------------------------------------------------------------------ SIGKILL

@pytest.mark.parametrize("seed", [0, 1, 2])
def test_sigkill_at_a_random_point_then_resume(cache, tmp_path, seed):
    root, _ = cache
    store = tmp_path / "s"
    # A last budget of 2^20 spp (about 15 s or more a job) keeps the run busy long after its
    # first records, so the kill (within 1.5 s of them) always lands inside the run and
    # before a job the resumed run does not have completes. With 1-4 spp alone the run could
    # finish first; with 16384 spp (0.2-0.4 s a job) the faster tracer sometimes finished one
    # before the kill, and the store then held 7 records where the resumed sweep has 6 jobs.
    args = list(_args(store))
    args[args.index("--spp") + 1] = "1,2,4,1048576"
    proc = _popen(args, root)
    deadline = time.monotonic() + 300
    while proc.poll() is None and not (store / META).exists() and time.monotonic() < deadline:
        time.sleep(0.005)  # the run has started writing: kill it at a random point from here
    time.sleep(random.Random(seed).uniform(0.0, 1.5))
    proc.send_signal(signal.SIGKILL)
    proc.communicate()
    before = {record_key(r) for r in read_records(store)} if (store / RESULTS).exists() else set()
    again = rtbench(*_args(store), cache=root)
    assert f"{len(before)} already there" in again.stdout
    _assert_complete(store)
    runs = json.loads((store / META).read_text())["runs"]
    assert runs[-1]["jobs_done"] == N_JOBS - len(before) and runs[-1]["ended"] is not None


def test_ctrl_c_records_the_run_history(cache, tmp_path):
    root, _ = cache
    store = tmp_path / "s"
    # Jobs of 65536 spp (one to two seconds each) after the small ones keep the run busy long
    # after its first two records, when the interrupt is sent: with 1-4 spp alone, or even
    # 16384 spp on a fast machine, the run can finish first and the test would test nothing.
    args = list(_args(store))
    args[args.index("--spp") + 1] = "1,2,4,65536"
    proc = _popen(args, root)
    deadline = time.monotonic() + 300
    while proc.poll() is None and time.monotonic() < deadline:
        if (store / RESULTS).exists() and (store / RESULTS).read_bytes().count(b"\n") >= 2:
            break
        time.sleep(0.01)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode != 0, "the run finished before the interrupt: nothing was tested"
    assert proc.returncode == 130 and "interrupted" in err
    run = json.loads((store / META).read_text())["runs"][-1]
    assert run["interrupted"] is True and run["jobs_done"] == len(read_records(store)) >= 2
    assert run["started"] <= run["ended"] and run["seconds"] > 0


# ---------------------------------------------------------------------------- two runs, one store

def test_two_concurrent_runs_on_one_store(cache, tmp_path):
    root, _ = cache
    store = tmp_path / "s"
    # The second run starts once the first holds the store's writer lock, and the first
    # holds it for a few seconds (two 65536-spp jobs after the small ones): with the small
    # jobs alone (or 16384 spp on a fast machine) the first run can end before the second
    # has even started, and the second then finds the store complete without waiting.
    args = list(_args(store))
    args[args.index("--spp") + 1] = "1,2,4,65536"
    n_jobs = 4 * 2
    a = _popen(args, root)
    lock = store / WRITER_LOCK
    deadline = time.monotonic() + 300
    while a.poll() is None and time.monotonic() < deadline:
        if lock.exists() and lock.read_bytes().startswith(b"pid"):
            break
        time.sleep(0.005)
    b = _popen(args, root)
    out_a, err_a = a.communicate(timeout=600)
    out_b, err_b = b.communicate(timeout=600)
    assert a.returncode == b.returncode == 0, (err_a, err_b)
    _assert_complete(store, n_jobs)
    rendered = sorted(int(m) for o in (out_a, out_b) for m in re.findall(r"\((\d+) jobs rendered", o))
    assert rendered == [0, n_jobs]  # one rendered everything, the other waited and found it done
    assert "waiting for the other run" in err_b


# ------------------------------------------------------------------------- read-only folders

@contextlib.contextmanager
def _read_only(path: Path):
    """``path`` read-only for a child process: permissions (non-root) or a read-only bind mount (root)."""
    if os.geteuid() != 0:
        modes = {p: p.stat().st_mode for p in [path, *path.rglob("*")]}
        for p in modes:
            p.chmod(modes[p] & ~0o222)
        try:
            yield
        finally:
            for p, m in modes.items():
                p.chmod(m)
        return
    if shutil.which("mount") is None or subprocess.run(["mount", "--bind", str(path), str(path)],
                                                       capture_output=True).returncode != 0:
        pytest.skip("cannot make a read-only folder here (root without mount)")
    try:
        if subprocess.run(["mount", "-o", "remount,bind,ro", str(path)], capture_output=True).returncode != 0:
            pytest.skip("cannot remount read-only here")
        yield
    finally:
        subprocess.run(["umount", str(path)], capture_output=True)


def test_read_only_cache_serves_its_valid_entries(cache, tmp_path):
    root, _ = cache
    ro = tmp_path / "ro-cache"
    shutil.copytree(root, ro)
    with _read_only(ro):
        store = tmp_path / "s"
        rtbench(*_args(store), cache=ro)  # references and tail references all read from the read-only cache
        _assert_complete(store)
        miss = rtbench("reference", "cornell_box", "--spp", "64", "--width", "8", "--height", "8", cache=ro,
                       check=False)
    assert miss.returncode == 3
    line = _one_line(miss.stderr)
    assert line.startswith("rtbench reference: error:") and "cannot write to the cache" in line


def test_read_only_store(cache, tmp_path):
    root, warm = cache
    store = _copy_store(warm, tmp_path / "s")
    before = (store / RESULTS).read_bytes()
    with _read_only(store):
        again = rtbench(*_args(store), cache=root, check=False)
        report_in_place = rtbench("report", store, "--quiet", cache=root, check=False)
        report_elsewhere = rtbench("report", store, "--quiet", "--out", tmp_path / "out", cache=root, check=False)
    assert again.returncode == 3 and _one_line(again.stderr).startswith("rtbench curves: error:")
    assert report_in_place.returncode == 3 and _one_line(report_in_place.stderr).startswith("rtbench report: error:")
    assert report_elsewhere.returncode == 0, report_elsewhere.stderr  # a reader never needs to write the store
    assert (store / RESULTS).read_bytes() == before


# ---------------------------------------------------------------------------------- corruption

def test_corrupt_cache_entry_is_rendered_again(cache, tmp_path):
    root, _ = cache
    copy = tmp_path / "cache"
    shutil.copytree(root, copy)
    for exr in (copy / "references").glob("*.mean.exr"):
        data = bytearray(exr.read_bytes())
        data[-20:-8] = bytes(12)
        exr.write_bytes(bytes(data))
    rtbench(*_args(tmp_path / "s"), cache=copy)
    _assert_complete(tmp_path / "s")
    a = {record_key(r): r["mse"] for r in read_records(tmp_path / "s")}
    b = {record_key(r): r["mse"] for r in read_records(cache[1])}
    assert a == pytest.approx(b)  # measured against a re-rendered reference, not the corrupt one


def test_corrupt_store_reference_is_replaced_on_resume(cache, tmp_path):
    root, warm = cache
    store = _copy_store(warm, tmp_path / "s")
    summary = (store / SUMMARY).read_text()
    info = json.loads((store / META).read_text())["references"]["cornell_box"]
    path = store / info["path"]
    data = bytearray(path.read_bytes())
    data[-20:-8] = bytes(12)
    path.write_bytes(bytes(data))
    rtbench(*_args(store), cache=root)
    from benchmarks.store import file_sha256

    assert file_sha256(path) == info["sha256"]
    strip = [{k: v for k, v in r.items() if "second" not in k and "efficiency" not in k and "time" not in k}
             for r in (json.loads(summary)["rows"][0], json.loads((store / SUMMARY).read_text())["rows"][0])]
    assert strip[0] == strip[1]


# ----------------------------------------------------------------------------------- full disk

def _tmpfs(path: Path, size: str) -> bool:
    path.mkdir(parents=True, exist_ok=True)
    if os.geteuid() != 0 or shutil.which("mount") is None:
        return False
    return subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(path)],
                          capture_output=True).returncode == 0


def test_full_disk_loses_nothing(cache, tmp_path, monkeypatch, capsys):
    root, _ = cache
    disk = tmp_path / "disk"
    if _tmpfs(disk, "24k"):  # a real full disk: room for the references and a few jobs
        try:
            full = rtbench(*_args(disk / "s"), cache=root, check=False)
            code, err = full.returncode, full.stderr
            shutil.copytree(disk / "s", tmp_path / "s")
        finally:
            subprocess.run(["umount", str(disk)], capture_output=True)
    else:  # simulated: ENOSPC from the third record's write
        from benchmarks.cli import main
        from benchmarks.sweep import runners

        real, calls = runners.append_record, []

        def append(store, record):
            calls.append(record)
            if len(calls) >= 3:
                raise OSError(errno.ENOSPC, "No space left on device", str(Path(store) / RESULTS))
            real(store, record)

        monkeypatch.setenv("RTBENCH_CACHE", str(root))
        monkeypatch.setattr(runners, "append_record", append)
        code = main([str(a) for a in _args(tmp_path / "s")])
        err = capsys.readouterr().err
        monkeypatch.undo()
    assert code == 3
    line = _one_line(err)
    assert "No space left on device" in line and "disk full" in line
    done = len(read_records(tmp_path / "s")) if (tmp_path / "s" / RESULTS).exists() else 0
    again = rtbench(*_args(tmp_path / "s"), cache=root)
    assert f"{done} already there" in again.stdout
    _assert_complete(tmp_path / "s")


# ----------------------------------------------------------------------------------- permissions

def test_cache_and_store_files_get_the_umask_permissions(cache):
    """Not the 0600 of a temporary file: a cache or store shared between users stays readable."""
    from reference_tracer.imageio import new_file_mode

    root, store = cache
    files = [p for p in [*(root / "references").iterdir(), *store.rglob("*")] if p.is_file()]
    assert files and {oct(p.stat().st_mode & 0o777) for p in files} == {oct(new_file_mode())}
