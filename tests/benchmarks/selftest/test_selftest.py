"""The self-test (``rtbench selftest``, ``benchmarks.selftest``): seeded bugs and who catches them.

Fast checks in the default suite: the mutants are out of reach of ``rt.render``, each one
changes the image of its scene, the unmutated path is bit-identical to ``rt.render``, and a
small self-test (three mutants at 16x16, a few hundred spp) catches them all. The whole
catalogue at the gate's default budget is behind ``@pytest.mark.slow``.
"""
from __future__ import annotations

import dataclasses
import inspect

import numpy as np
import pytest

import reference_tracer as rt
from benchmarks.cli import main
from benchmarks.selftest import (CATALOGUE, SELFTEST_SCENES, ladder, mutant_id, mutant_names, render_mutant,
                                 resolve_mutants, run_selftest, selftest_scene)
from harness_util import cache_root, strict_json


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return cache_root(tmp_path_factory)


def test_mutants_cannot_be_reached_through_render():
    assert "mutant" not in inspect.signature(rt.render).parameters
    assert "mutant" not in inspect.getsource(rt.render)
    scene = selftest_scene("cornell_box", width=4)
    with pytest.raises(TypeError):
        rt.render(scene, spp=1, strategy="mis", mutant=1)  # noqa - the keyword does not exist
    # the tracer's module has no mutant at all (this test names the private modules on purpose)
    from reference_tracer import _core
    from reference_tracer.probe import core_scene
    from reference_tracer.testing import mutant_core_scene

    with pytest.raises(TypeError):
        core_scene(scene).render(1, 4, 0, 1, None, False, mutant=1)
    assert not any("mutant" in name for name in dir(_core))
    # the self-test's module range-checks the id
    bugged = mutant_core_scene(scene)
    for bad in (-1, len(mutant_names()), 1000):
        with pytest.raises(ValueError, match="mutant id out of range"):
            bugged.render(1, 4, 0, 1, None, False, mutant=bad)
    with pytest.raises(ValueError, match="unknown mutant"):
        render_mutant(scene, "no_such_bug", spp=1, strategy="mis")


def test_catalogue_matches_the_core_and_is_complete():
    names = [m.name for m in CATALOGUE]
    assert names == mutant_names()[1:] and mutant_names()[0] == "none"
    assert len(names) >= 10 and len(set(names)) == len(names)
    assert mutant_id("missing_cosine") == 1
    for m in CATALOGUE:
        assert m.strategy in rt.STRATEGIES and m.description and m.breaks and m.why
        selftest_scene(m.scene, width=4)  # every scene builds
    assert set(SELFTEST_SCENES) <= {m.scene for m in CATALOGUE}
    assert [m.name for m in resolve_mutants("pdf_off_by_pi, missing_cosine,pdf_off_by_pi")] == [
        "pdf_off_by_pi", "missing_cosine"]
    with pytest.raises(ValueError, match="unknown mutant"):
        resolve_mutants(["missing_cosine", "typo"])
    assert ladder(4096) == [64, 256, 1024, 4096] and ladder(100, (64, 256)) == [64, 100]


def test_the_unmutated_path_is_the_tracer():
    scene = selftest_scene("cornell_glass", width=12)
    a = rt.render(scene, spp=8, strategy="mixture", seed=3, threads=2, moments=True)
    b = render_mutant(scene, "none", spp=8, strategy="mixture", seed=3, threads=2, moments=True)
    assert np.array_equal(a.mean, b.mean) and np.array_equal(a.variance, b.variance)
    assert np.array_equal(a.moments.m4, b.moments.m4) and a.rays == b.rays


@pytest.mark.parametrize("m", CATALOGUE, ids=lambda m: m.name)
def test_each_mutant_changes_its_image(m):
    scene = selftest_scene(m.scene, width=12)
    kw = dict(spp=16, strategy=m.strategy, seed=7, threads=2)
    normal, bugged = render_mutant(scene, "none", **kw), render_mutant(scene, m.name, **kw)
    assert bugged.nonfinite_samples == 0
    assert not np.array_equal(normal.mean, bugged.mean), f"{m.name} leaves {m.scene} unchanged"


def test_mutants_that_need_their_scene_are_invisible_elsewhere():
    """Why the catalogue picks its scenes: closed glass lit from outside cancels the 1/eta^2
    of refraction exactly, and a wrong Lambertian density used consistently in both MIS
    weights leaves mis unbiased (only mixture divides by it alone)."""
    # without roulette: its continuation probability carries eta^2 (as Mitsuba's does), so
    # with roulette the missing 1/eta^2 changes which paths survive even in closed glass
    glass = dataclasses.replace(selftest_scene("cornell_glass", width=12), rr_depth=None)
    kw = dict(spp=16, strategy="mis", seed=7, threads=2)
    assert np.array_equal(render_mutant(glass, "none", **kw).mean, render_mutant(glass, "glass_no_eta_scale", **kw).mean)
    box = selftest_scene("cornell_box", width=8)
    kw = dict(spp=2048, seed=7, threads=2)
    for strategy, changed in (("mis", False), ("mixture", True)):
        a = render_mutant(box, "none", strategy=strategy, **kw).mean.sum()
        b = render_mutant(box, "pdf_off_by_pi", strategy=strategy, **kw).mean.sum()
        assert (abs(b / a - 1) > 0.05) == changed, (strategy, b / a)


