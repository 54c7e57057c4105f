"""``rtbench compare STORE_A STORE_B``: a changed tracer shows, an unchanged one does not."""
from __future__ import annotations

import dataclasses
import json

import pytest

import reference_tracer as rt
from benchmarks.cli import main
from benchmarks.compare import compare_stores
from benchmarks.sweep import Group, run_sweep

# The budget reaches 4096 spp so that a 5% bias flattens the error curve beyond doubt: with
# spps (16, 64, 256) and a 256-spp reference the slope interval excludes zero for only 10 to
# 13 of 20 random streams (passing would be a coin flip pinned to one stream); with these,
# 20 of 20, the lowest lower bound 0.12.
GROUP = dict(scenes=("large_light",), strategies=("mis",), spps=(16, 256, 4096), seeds=2, width=8, height=8,
             mitsuba=False, reference_spp=4096)


def _sweep(out):
    return run_sweep([Group(**GROUP)], out=out, threads=1, progress=False)


@pytest.fixture(scope="module")
def store_a(tmp_path_factory):
    out = tmp_path_factory.mktemp("a") / "store"
    _sweep(out)
    return out


def test_same_build_twice_is_not_a_difference(store_a, tmp_path):
    _sweep(tmp_path / "b")
    (row,) = compare_stores(store_a, tmp_path / "b")
    assert row.verdict == "pass" and row.build_a == row.build_b
    assert row.slope_diff == pytest.approx(0.0, abs=1e-12)      # the same seeds: the same images
    lo, hi = row.slope_diff_ci
    assert lo <= 0.0 <= hi


def test_a_changed_constant_fails_the_gate_and_names_both_builds(store_a, tmp_path, monkeypatch, capsys):
    real = rt.render

    def brighter(*args, **kwargs):   # "a changed constant": 5% too much light
        res = real(*args, **kwargs)
        return dataclasses.replace(res, mean=res.mean * 1.05, variance=res.variance * 1.05 ** 2)

    monkeypatch.setattr(rt, "build_id", lambda: "0123456789abcdef")
    monkeypatch.setattr(rt, "render", brighter)
    _sweep(tmp_path / "b")
    monkeypatch.undo()
    code = main(["compare", str(store_a), str(tmp_path / "b"), "--out", str(tmp_path / "page"),
                 "--json", str(tmp_path / "cmp.json")])
    err = capsys.readouterr().err
    assert code == 1 and "B differs from A in large_light 8x8 mis" in err
    (row,) = json.loads((tmp_path / "cmp.json").read_text())
    assert row["verdict"] == "fail" and row["build_b"] == "0123456789abcdef" and row["build_a"] != row["build_b"]
    assert row["relative_bias"] == pytest.approx(0.05, abs=0.01)
    assert row["slope_diff_ci"][0] > 0   # the biased curve flattens (timings are not asserted)
    assert (tmp_path / "page" / "index.html").is_file() and (tmp_path / "page" / "curve_000.png").is_file()


def test_stores_without_common_curves_are_refused(store_a, tmp_path, capsys):
    run_sweep([Group(**{**GROUP, "scenes": ("furnace",), "spps": (4,), "seeds": 1})], out=tmp_path / "f",
              threads=1, progress=False)
    assert main(["compare", str(store_a), str(tmp_path / "f"), "--out", str(tmp_path / "p")]) == 2
    assert "no curve" in capsys.readouterr().err


def _shifted_sweep(out, monkeypatch, *, gain=1.0):
    """B of this very build with other seeds (an independent, honest store), optionally too bright."""
    real = rt.render

    def other_seeds(*args, seed=0, **kwargs):
        res = real(*args, seed=seed + 7919, **kwargs)
        return dataclasses.replace(res, mean=res.mean * gain, variance=res.variance * gain ** 2)

    monkeypatch.setattr(rt, "render", other_seeds)
    _sweep(out)
    monkeypatch.undo()


@pytest.mark.parametrize("gain, verdict", [(1.0, "pass"), (1.05, "fail")])
def test_b_of_this_build_is_judged_with_its_tail_reference(store_a, tmp_path, monkeypatch, gain, verdict):
    """When B is this build, its estimator's tail reference (variance, skewness, kurtosis at a
    high budget) backs the verdict, as in ``rtbench gate``: an independent honest B passes,
    a 5% too bright one still fails. A store of another build gets none, and says why."""
    _shifted_sweep(tmp_path / "b", monkeypatch, gain=gain)
    code = main(["compare", str(store_a), str(tmp_path / "b"), "--out", str(tmp_path / "page"), "--quiet",
                 "--tail-spp", "2048", "--threads", "1", "--json", str(tmp_path / "cmp.json")])
    (row,) = json.loads((tmp_path / "cmp.json").read_text())
    assert row["tails"] == "tail reference of ours mis at 2048 spp"
    assert row["verdict"] == verdict and code == (0 if verdict == "pass" else 1)
    if verdict == "pass":   # the same store judged by a "foreign" build: no tail reference, and why
        from benchmarks.compare import estimator_knowledge

        knowledge = estimator_knowledge(tail_spp=2048, threads=1)
        records = [dict(r, build="feedfacecafebeef") for r in _records(tmp_path / "b")]
        note = knowledge(("large_light", "ours", "mis", 8, 8), records).note
        assert note.startswith("none: B is build feedfacecafebeef")


def _records(store):
    from benchmarks.store import read_records

    return read_records(store)


