"""``rtbench gate`` and its driver (``benchmarks.gate.suite``): verdicts, messages, images, bad input.

Small images (8-16 pixels) and references of a few hundred spp in a per-session cache, so
this file takes seconds. The gate's statistics are tested in ``test_gate_stats.py``, its
false-alarm rate and power on real renders in ``test_gate_power.py``.
"""
from __future__ import annotations

import numpy as np
import pytest

from benchmarks.cli import main
from benchmarks.constants import GATE_ALPHA
from benchmarks.gate import compare, gate_reference, gate_scene, resolve_scenes, resolve_strategies, run_gate
from benchmarks.references import CLOSED_FORM_REASONS, closed_form_reference_of
from harness_util import cache_root, strict_json

SMALL = dict(width=16, spp=64, ref_spp=256, threads=2)


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return cache_root(tmp_path_factory)


def test_unbiased_passes_and_biased_strategy_fails_with_where_and_how_much(cache):
    report = run_gate(["cornell_box", "furnace"], strategies=["light"], cache=cache, **SMALL)
    verdict = {(c.scene, c.strategy): c for c in report.cases}
    assert list(verdict) == [("cornell_box", "mis"), ("cornell_box", "light"), ("furnace", "mis"),
                             ("furnace", "light")]
    # four comparisons share alpha (Bonferroni)
    assert report.case_alpha == pytest.approx(GATE_ALPHA / 4)
    assert all(c.alpha == report.case_alpha for c in report.cases)
    assert verdict["cornell_box", "mis"].passed and verdict["furnace", "mis"].passed
    assert not report.passed and {(c.scene, c.strategy) for c in report.failures} == {
        ("cornell_box", "light"), ("furnace", "light")}
    # light sampling misses all indirect light: the image is far too dark, everywhere
    box = verdict["cornell_box", "light"]
    assert box.result.relative_bias < -0.1
    msg = box.message()
    assert msg.startswith("cornell_box (light, 16x16, 64 spp)")
    assert "relative bias of the image -" in msg and ("rows" in msg or "pixel row" in msg)
    # the furnace is compared with its closed form, exactly: zero-variance reference
    fur = verdict["furnace", "light"]
    assert fur.reference.source == "closed form" and fur.reference.variance.max() == 0
    assert "closed form reference" in fur.message()


def test_furnace_reference_is_exact_and_mis_matches_it():
    scene = gate_scene("furnace", width=8)
    ref = closed_form_reference_of("furnace", scene.camera.width, scene.camera.height)
    assert ref is not None and "furnace" in CLOSED_FORM_REASONS
    np.testing.assert_allclose(ref.mean, 0.5 * (1 - 0.8**8) / 0.2, rtol=1e-6)
    assert gate_reference("furnace", scene).source == "closed form"
    assert closed_form_reference_of("cornell_box", 8, 8) is None


def test_rounding_level_variance_is_zero_variance():
    """A directly seen light: our per-sample variance is float rounding (~1e-15), the
    reference's exactly 0, and the two emitter constants differ by 3e-6 relative
    (Mitsuba's 0.8356318 vs our 0.83562905 in ``large_light``). That is equality within
    ``zero_var_rtol``; before the fix every 256-spp render of ``large_light`` failed."""
    ours = np.full((4, 4, 3), 0.83562905, dtype=np.float32)
    ref = np.full((4, 4, 3), 0.8356318, dtype=np.float32)
    res = compare(ours, np.full_like(ours, 3.3e-15), 256, ref, np.zeros_like(ref), 8192)
    assert res.passed and res.n_tests["pixel"] == 0
    # a real difference (0.1%) with no noise is still a certain failure
    res = compare(ours * 1.001, np.full_like(ours, 3.3e-15), 256, ref, np.zeros_like(ref), 8192)
    assert not res.passed and res.p_value == 0.0
    # a genuinely noisy pixel (per-sample std 1% of the mean) is not zeroed
    res = compare(ours, np.full_like(ours, (0.01 * 0.8356) ** 2), 256, ref, np.zeros_like(ref), 8192)
    assert res.n_tests["pixel"] == ours.size


