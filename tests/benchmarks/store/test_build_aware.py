"""Build-aware stores: a new build of the tracer never reuses the old build's records."""
from __future__ import annotations

import pytest

import reference_tracer as rt
from benchmarks.store import read_records, record_key, result_lines
from benchmarks.sweep import Group, run_sweep
from benchmarks.sweep.execute import execute_job
from benchmarks.sweep.jobs import Job
from benchmarks.references import closed_form_reference_of

NEW_BUILD = "feedfacefeedface"


def _sweep(out):
    group = Group(scenes=("furnace",), strategies=("mis",), spps=(1, 2), seeds=1, width=4, height=4,
                  mitsuba=False, reference_spp=16)
    return run_sweep([group], out=out, threads=1, progress=False)


def test_new_build_renders_again_and_curves_show_one_build(tmp_path, monkeypatch):
    store = tmp_path / "store"
    first = _sweep(store)
    old_build = rt.build_id()
    assert first.done == 2 and {r["build"] for r in read_records(store)} == {old_build}
    assert _sweep(store).skipped == 2          # same build: resumed, nothing rendered

    monkeypatch.setattr(rt, "build_id", lambda: NEW_BUILD)   # "rebuilt with a changed constant"
    second = _sweep(store)
    assert second.done == 2 and second.skipped == 0          # no stale reuse
    raw = [line.value for line in result_lines(store)]
    assert sorted(r["build"] for r in raw) == sorted([old_build] * 2 + [NEW_BUILD] * 2)  # old kept beside
    assert {r["build"] for r in read_records(store)} == {NEW_BUILD}                      # never mixed
    assert {row["build"] for row in second.rows} == {NEW_BUILD}
    assert _sweep(store).skipped == 2


def test_record_key_carries_the_build():
    rec = {"scene": "s", "renderer": "ours", "strategy": "mis", "spp": 1, "seed": 0, "width": 4, "height": 4}
    assert record_key({**rec, "build": "a"}) != record_key({**rec, "build": "b"})
    assert record_key(rec)[-1] is None       # stores written before builds were recorded


def test_job_planned_for_another_build_is_refused():
    job = Job("furnace", "ours", "mis", 1, 0, 4, 4, build="0000000000000000")
    with pytest.raises(RuntimeError, match="planned for tracer build 0000000000000000"):
        execute_job(job, closed_form_reference_of("furnace", 4, 4), threads=1)


def test_git_describe_is_not_part_of_a_records_identity():
    """A commit between two runs (or a Dask worker started after one) changes build_git, not the build."""
    from harness_util import comparable

    rec = {"scene": "s", "mse": 1.0, "build": "a", "build_git": "v1-dirty"}
    assert comparable(rec) == comparable({**rec, "build_git": "v2"})
    assert comparable(rec) != comparable({**rec, "build": "b"})
