"""The results store: durable appends, truncated tails, dedupe, metadata (no rendering)."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from benchmarks.store import (KEY_FIELDS, RESULTS, append_record, finished_keys, read_json, read_records,
                              record_key, update_meta, write_image, write_json, read_image)


def rec(spp=4, seed=0, **kw):
    r = {"scene": "s", "renderer": "ours", "strategy": "mis", "spp": spp, "seed": seed, "width": 8,
         "height": 8, "mse": 0.5}
    r.update(kw)
    return r


def test_append_and_read_roundtrip(tmp_path):
    append_record(tmp_path, rec(mse=float("nan"), ssim=np.float32(0.25), n=np.int64(3), ok=np.bool_(True)))
    append_record(tmp_path, rec(spp=8))
    rs = read_records(tmp_path)
    assert [r["spp"] for r in rs] == [4, 8]
    assert rs[0]["mse"] is None and rs[0]["ssim"] == 0.25 and rs[0]["n"] == 3 and rs[0]["ok"] is True
    # the last field is the build (None: a record that names none)
    assert finished_keys(tmp_path) == {("s", "ours", "mis", 4, 0, 8, 8, None), ("s", "ours", "mis", 8, 0, 8, 8, None)}
    # one JSON object per line, valid JSON everywhere (no NaN tokens)
    lines = (tmp_path / RESULTS).read_text().splitlines()
    assert len(lines) == 2 and all(json.loads(line) for line in lines)


def test_truncated_last_line_is_skipped_and_cut_before_appending(tmp_path):
    append_record(tmp_path, rec(spp=1))
    append_record(tmp_path, rec(spp=2))
    path = tmp_path / RESULTS
    full = path.read_bytes()
    # a writer killed half-way through the third record
    third = json.dumps(rec(spp=3)).encode()
    path.write_bytes(full + third[: len(third) // 2])
    assert [r["spp"] for r in read_records(tmp_path)] == [1, 2]
    assert (1, 2) == tuple(sorted(k[3] for k in finished_keys(tmp_path)))
    append_record(tmp_path, rec(spp=3))
    assert [r["spp"] for r in read_records(tmp_path)] == [1, 2, 3]
    assert path.read_bytes() == full + third + b"\n"


def test_corrupt_middle_line_warns_and_is_skipped(tmp_path):
    append_record(tmp_path, rec(spp=1))
    with open(tmp_path / RESULTS, "a") as f:
        f.write("{not json\n")
    append_record(tmp_path, rec(spp=2))
    with pytest.warns(RuntimeWarning, match="line 2"):
        assert [r["spp"] for r in read_records(tmp_path)] == [1, 2]


def test_dedupe_last_record_wins_in_file_order(tmp_path):
    """The last record of a job stays where it is in the file (it was moved to the first's position, which made
    a newer build's record look older than the records after it: :func:`latest_builds` read the wrong build)."""
    append_record(tmp_path, rec(spp=1, mse=1.0))
    append_record(tmp_path, rec(spp=2, mse=2.0))
    append_record(tmp_path, rec(spp=1, mse=3.0))
    assert [(r["spp"], r["mse"]) for r in read_records(tmp_path)] == [(2, 2.0), (1, 3.0)]
    assert len(read_records(tmp_path, dedupe=False)) == 3


def test_record_without_key_fields_is_refused(tmp_path):
    bad = rec()
    del bad["seed"]
    with pytest.raises(ValueError, match="seed"):
        append_record(tmp_path, bad)
    assert record_key(rec()) == tuple(rec()[k] for k in KEY_FIELDS) + (None,)  # no build recorded


def test_store_path_that_is_a_file_is_an_error(tmp_path):
    f = tmp_path / "file"
    f.write_text("x")
    with pytest.raises(ValueError, match="not a folder"):
        append_record(f, rec())


def test_meta_merge_and_atomic_json(tmp_path):
    update_meta(tmp_path, preset="quick", references={"a": {"spp": 1}}, total_seconds=1.0)
    meta = update_meta(tmp_path, references={"b": {"spp": 2}}, total_seconds=math.inf)
    assert meta["references"] == {"a": {"spp": 1}, "b": {"spp": 2}}
    assert read_json(tmp_path / "meta.json")["total_seconds"] is None
    write_json(tmp_path / "x.json", {"v": [1, 2]})
    assert read_json(tmp_path / "x.json") == {"v": [1, 2]}
    # strict JSON (the commands' --json too): numpy values become Python's, NaN and infinity null
    write_json(tmp_path / "sub" / "y.json", {"a": np.array([1.5, np.nan]), "b": np.float32(np.inf), "c": np.int64(3),
                                            "d": (np.bool_(True), -math.inf)})
    text = (tmp_path / "sub" / "y.json").read_text()
    assert json.loads(text, parse_constant=pytest.fail) == {"a": [1.5, None], "b": None, "c": 3, "d": [True, None]}
    assert not list(tmp_path.glob(".*tmp"))  # no temporary files left behind
    assert read_json(tmp_path / "missing.json", default=7) == 7


def test_images_roundtrip_and_paths_stay_inside_the_store(tmp_path):
    img = np.random.default_rng(0).random((4, 5, 3)).astype(np.float32)
    rel = write_image(tmp_path, "images/a/b.exr", img)
    assert rel == "images/a/b.exr"
    np.testing.assert_array_equal(read_image(tmp_path, rel), img)
    with pytest.raises(ValueError, match="relative"):
        write_image(tmp_path, "../escape.exr", img)
