"""Mitsuba's ``direct`` integrator: direct light from light samples and BSDF samples, each
kind averaged over its count and weighted by the power heuristic on densities scaled by the
kind's share of the samples.

Agreement with Mitsuba's own ``direct``: per channel, the whole image's z of the difference
(|z| <= 4: about 6e-5 per channel under the normal approximation) and the share of pixel
values with |z| > 4 (<= 1%; about 0.006% expected of agreeing images).
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import reference_tracer as rt
from benchmarks.gate.agreement import agreement
from mitsuba_scenes import from_mitsuba, get_scene, render_mitsuba, to_mitsuba, to_xml
from mitsuba_xml import scene_xml

SPP = 4096


def _glossy(direct, **size):
    scene = get_scene("glossy_plates", **(size or dict(width=48, height=32)))
    return dataclasses.replace(scene, direct=direct)


def test_direct_is_validated():
    with pytest.raises(ValueError, match="at least one"):
        rt.Direct(0, 0)
    with pytest.raises(ValueError, match="emitter_samples"):
        rt.Direct(-1, 1)
    with pytest.raises(ValueError, match="bsdf_samples"):
        rt.Direct(1, 1.5)
    with pytest.raises(ValueError, match="bsdf_samples"):
        rt.Direct(1, True)
    with pytest.raises(ValueError, match="Scene.direct"):
        dataclasses.replace(get_scene("cornell_box", width=4, height=4), direct=(1, 1))


def test_strategies_pick_the_techniques():
    d = rt.Direct(2, 3)
    assert d.counts("mis") == (2, 3)
    assert d.counts("light") == (2, 0) and d.counts("cosine") == (0, 3)
    assert rt.Direct(0, 4).counts("light") == (4, 0)  # no light samples given: as many as BSDF ones
    assert rt.Direct(5, 0).counts("uniform") == (0, 5)


@pytest.mark.parametrize("strategy", ["mis", "cosine"])
def test_one_sample_of_each_is_the_path_integrator_at_depth_two(strategy):
    """Direct(1, 1) draws the same numbers as ``path`` with max_depth 2 and weighs them the
    same (the shares 1/2 cancel in the power heuristic): the images agree bit for bit."""
    scene = _glossy(None, width=24, height=16)
    a = rt.render(dataclasses.replace(scene, direct=rt.Direct(1, 1)), spp=64, strategy=strategy, seed=3)
    b = rt.render(dataclasses.replace(scene, max_depth=2), spp=64, strategy=strategy, seed=3)
    assert np.array_equal(a.mean, b.mean) and np.array_equal(a.variance, b.variance)


def test_more_samples_per_ray_cut_the_variance():
    """Four light and four BSDF samples per camera ray: about a quarter of the variance per
    camera sample of one of each, in the typical pixel (the median ratio; pixels where the
    camera's own jitter across an emitter's edge dominates keep theirs). Measured 0.26."""
    one = rt.render(_glossy(rt.Direct(1, 1)), spp=256, strategy="mis", seed=1)
    four = rt.render(_glossy(rt.Direct(4, 4)), spp=256, strategy="mis", seed=1)
    lit = one.variance > 0
    assert 0.15 < np.median(four.variance[lit] / one.variance[lit]) < 0.4


@pytest.mark.parametrize("counts,strategy", [((1, 0), "light"), ((0, 1), "cosine"), ((1, 1), "mis"),
                                             ((2, 3), "mis")])
def test_agrees_with_mitsubas_direct(counts, strategy):
    """Mitsuba renders the scene with ``direct`` and the counts our strategy takes."""
    ne, nb = rt.Direct(*counts).counts(strategy)
    assert (ne, nb) == counts
    scene = _glossy(rt.Direct(*counts))
    assert to_mitsuba(scene)["integrator"] == {"type": "direct", "emitter_samples": ne, "bsdf_samples": nb,
                                              "hide_emitters": False}
    ours = rt.render(scene, spp=SPP, strategy=strategy, seed=1, threads=2)
    mit = render_mitsuba(scene, spp=SPP, seed=1, batches=16, threads=2)
    a = agreement(ours, mit)
    assert a.agrees, a.describe()


def test_the_agreement_test_sees_missing_weights():
    """The estimator of a Direct(1, 1) that forgets the MIS weights counts the direct light
    twice: built from our light-only and BSDF-only images (less the emission seen directly,
    which it counts once), it disagrees with Mitsuba's Direct(1, 1)."""
    scene = _glossy(rt.Direct(1, 1))
    light = rt.render(scene, spp=SPP, strategy="light", seed=1, threads=2)
    bsdf = rt.render(scene, spp=SPP, strategy="cosine", seed=2, threads=2)
    seen = rt.render(dataclasses.replace(scene, direct=None, max_depth=1), spp=SPP, strategy="mis", seed=3)
    wrong = dataclasses.replace(light, mean=light.mean + bsdf.mean - seen.mean,
                                variance=light.variance + bsdf.variance + seen.variance)
    mit = render_mitsuba(scene, spp=SPP, seed=1, batches=16, threads=2)
    a = agreement(wrong, mit)
    assert max(abs(g) for g in a.global_z) > 4.0 and a.share > 0.01, a.describe()


