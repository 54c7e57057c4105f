"""How every reader reads a store: which build a curve shows, files confined to the store, bad key fields
skipped (``STORE.md``, ``SECURITY.md``)."""
from __future__ import annotations

import json
import os
import warnings

import pytest

from benchmarks.store import (META, RESULTS, SUMMARY, append_record, finished_keys, job_records, read_meta,
                              read_records, read_summary_rows)

OLD, NEW = "0ld0ld0ld0ld0ld0", "feedfacefeedface"


def rec(**kw):
    r = {"scene": "s", "renderer": "ours", "strategy": "mis", "spp": 1, "seed": 0, "width": 8, "height": 8,
         "mse": 0.5, "seconds": 1.0, "build": OLD}
    r.update(kw)
    return r


def _points(records):
    return sorted((r["build"], r["spp"], r["seed"]) for r in records)


def _quiet_read(store):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        records = read_records(store)
    return records, [str(w.message) for w in caught]


# ------------------------------------------------------------------ 1: a curve shows its latest build

def _old_then_new(store):
    """Build OLD at spp 1, 2, 4 (2 seeds), then build NEW at spp 1: NEW is the latest build."""
    for spp in (1, 2, 4):
        for seed in (0, 1):
            append_record(store, rec(spp=spp, seed=seed))
    for seed in (0, 1):
        append_record(store, rec(spp=1, seed=seed, build=NEW))


def test_the_newest_build_in_file_order_is_the_one_shown(tmp_path):
    """A NEW build's spp-1 records replaced OLD's at OLD's (first) position, so OLD's spp-4 record read as the
    curve's last: NEW was hidden as "older" and OLD lost its spp-1 point."""
    _old_then_new(tmp_path)
    assert _points(read_records(tmp_path)) == [(NEW, 1, 0), (NEW, 1, 1)]


def test_a_superseded_record_takes_no_point_from_another_build(tmp_path):
    """OLD at spp 1, NEW at spp 1, then OLD again at spp 2 and 4 (its run resumed last): OLD is the latest
    build and keeps all three points; NEW's spp-1 record of the same job does not remove OLD's."""
    append_record(tmp_path, rec(spp=1))
    append_record(tmp_path, rec(spp=1, build=NEW))
    append_record(tmp_path, rec(spp=2))
    append_record(tmp_path, rec(spp=4))
    append_record(tmp_path, rec(spp=2, mse=0.25))            # a re-run of one job of OLD: the last wins
    records = read_records(tmp_path)
    assert _points(records) == [(OLD, 1, 0), (OLD, 2, 0), (OLD, 4, 0)]
    assert [r["mse"] for r in records if r["spp"] == 2] == [0.25]


def test_report_names_the_old_build_as_old(tmp_path):
    from reports.store import load_store

    _old_then_new(tmp_path)
    st = load_store(tmp_path)
    assert {r["build"] for r in st.records} == {NEW} and len(st.records) == 2
    older = [p for p in st.problems if "older build" in p]
    assert older == [f"{RESULTS}: 6 record(s) of older build(s) ({OLD}) not shown: each curve shows its latest "
                     "build only"], st.problems


# ------------------------------------------------------------------ 2: no file read from outside the store

@pytest.fixture
def outside(tmp_path):
    """Files outside the store that a link in it points to."""
    out = tmp_path / "elsewhere"
    out.mkdir()
    (out / "x.json").write_text(json.dumps({"preset": "stolen", "rows": [{"scene": "x", "renderer": "ours",
                                                                          "strategy": "mis"}]}))
    (out / "x.jsonl").write_text(json.dumps(rec()) + "\n")
    return out


