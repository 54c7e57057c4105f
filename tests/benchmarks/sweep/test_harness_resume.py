"""A sweep killed with SIGKILL and run again ends with exactly the records of an uninterrupted one."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import pytest

from benchmarks.store import RESULTS, read_records, record_key
from harness_util import ROOT, cache_root, comparable, rtbench

ARGS = ("curves", "cornell_box", "--strategies", "uniform,mis", "--spp", "1,2,4,8,16", "--seeds", "3",
        "--width", "16", "--height", "16", "--reference-spp", "1024", "--threads", "2", "--quiet")
N_JOBS = 3 * 5 * 3  # (uniform, mis, Mitsuba) x 5 spp x 3 seeds
#: summary fields that depend on timing
TIMED_SUMMARY = {"efficiency", "efficiency_vs_mitsuba", "time_to_target", "samples_per_second",
                 "samples_per_second_vs_mitsuba", "seconds_at_top"}


def _lines(path):
    try:
        return path.read_bytes().count(b"\n")
    except FileNotFoundError:
        return 0


def test_killed_sweep_resumes_to_the_same_records(tmp_path_factory):
    cache = cache_root(tmp_path_factory)
    base = tmp_path_factory.mktemp("resume")
    a, b = base / "uninterrupted", base / "killed"

    proc = rtbench(*ARGS, "--out", a, cache=cache)
    assert "rtbench summary" not in proc.stdout  # --quiet: no table (issue 16)
    rec_a = read_records(a)
    assert len(rec_a) == N_JOBS

    env = dict(os.environ, RTBENCH_CACHE=str(cache))
    proc = subprocess.Popen([sys.executable, "-m", "benchmarks.cli", *ARGS, "--out", str(b)], cwd=ROOT, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 300
    while _lines(b / RESULTS) < 8 and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.01)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    proc.stderr.close()
    done_at_kill = _lines(b / RESULTS)
    assert 8 <= done_at_kill < N_JOBS, f"the kill came at {done_at_kill} of {N_JOBS} jobs"
    # as if the kill had also landed in the middle of writing the next record
    partial = json.dumps({"scene": "cornell_box", "renderer": "ours", "strategy": "mis", "spp": 16})
    with open(b / RESULTS, "a") as f:
        f.write(partial[:40])

    again = rtbench(*ARGS, "--out", b, cache=cache)
    assert f"{done_at_kill} already there" in again.stdout
    raw = read_records(b, dedupe=False)
    keys = [record_key(r) for r in raw]
    assert len(keys) == len(set(keys)) == N_JOBS  # no job rendered twice, none lost
    before = raw[:done_at_kill]
    assert all(r["finished"] <= raw[done_at_kill]["finished"] for r in before)

    by_a = {record_key(r): comparable(r) for r in rec_a}
    by_b = {record_key(r): comparable(r) for r in raw}
    assert by_a.keys() == by_b.keys()
    diff = [k for k in by_a if by_a[k] != by_b[k]]
    assert not diff, (diff[:3], by_a[diff[0]], by_b[diff[0]]) if diff else None

    sum_a = json.loads((a / "summary.json").read_text())["rows"]
    sum_b = json.loads((b / "summary.json").read_text())["rows"]
    def untimed(r):
        out = {k: v for k, v in r.items() if k not in TIMED_SUMMARY and k != "by_metric"}
        out["by_metric"] = {m: {k: v for k, v in f.items() if k not in TIMED_SUMMARY and k != "efficiency_source"}
                            for m, f in (r.get("by_metric") or {}).items()}
        return out

    strip = [[untimed(r) for r in rows] for rows in (sum_a, sum_b)]
    assert strip[0] == strip[1]
    meta = json.loads((b / "meta.json").read_text())
    assert len(meta["runs"]) >= 1 and meta["total_seconds"] > 0


@pytest.mark.parametrize("bad", [("--spp", "1,x"), ("--seeds", "0"), ("--strategies", "mis,best"),
                                 ("--width", "0")])
def test_curves_cli_rejects_bad_input_without_traceback(tmp_path, capsys, bad):
    from benchmarks.cli import main

    code = main(["curves", "cornell_box", "--out", str(tmp_path / "s"), "--quiet", *bad])
    err = capsys.readouterr().err
    assert code == 2, err
    assert err.startswith("rtbench curves: error:") and "Traceback" not in err
    assert not (tmp_path / "s" / RESULTS).exists()


def test_run_cli_rejects_unknown_scene(tmp_path, capsys):
    from benchmarks.cli import main

    code = main(["run", "--scenes", "cornell_box,nope", "--out", str(tmp_path / "s"), "--quiet"])
    err = capsys.readouterr().err
    assert code == 2 and "unknown scene" in err and "nope" in err


@pytest.mark.slow
def test_rtbench_run_end_to_end_on_one_scene(tmp_path_factory):
    """`rtbench run` (quick preset, one scene): store, summary, report and the printed table."""
    cache = cache_root(tmp_path_factory)
    out = tmp_path_factory.mktemp("run") / "quick"
    proc = rtbench("run", "--scenes", "furnace", "--out", out, cache=cache)
    assert "rtbench summary" in proc.stdout and "furnace" in proc.stdout
    assert f"results: {out.resolve()}" in proc.stdout
    recs = read_records(out)
    assert len(recs) == 6 * 9 * 4  # 5 strategies + Mitsuba, spp 1..256, 4 seeds
    meta = json.loads((out / "meta.json").read_text())
    # furnace's reference is its closed form (exact: CLOSED_FORM_SPP stands for "no sampling noise")
    from benchmarks.constants import CLOSED_FORM, CLOSED_FORM_SPP

    furnace = meta["references"]["furnace"]
    assert meta["preset"] == "quick" and furnace["variant"] == CLOSED_FORM and furnace["spp"] == CLOSED_FORM_SPP
    try:
        import reports  # noqa: F401
    except ImportError:
        assert "report skipped" in proc.stdout
    else:
        assert (out / "index.html").exists() and f"report: {(out / 'index.html').resolve()}" in proc.stdout