def _xml(tmp_path, integrator: str) -> str:
    path = tmp_path / "s.xml"
    light = '<shape type="sphere"><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>'
    path.write_text(scene_xml(light, integrator=integrator, width=8, height=8))
    return str(path)


@pytest.mark.parametrize("body,expected", [
    ("", rt.Direct(1, 1)),
    ('<integer name="emitter_samples" value="0"/><integer name="bsdf_samples" value="1"/>', rt.Direct(0, 1)),
    ('<integer name="shading_samples" value="4"/>', rt.Direct(4, 4)),
    ('<integer name="shading_samples" value="4"/><integer name="bsdf_samples" value="2"/>', rt.Direct(4, 2)),
])
def test_importer_reads_direct(tmp_path, body, expected):
    scene = from_mitsuba(_xml(tmp_path, f'<integrator type="direct">{body}</integrator>'))
    assert scene.direct == expected


@pytest.mark.parametrize("body,message", [
    ('<boolean name="hide_emitters" value="true"/>', "direct hide_emitters=true"),
    ('<integer name="emitter_samples" value="0"/><integer name="bsdf_samples" value="0"/>', "at least one"),
    ('<integer name="emitter_samples" value="5000"/>', "4096"),
    ('<float name="bsdf_samples" value="1.5"/>', "whole numbers"),
    ('<integer name="max_depth" value="3"/>', "max_depth"),
])
def test_importer_refuses_what_direct_cannot_do(tmp_path, body, message):
    with pytest.raises(ValueError, match=message) as e:
        from_mitsuba(_xml(tmp_path, f'<integrator type="direct">{body}</integrator>'))
    assert "s.xml (line" in str(e.value)


def test_direct_round_trips_through_xml(tmp_path):
    scene = _glossy(rt.Direct(3, 2), width=8, height=8)
    back = from_mitsuba(to_xml(scene, tmp_path / "g.xml"))
    assert back.direct == rt.Direct(3, 2)


def test_a_run_shows_veachs_comparison_ours_beside_mitsubas(tmp_path, tmp_path_factory):
    """A sweep of a scene with ``direct``: Mitsuba's curves are its three techniques, each ours
    is compared with the one of the same counts, and the report's first screen after the
    headline shows the six images at equal spp and their error curves."""
    from benchmarks.sweep import Group, make_jobs, run_sweep
    from mitsuba_scenes.scene_files import clear_registry, register_scene_file
    from reports import build_report

    from harness_util import cache_root

    xml = to_xml(_glossy(rt.Direct(1, 1), width=16, height=12), tmp_path / "glossy_direct.xml")
    entry = register_scene_file(xml)
    try:
        jobs = make_jobs([entry.name], strategies=["cosine", "light", "mis"], spps=[1], seeds=1, width=16,
                         height=12)
        assert [(j.renderer, j.strategy) for j in jobs] == [
            ("ours", "cosine"), ("ours", "light"), ("ours", "mis"),
            ("mitsuba", "direct_bsdf"), ("mitsuba", "direct_light"), ("mitsuba", "direct_mis")]
        g = Group(scenes=(entry.name,), strategies=("cosine", "light", "mis"), spps=(1, 4, 16, 64), seeds=2,
                  width=16, height=12, reference_spp=1024)
        out = tmp_path / "store"
        result = run_sweep([g], out=out, progress=False, cache=cache_root(tmp_path_factory), threads=2)
        assert not result.failed and result.done == 4 * 2 * 6
        rows = {(r["renderer"], r["strategy"]): r for r in result.rows}
        # ours is compared with Mitsuba's technique of the same counts (its efficiency ratio uses it)
        for ours, mits in (("cosine", "direct_bsdf"), ("light", "direct_light"), ("mis", "direct_mis")):
            a, b = rows[("ours", ours)], rows[("mitsuba", mits)]
            assert a["efficiency_vs_mitsuba"] == pytest.approx(a["efficiency"] / b["efficiency"])
        build_report(out)
        page = (out / "index.html").read_text()
        card = page[page.index('class="card direct"'):]
        card = card[:card.index("</section>")]
        assert card.count('data-kind="image"') == 6 and 'data-plot="direct"' in card
        for label in ("BSDF sampling", "light sampling", "MIS", "16 spp"):
            assert label in card
        assert page.index('class="card direct"') < page.index('class="card scene"')
    finally:
        clear_registry()
