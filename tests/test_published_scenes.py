"""Scenes other people wrote and published (tests/fixtures/published, SOURCES.md there),
imported unmodified and judged by Mitsuba itself: ``mi.load_file`` of the same file against
our tracer through ``from_mitsuba``, at a small film size set through the files' own
parameters.

The statistic (``benchmarks.gate.agreement``): per pixel and channel ``z = (ours - Mitsuba) /
sqrt(var_ours / N + var_mitsuba / N)`` and, per channel, the same for the image's sum, with the
variances of filtered pixels and of their sums computed from the samples. Both renders are
4096 spp (Mitsuba in 16 batches of 256 for its variance). The scene agrees when every channel's
global |z| <= 4 (3 tests at alpha 6e-5 each under the normal approximation) and at most 1% of
the pixel values have |z| > 4 (about 0.006% expected of agreeing images; filtered neighbours
are correlated, so the share is noisy, hence the margin).
"""
from __future__ import annotations

from pathlib import Path

import pytest

import reference_tracer as rt
from benchmarks.gate.agreement import agreement
from mitsuba_scenes import from_mitsuba, render_mitsuba

PUBLISHED = Path(__file__).resolve().parent / "fixtures" / "published"
SPP = 4096

SCENES = {
    "bitterli/cornell-box": {"resx": "32", "resy": "32"},
    "bitterli/veach-mis": {"resx": "48", "resy": "27"},
}


@pytest.mark.parametrize("name", sorted(SCENES))
def test_published_scene_imports_unmodified_and_agrees_with_mitsuba(name):
    path = PUBLISHED / name / "scene_v3.xml"
    params = SCENES[name]
    scene = from_mitsuba(path, params=params)
    ours = rt.render(scene, spp=SPP, strategy="mis", seed=1, threads=2)
    mit = render_mitsuba(path, spp=SPP, seed=1, batches=16, params=params, threads=2)
    assert ours.mean.shape == mit.mean.shape == (int(params["resy"]), int(params["resx"]), 3)
    a = agreement(ours, mit, pixel_filter=scene.camera.filter)
    assert a.agrees, a.describe()


def test_the_agreement_test_sees_a_wrong_import():
    """The same statistic on veach-mis with our plates' roughness doubled: it fails."""
    import dataclasses

    path = PUBLISHED / "bitterli/veach-mis/scene_v3.xml"
    params = SCENES["bitterli/veach-mis"]
    scene = from_mitsuba(path, params=params)
    shapes = [dataclasses.replace(s, material=dataclasses.replace(s.material, alpha=2 * s.material.alpha))
              if isinstance(s.material, rt.RoughConductor) else s for s in scene.shapes]
    wrong = dataclasses.replace(scene, shapes=shapes)
    ours = rt.render(wrong, spp=SPP, strategy="mis", seed=1, threads=2)
    mit = render_mitsuba(path, spp=SPP, seed=1, batches=16, params=params, threads=2)
    a = agreement(ours, mit, pixel_filter=scene.camera.filter)
    assert not a.agrees, a.describe()
