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

Scenes: Bitterli's Cornell Box and Veach MIS, and Mitsuba's own Cornell box (``cbox-rgb.xml``
of mitsuba-data, the scene Mitsuba's tests and docs use): OBJ meshes, one of them (the red
wall, a slightly warped quad without ``vn``) shaded with the vertex normals Mitsuba computes.
"""
from __future__ import annotations


import numpy as np
import pytest

import reference_tracer as rt
from benchmarks.gate.agreement import agreement
from mitsuba_scenes import from_mitsuba, render_mitsuba
from repo_paths import FIXTURES

PUBLISHED = FIXTURES / "published"
SPP = 4096

# folder: (scene file, its $name parameters, the film size they give (height, width))
SCENES = {
    "bitterli/cornell-box": ("scene_v3.xml", {"resx": "32", "resy": "32"}, (32, 32)),
    "bitterli/veach-mis": ("scene_v3.xml", {"resx": "48", "resy": "27"}, (27, 48)),
    "mitsuba/cbox": ("cbox-rgb.xml", {"res": "32"}, (32, 32)),
}


@pytest.mark.parametrize("name", sorted(SCENES))
def test_published_scene_imports_unmodified_and_agrees_with_mitsuba(name):
    file, params, size = SCENES[name]
    path = PUBLISHED / name / file
    scene = from_mitsuba(path, params=params)
    ours = rt.render(scene, spp=SPP, strategy="mis", seed=1, threads=2)
    mit = render_mitsuba(path, spp=SPP, seed=1, batches=16, params=params, threads=2)
    assert ours.mean.shape == mit.mean.shape == (*size, 3)
    a = agreement(ours, mit, pixel_filter=scene.camera.filter)
    assert a.agrees, a.describe()


def test_mitsuba_cbox_red_wall_is_shaded_with_computed_normals():
    """The red wall's OBJ has no ``vn``: Mitsuba computes vertex normals (the quad is warped,
    so they differ from its triangles' normals) and the import keeps them; the other meshes'
    normals equal their faces' and stay flat."""
    scene = from_mitsuba(PUBLISHED / "mitsuba/cbox/cbox-rgb.xml", params={"res": "8"})
    smooth = [s for s in scene.shapes if s.normals is not None]
    assert len(smooth) == 1 and len(scene.shapes) == 8
    red = smooth[0]
    assert red.material.albedo == pytest.approx((0.570068, 0.0430135, 0.0443706))
    fn = np.cross(*(red.world_triangles()[:, k] - red.world_triangles()[:, 0] for k in (1, 2)))
    fn /= np.linalg.norm(fn, axis=1, keepdims=True)
    tilt = np.degrees(np.arccos(np.clip(np.einsum("fkc,fc->fk", red.world_triangle_normals(), fn), -1, 1)))
    assert 0.05 < tilt.max() < 2.0


def test_the_agreement_test_sees_a_wrong_import():
    """The same statistic on veach-mis with our plates' roughness doubled: it fails."""
    import dataclasses

    path = PUBLISHED / "bitterli/veach-mis/scene_v3.xml"
    params = SCENES["bitterli/veach-mis"][1]
    scene = from_mitsuba(path, params=params)
    shapes = [dataclasses.replace(s, material=dataclasses.replace(s.material, alpha=2 * s.material.alpha))
              if isinstance(s.material, rt.RoughConductor) else s for s in scene.shapes]
    wrong = dataclasses.replace(scene, shapes=shapes)
    ours = rt.render(wrong, spp=SPP, strategy="mis", seed=1, threads=2)
    mit = render_mitsuba(path, spp=SPP, seed=1, batches=16, params=params, threads=2)
    a = agreement(ours, mit, pixel_filter=scene.camera.filter)
    assert not a.agrees, a.describe()


def _veach_docs_copy(tmp_path):
    """Mitsuba's documentation scene of Veach's comparison, copied with only its film's size
    changed (768x512 -> 48x32, in ``include/veach_mis.xml``, the file that declares it)."""
    import shutil

    root = tmp_path / "mitsuba"
    shutil.copytree(PUBLISHED / "mitsuba" / "docs", root / "docs")
    shutil.copytree(PUBLISHED / "mitsuba" / "common", root / "common")
    include = root / "docs" / "scenes" / "include" / "veach_mis.xml"
    text = include.read_text()
    for old, new in (('name="width" value="768"', 'name="width" value="48"'),
                     ('name="height" value="512"', 'name="height" value="32"')):
        assert text.count(old) == 1
        text = text.replace(old, new)
    include.write_text(text)
    return root / "docs" / "scenes"


@pytest.mark.parametrize("file,counts,strategy", [("integrator_direct_both.xml", (1, 1), "mis"),
                                                  ("integrator_direct_bsdf.xml", (0, 1), "cosine"),
                                                  ("integrator_direct_lum.xml", (1, 0), "light")])
def test_mitsubas_veach_scene_imports_unmodified_and_agrees(tmp_path, file, counts, strategy):
    """The Veach MIS scene of Mitsuba's documentation (its ``direct`` integrator with emitter
    and BSDF samples, roughplastic plates, spheres lights, OBJ meshes, Gaussian film), each of
    its three files, against ``mi.load_file`` of the same file."""
    path = _veach_docs_copy(tmp_path) / file
    scene = from_mitsuba(path)
    assert scene.direct == rt.Direct(*counts) and scene.camera.filter == rt.Filter("gaussian")
    assert sum(isinstance(s.material, rt.RoughPlastic) for s in scene.shapes) == 4
    ours = rt.render(scene, spp=SPP, strategy=strategy, seed=1, threads=2)
    mit = render_mitsuba(path, spp=SPP, seed=1, batches=16, threads=2)
    assert ours.mean.shape == mit.mean.shape == (32, 48, 3)
    a = agreement(ours, mit, pixel_filter=scene.camera.filter)
    assert a.agrees, a.describe()