def test_small_selftest_catches_three_mutants(cache, tmp_path):
    out = tmp_path / "selftest.json"
    md = tmp_path / "selftest.md"
    code = main(["selftest", "--mutants", "max_depth_off_by_one,emitter_weight_one", "--mutants",
                 "light_pdf_no_jacobian", "--spp", "256", "--spp-ladder", "64", "--width", "16", "--ref-spp", "1024",
                 "--tail-spp", "1024", "--threads", "2", "--cache", str(cache), "--json", str(out),
                 "--markdown", str(md)])
    assert code == 0
    data = strict_json(out.read_text())
    rows = {r["mutant"]: r for r in data["rows"]}
    assert list(rows) == ["max_depth_off_by_one", "emitter_weight_one", "light_pdf_no_jacobian"]
    for r in rows.values():
        assert r["caught"] and r["verdict"] == "fail" and r["smallest_spp_caught"] == 64
        assert [s["spp"] for s in r["ladder"]] == [64, 256]
        for key in ("caught_by_mitsuba_rule", "smallest_spp_caught_by_mitsuba_rule", "scene", "strategy"):
            assert key in r
        assert r["control_verdict"] == "pass"  # the unmutated tracer passes the same comparison
    assert rows["max_depth_off_by_one"]["reference"] == "closed form"
    assert rows["emitter_weight_one"]["relative_bias"] > 0.2 and rows["light_pdf_no_jacobian"]["relative_bias"] < -0.2
    assert data["caught"] == 3 and data["passed"]
    assert "| max_depth_off_by_one | furnace | mis | fail | yes | 64 |" in md.read_text()


def test_selftest_json_is_strict_with_undefined_numbers_as_null(cache, tmp_path):
    # at 2 spp the image mean is too far from normal to test: the verdict is undetermined and
    # the smallest bias it would catch is undefined (NaN), written as null
    out = tmp_path / "selftest.json"
    code = main(["selftest", "--mutants", "emitter_weight_one", "--spp", "2", "--spp-ladder", "2", "--width", "8",
                 "--ref-spp", "1024", "--tail-spp", "1024", "--no-controls", "--threads", "2", "--cache", str(cache),
                 "--json", str(out), "--quiet"])
    assert code == 1   # a mutant missed
    (row,) = strict_json(out.read_text())["rows"]
    assert row["verdict"] == "undetermined" and row["min_detectable_bias"] is None
    assert isinstance(row["relative_bias"], float)


def test_selftest_cli_bad_usage(capsys):
    assert main(["selftest", "--mutants", "nope"]) == 2
    assert "unknown mutant 'nope'" in capsys.readouterr().err
    assert main(["selftest", "--spp", "1"]) == 2
    assert main(["selftest", "--list"]) == 0
    assert "why this scene" in capsys.readouterr().out


@pytest.mark.slow
def test_full_selftest_at_the_gate_budget():
    """The whole catalogue at the gate's defaults (32x32, 4096 spp; references in the
    user's cache): the gate catches at least 90% and never fewer than Mitsuba's rule."""
    report = run_selftest()
    missed = [(r["mutant"], r["verdict"], r["relative_bias"]) for r in report.rows if not r["caught"]]
    assert report.passed, f"caught {report.n_caught}/{report.n}; missed {missed}"
    assert report.n_caught >= report.n_caught_by_mitsuba_rule


def test_correlation_level_catches_correlated_pixel_streams(cache):
    """The mutant whose pixels share one random stream keeps every mean right; the gate's
    correlation level must catch it (neighbour correlation ~0.1-0.2) while the unmutated
    tracer passes the same comparison with a correlation near 0 (1/sqrt(1984) = 0.022
    per channel at 32x32). Fixed seeds; under the null hypothesis the control fails with
    probability <= alpha = 0.01."""
    from benchmarks.gate.suite import compare_render
    from benchmarks.selftest.driver import scene_reference
    from reference_tracer.testing import mutants_build_id
    from benchmarks.tails import tail_reference

    scene = selftest_scene("cornell_box", width=32)
    ref = scene_reference("cornell_box", scene, ref_spp=1024, threads=2, cache=cache)
    results = {}
    for name in ("none", "correlated_pixel_streams"):
        def render(sc, *, _name=name, **kw):
            return render_mutant(sc, _name, **kw)

        tails = tail_reference(scene, strategy="mis", spp=1024, threads=2, cache=cache, render=render,
                               variant=f"{name}@{mutants_build_id()}")
        out = render_mutant(scene, name, spp=256, strategy="mis", seed=3, threads=2)
        results[name] = compare_render(out.mean, out.variance, 256, ref, alpha=0.01, tails=tails)
    control, mutant = results["none"], results["correlated_pixel_streams"]
    assert control.verdict == "pass" and np.all(np.abs(control.neighbour_correlation) < 0.1)
    assert mutant.verdict == "fail" and "correlation" in mutant.failed_levels
    assert np.all(mutant.neighbour_correlation > 0.05)
    assert "correlate at" in mutant.reason


def test_selftest_table_prints_brackets_as_text():
    """The table's cells are text: a bracketed part of a name stays, where rich would read it as a
    style tag and drop it."""
    import types

    from rich.console import Console

    from benchmarks.commands.selftest import selftest_table

    row = {"mutant": "light.pdf[twice]", "scene": "scene[v2]", "strategy": "mis", "verdict": "fail", "caught": True,
           "smallest_spp_caught": 64, "caught_by_mitsuba_rule": False, "smallest_spp_caught_by_mitsuba_rule": None,
           "relative_bias": 0.01, "relative_bias_se": 0.001, "control_verdict": "pass",
           "control_caught_by_mitsuba_rule": False}
    report = types.SimpleNamespace(spp=64, alpha=0.00125, rows=[row])
    console = Console(width=300, record=True)
    console.print(selftest_table(report))
    text = console.export_text()
    assert "light.pdf[twice]" in text and "scene[v2]" in text