def test_cli_failure_writes_images_and_message(cache, tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("RTBENCH_CACHE", str(cache))
    out = tmp_path / "gate"
    code = main(["gate", "cornell_box", "--width", "16", "--spp", "64", "--ref-spp", "256", "--threads", "2",
                 "--strategies", "light", "--out", str(out), "--json", str(tmp_path / "gate.json")])
    cap = capsys.readouterr()
    assert code == 1
    assert "FAIL" in cap.out and "pass" in cap.out  # the table: mis passes, light fails
    fail_lines = [ln for ln in cap.err.splitlines() if ln.startswith("rtbench gate: FAIL")]
    assert len(fail_lines) == 1 and "cornell_box (light" in fail_lines[0] and "relative bias" in fail_lines[0]
    assert "1 of 2 comparison(s) failed" in cap.err
    for suffix in ("_p.png", "_p.exr", "_ours.png", "_reference.png"):
        assert (out / f"cornell_box_light{suffix}").stat().st_size > 0
    assert not (out / "cornell_box_mis_p.png").exists()  # images only for failures
    import json

    data = json.loads((tmp_path / "gate.json").read_text())
    assert [c["passed"] for c in data["cases"]] == [True, False] and data["passed"] is False


def test_cli_json_is_strict_with_undefined_numbers_as_null(cache, tmp_path, monkeypatch):
    # light sampling in the furnace is exact per sample (zero variance) and wrong, against a
    # noiseless closed form: its t-statistic is infinite, written as null
    monkeypatch.setenv("RTBENCH_CACHE", str(cache))
    out = tmp_path / "gate.json"
    code = main(["gate", "furnace", "--strategies", "light", "--width", "8", "--spp", "16", "--tail-spp", "64",
                 "--threads", "2", "--out", str(tmp_path / "gate"), "--json", str(out), "--quiet"])
    assert code == 1
    cases = {c["strategy"]: c for c in strict_json(out.read_text())["cases"]}
    assert cases["light"]["verdict"] == "fail" and cases["light"]["relative_bias_se"] == 0.0
    assert cases["light"]["max_abs_t"] is None
    assert cases["mis"]["verdict"] == "pass" and isinstance(cases["mis"]["max_abs_t"], float)


def test_cli_pass_exits_zero(cache, tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("RTBENCH_CACHE", str(cache))
    code = main(["gate", "cornell_box", "furnace", "--width", "16", "--spp", "64", "--ref-spp", "256",
                 "--threads", "2", "--out", str(tmp_path / "gate")])
    assert code == 0, capsys.readouterr()
    assert "gate passed" in capsys.readouterr().out
    assert not (tmp_path / "gate").exists()


@pytest.mark.parametrize("bad, words", [
    (["nope"], "unknown scene"),
    (["cornell_box", "--strategies", "mis,bogus"], "unknown strategy bogus"),
    (["cornell_box", "--spp", "1"], "spp must be >= 2, got 1"),
    (["cornell_box", "--ref-spp", "0"], "--reference-spp must be >= 1"),
    (["cornell_box", "--reference-spp", "1"], "ref_spp must be >= 2, got 1"),
    (["cornell_box", "--tail-spp", "1"], "tail_spp must be 0 (no tail references) or >= 2"),
    (["cornell_box", "--alpha", "1.5"], "--alpha must be in (0, 1)"),
    (["cornell_box", "--width", "0"], "--width must be >= 1"),
    (["cornell_box", "--threads", "0"], "--threads must be >= 1"),
])
def test_cli_bad_input_is_one_line(bad, words, capsys, tmp_path, monkeypatch):
    monkeypatch.setenv("RTBENCH_CACHE", str(tmp_path / "cache"))
    code = main(["gate", *bad, "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and err[0].startswith("rtbench gate: error:") and words in err[0], err
    assert not (tmp_path / "cache" / "references").exists() or not any((tmp_path / "cache" / "references").iterdir())


def test_resolve_helpers():
    assert resolve_strategies([]) == ["mis"]
    assert resolve_strategies("light,mis, cosine") == ["mis", "light", "cosine"]
    assert resolve_scenes("cornell_box,cornell_box") == ["cornell_box"]
    assert len(resolve_scenes(None)) == 8
    with pytest.raises(ValueError, match="no scene"):
        resolve_scenes([])


@pytest.mark.parametrize("tail_spp, warned", [(1024, "is below 16384"), (0, "turns the tail references off"),
                                              (16384, None)])
def test_a_tail_spp_below_the_calibrated_budget_is_warned_about(tail_spp, warned, capsys):
    # the warning comes before any render: an unknown scene then stops the command at once
    assert main(["gate", "no_such_scene", "--tail-spp", str(tail_spp), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "unknown scene" in err
    if warned:
        assert f"warning: --tail-spp {tail_spp} {warned}" in err
    else:
        assert "warning" not in err