def test_tail_spp_is_validated(store_a, capsys):
    assert main(["compare", str(store_a), str(store_a), "--tail-spp", "1", "--quiet"]) == 2
    assert "--tail-spp" in capsys.readouterr().err


def test_a_store_without_its_images_is_bad_input(tmp_path, capfd):
    """B's results.jsonl names images that are not there: compare printed the EXR library's line and
    ``internal error: RuntimeError`` (exit 3); now one line naming the image, exit 2."""
    import shutil

    small = dict(GROUP, spps=(1, 2), reference_spp=16)
    run_sweep([Group(**small)], out=tmp_path / "a", threads=1, progress=False)
    shutil.copytree(tmp_path / "a", tmp_path / "b")
    shutil.rmtree(tmp_path / "b" / "images")
    capfd.readouterr()
    code = main(["compare", str(tmp_path / "a"), str(tmp_path / "b"), "--out", str(tmp_path / "page"), "--quiet"])
    err = [ln for ln in capfd.readouterr().err.splitlines() if ln.strip()]
    assert code == 2
    assert len(err) == 1 and err[0].startswith("rtbench compare: error: ") and "internal error" not in err[0], err
    assert str(tmp_path / "b" / "images") in err[0] and "missing, though the store names it" in err[0]


# ------------------------------------------------------------ synthetic stores: how compare reads records

def _write_store(path, records):
    from benchmarks.store import append_record

    for r in records:
        append_record(path, {"scene": "cornell_box", "renderer": "ours", "strategy": "mis", "seed": 0, "width": 8,
                             "height": 8, "build": "0ld0ld0ld0ld0ld0", **r})
    return path


def _curve(path, extra=(), **kw):
    """spp 1, 2, 4 with seeds 0 and 1 (MSE 1/spp), then ``extra`` records."""
    recs = [{"spp": s, "seed": seed, "mse": 1.0 / s, "seconds": 0.01 * s, **kw} for s in (1, 2, 4) for seed in (0, 1)]
    return _write_store(path, recs + list(extra))


def test_compare_shows_the_newest_build_of_a_curve(tmp_path):
    """B's newest build (spp 1 only, appended last) was read as older and hidden; B's old build lost spp 1."""
    new = [{"spp": 1, "seed": seed, "mse": 1.0, "seconds": 0.01, "build": "feedfacefeedface"} for seed in (0, 1)]
    (row,) = compare_stores(_curve(tmp_path / "a"), _curve(tmp_path / "b", new))
    assert row.build_b == "feedfacefeedface" and row.spps_b == [1]
    assert row.build_a == "0ld0ld0ld0ld0ld0" and row.spps_a == [1, 2, 4]


@pytest.mark.parametrize("bad", [{"seconds": "x"}, {"seconds": [1]}, {"mse": "x"}, {"mse_corrected": float("nan")},
                                 {"mse_corrected": float("inf")}])
def test_compare_leaves_out_a_bad_value_with_a_warning_never_fatal(tmp_path, bad):
    """``"seconds": "x"`` was a bare "could not convert string to float", ``[1]`` an internal TypeError, and one
    NaN ``mse_corrected`` silently dropped its whole spp budget from the slope: now that record alone is left
    out, with a warning naming the store and the curve."""
    import math
    import warnings

    b = _curve(tmp_path / "b", [{"spp": 2, "seed": 2, "mse": 0.5, "seconds": 0.02, **bad}])
    with open(b / "results.jsonl") as f:    # NaN and infinity reach the file as a foreign writer writes them
        assert f.read().count("\n") == 7
    if any(isinstance(v, float) for v in bad.values()):
        lines = (b / "results.jsonl").read_text().splitlines()
        last = json.loads(lines[-1])
        last.update(bad)
        (b / "results.jsonl").write_text("\n".join(lines[:-1] + [json.dumps(last)]) + "\n")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        (row,) = compare_stores(_curve(tmp_path / "a"), b)
    said = [str(w.message) for w in caught if "left out" in str(w.message)]
    assert len(said) == 1 and str(b / "results.jsonl") in said[0] and "cornell_box 8x8 mis" in said[0], said
    assert row.spps_b == [1, 2, 4] and all(math.isfinite(x) for x in row.rmse_b)
    assert row.slope_b == pytest.approx(row.slope_a)


def test_compare_takes_an_image_field_that_is_no_file_name_as_absent(tmp_path):
    """``"stats_image": 5`` was fatal (read as a path); now the curve has no images and says so."""
    (row,) = compare_stores(_curve(tmp_path / "a"), _curve(tmp_path / "b", stats_image=5, image=[1]))
    assert row.verdict is None and "no images" in row.reason


def test_compare_refuses_an_output_that_is_a_file_before_any_work(tmp_path, capsys, monkeypatch):
    """``--out FILE`` rendered everything, then failed with exit 3; now exit 2 up front, as report does."""
    import benchmarks.compare as cmp

    a, b = _curve(tmp_path / "a"), _curve(tmp_path / "b")
    (tmp_path / "page").write_text("not a folder")
    monkeypatch.setattr(cmp, "compare_stores", lambda *a, **k: pytest.fail("compared before checking --out"))
    assert main(["compare", str(a), str(b), "--out", str(tmp_path / "page"), "--quiet", "--tail-spp", "0"]) == 2
    assert "exists and is not a folder" in capsys.readouterr().err
    assert (tmp_path / "page").read_text() == "not a folder"