@pytest.mark.parametrize("name, target", [(META, "x.json"), (SUMMARY, "x.json"), (RESULTS, "x.jsonl")])
def test_a_store_file_linked_out_of_the_store_is_not_read(tmp_path, outside, name, target):
    from reports.store import load_store

    store = tmp_path / "store"
    store.mkdir()
    if name != RESULTS:
        append_record(store, rec())
    os.symlink(outside / target, store / name)
    problems = []
    assert read_meta(store, problems=problems).get("preset") is None
    assert read_summary_rows(store, problems=problems) == []
    records, skipped = job_records(store)
    assert len(records) == (0 if name == RESULTS else 1)
    st = load_store(store)
    said = [p for p in st.problems if "leaves its folder through a symbolic link" in p]
    assert len(said) == 1 and name in said[0], st.problems
    assert st.meta.get("preset") is None and st.rows == []
    if name == RESULTS:
        assert st.records == [] and len(skipped) == 1
        records, messages = _quiet_read(store)
        assert records == [] and any("symbolic link" in m for m in messages)


def test_a_link_that_stays_in_the_store_is_read(tmp_path):
    store = tmp_path / "store"
    (store / "keep").mkdir(parents=True)
    append_record(store / "keep", rec())
    os.symlink("keep/" + RESULTS, store / RESULTS)
    (store / "keep" / "m.json").write_text(json.dumps({"preset": "quick"}))
    os.symlink("keep/m.json", store / META)
    assert len(read_records(store)) == 1 and read_meta(store)["preset"] == "quick"


# ------------------------------------------------------------------ 3: malformed key fields are skipped

BAD_KEYS = [{"width": [8]}, {"height": {"a": 1}}, {"seed": [0]}, {"build": ["x"]}, {"build": {"b": 1}},
            {"spp": float("inf")}, {"seed": True}]


@pytest.mark.parametrize("bad", BAD_KEYS, ids=lambda b: f"{next(iter(b))}={next(iter(b.values()))!r}")
def test_a_record_with_a_malformed_key_field_is_skipped_never_fatal(tmp_path, bad):
    """width/height/seed/build a list or dict: ``TypeError: unhashable type`` in record_key/dedupe_records;
    spp Infinity passed the check, then failed converting to int."""
    from reports.store import load_store

    append_record(tmp_path, rec())
    with open(tmp_path / RESULTS, "a") as f:
        f.write(json.dumps(rec(**{"spp": 2, **bad})) + "\n")
    records, messages = _quiet_read(tmp_path)
    assert [r["spp"] for r in records] == [1]
    assert len(messages) == 1 and "line 2 is not a job record" in messages[0] and next(iter(bad)) in messages[0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert len(finished_keys(tmp_path)) == 1                   # curves --resume
    st = load_store(tmp_path)
    assert [r["spp"] for r in st.records] == [1]
    assert any(p.startswith(f"{RESULTS}: line 2 is not a job record") for p in st.problems), st.problems


def test_gate_reference_of_a_build_skips_malformed_records(tmp_path):
    from benchmarks.gate.store_reference import _records

    append_record(tmp_path, rec())
    with open(tmp_path / RESULTS, "a") as f:
        f.write(json.dumps(rec(spp=2, width=[8])) + "\n")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert [r["spp"] for r in _records(tmp_path, OLD)] == [1]


# ------------------------------------------------------------------ 5: a summary row without its renderer

@pytest.mark.parametrize("row", [{"renderer": None}, {"renderer": "ours", "strategy": None}, {}])
def test_a_summary_row_without_its_identity_is_skipped_with_a_problem(tmp_path, row):
    from reports.store import load_store

    append_record(tmp_path, rec())
    good = {"scene": "s", "renderer": "ours", "strategy": "mis", "width": 8, "height": 8, "slope": -0.5}
    bad = {"scene": "s", **row} if row else {"scene": "s", "strategy": "mis"}
    (tmp_path / SUMMARY).write_text(json.dumps({"rows": [good, bad]}))
    st = load_store(tmp_path)
    assert st.rows == [good]
    assert any(p.startswith(f"{SUMMARY} row 1") and p.endswith("skipped") for p in st.problems), st.problems
