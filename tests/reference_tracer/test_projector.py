"""Mitsuba's ``projector`` emitter (:class:`reference_tracer.ProjectorLight`) and the ``spot``
emitter's projected ``texture`` (``SpotLight(texture=...)``).

* Agreement with Mitsuba (``benchmarks.gate.agreement``, 4096 spp, Mitsuba in 16 batches,
  as tests/reference_tracer/test_lights.py): a projector of a constant and of a bitmap (a PNG written here)
  onto a diffuse wall and floor, and a textured spot, under ``mis`` with the path integrator
  and under ``mis`` and ``light`` with the ``direct`` integrator.
* Delta-light samples (direction, what arrives, pmf) against the Python formulas, through
  the chi2 catalogue's check.
* Wavefront equals scalar bit for bit; bad input is a ValueError naming the field; import
  and translation round trips.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import reference_tracer as rt
from benchmarks.gate.agreement import agreement
from mitsuba_scenes import from_mitsuba, render_mitsuba, to_mitsuba, to_xml
from mitsuba_xml import diffuse_floor, path_integrator, scene_xml
from reference_tracer.render import BLIND_TO_DELTA_LIGHTS

SPP = 4096


@pytest.fixture(scope="module")
def mi():
    from mitsuba_scenes.variants import import_mitsuba

    return import_mitsuba()


def _png(path, seed=2, shape=(6, 9)):
    from PIL import Image

    img = (np.random.default_rng(seed).random((*shape, 3)) * 255).astype(np.uint8)
    Image.fromarray(img).save(path)
    return path


def _scene_xml(integrator: str, emitter: str) -> str:
    """A floor and a back wall lit by ``emitter`` alone."""
    return scene_xml(diffuse_floor() + """\
    <shape type="rectangle"><transform name="to_world"><scale value="3"/><translate y="1.5" z="-1.5"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.5, 0.6, 0.7"/></bsdf></shape>
    """ + emitter, integrator=integrator, fov=50, origin="0, 2, 5", target="0, 0.8, 0", width=24, height=18)


_PATH = path_integrator(3)
_DIRECT = '<integrator type="direct"/>'
_EMITTERS = {
    "projector_constant": """<emitter type="projector"><rgb name="irradiance" value="2, 1.5, 1"/>
        <float name="fov" value="40"/><float name="scale" value="1.5"/>
        <transform name="to_world"><lookat origin="1.5, 2.5, 2" target="-0.3, 0.5, -1" up="0, 1, 0"/></transform>
        </emitter>""",
    "projector_bitmap": """<emitter type="projector"><texture type="bitmap" name="irradiance">
        <string name="filename" value="tex.png"/></texture><float name="fov" value="35"/>
        <string name="fov_axis" value="y"/>
        <transform name="to_world"><lookat origin="-1, 2, 2.5" target="0.2, 0.6, -1" up="0, 1, 0"/></transform>
        </emitter>""",
    "spot_texture": """<emitter type="spot"><rgb name="intensity" value="20, 15, 10"/>
        <float name="cutoff_angle" value="35"/><float name="beam_width" value="25"/>
        <texture type="bitmap" name="texture"><string name="filename" value="tex.png"/>
            <string name="filter_type" value="nearest"/></texture>
        <transform name="to_world"><lookat origin="1, 3, 2" target="-0.2, 0.4, -1" up="0.3, 1, 0"/></transform>
        </emitter>""",
}


@pytest.mark.parametrize("integrator", ["path", "direct"])
@pytest.mark.parametrize("name", sorted(_EMITTERS))
def test_agrees_with_mitsuba(tmp_path, mi, name, integrator):
    _png(tmp_path / "tex.png")
    xml = tmp_path / "scene.xml"
    xml.write_text(_scene_xml(_PATH if integrator == "path" else _DIRECT, _EMITTERS[name]))
    scene = from_mitsuba(xml)
    assert len(scene.delta_lights) == 1
    mit = render_mitsuba(xml, spp=SPP, seed=1, batches=16, threads=2)
    assert mit.mean.max() > 0
    # the path integrator's `light` sees direct light only (biased on purpose): mis alone there
    for strategy in ("mis", "light") if integrator == "direct" else ("mis",):
        ours = rt.render(scene, spp=SPP, strategy=strategy, seed=1, threads=2)
        a = agreement(ours, mit, pixel_filter=scene.camera.filter)
        assert a.agrees, (strategy, a.describe())


# --------------------------------------------------------------------------- model and core
def _lights():
    tex = rt.Bitmap(np.random.default_rng(3).random((4, 6, 3)) + 0.1)
    return [rt.ProjectorLight((0.5, 2.5, 2.0), (-0.2, -0.6, -0.8), tex, fov=50, scale=2.0),
            rt.ProjectorLight((-1.0, 2.0, 1.0), (0.3, -1.0, -0.2), (1.0, 2.0, 3.0), fov=60, up=(0, 0, 1)),
            rt.SpotLight((1.0, 3.0, 1.0), (-0.3, -1.0, -0.3), 20, cutoff_angle=40, beam_width=30,
                         texture=rt.Checkerboard(1.0, 0.2, to_uv=np.diag([5.0, 5.0, 1.0])))]


def _scene(lights, **kw):
    floor = rt.Quad((-3, 0, -3), (0, 0, 6), (6, 0, 0), rt.Lambertian((0.7, 0.6, 0.5)))
    wall = rt.Quad((-3, 0, -1.5), (6, 0, 0), (0, 3, 0), rt.Lambertian(0.5))
    ball = rt.Sphere((0.2, 0.5, 0.0), 0.5, rt.Plastic((0.3, 0.5, 0.7)))
    return rt.Scene(rt.Camera((0, 2, 5), (0, 0.8, 0), (0, 1, 0), 50, 20, 16), [floor, wall, ball],
                    lights=lights, **kw)


@pytest.mark.parametrize("strategy", ["mis", "light"])
def test_wavefront_equals_scalar(strategy):
    scene = _scene(_lights(), max_depth=5, rr_depth=2)
    a, b = (rt.render(scene, spp=6, strategy=strategy, seed=7, threads=2, moments=True, integrator=i)
            for i in ("scalar", "wavefront"))
    assert np.array_equal(a.mean, b.mean) and np.array_equal(a.variance, b.variance) and a.rays == b.rays
    assert a.nonfinite_samples == 0 and a.mean.max() > 0


@pytest.mark.parametrize("strategy", BLIND_TO_DELTA_LIGHTS)
def test_blind_strategies_are_refused(strategy):
    with pytest.raises(ValueError, match="ProjectorLight"):
        rt.render(_scene(_lights()[:1]), spp=1, strategy=strategy)


def test_delta_samples_are_the_formulas():
    """Each light's samples from a reference point: the direction toward it, what arrives
    (ProjectorLight.arriving / SpotLight.arriving, independent numpy formulas) and the pmf of
    its selection by power (the chi2 catalogue's check)."""
    from benchmarks.chi2 import catalogue
    from benchmarks.chi2.runner import run_routine

    routines = [r for r in catalogue.ROUTINES if r.name == "light.scene_projector"]
    assert routines
    result = run_routine(routines[0], n=20000, seed=3)
    bad = {k: v for k, v in result.checks.items() if not v["ok"]}
    assert not bad, bad


def test_projector_power_and_uv():
    p = rt.ProjectorLight((0, 0, 0), (0, 0, 1), rt.Bitmap(np.ones((2, 4))), fov=90)
    assert p.aspect == 2.0 and p.image_area() == pytest.approx(2.0)
    assert p.power() == pytest.approx(math.pi * 2.0)
    uv, lit = p.uv([[0.0, 0.0, 1.0], [0.99, 0.0, 1.0], [0.0, 0.51, 1.0], [0.0, 0.0, -1.0]])
    assert lit.tolist() == [True, True, False, False] and uv[0].tolist() == [0.5, 0.5]
    # fov along y of a wide image: x_fov from Mitsuba's parse_fov
    q = rt.ProjectorLight((0, 0, 0), (0, 0, 1), rt.Bitmap(np.ones((2, 4))), fov=60, fov_axis="y")
    assert q.x_fov == pytest.approx(math.degrees(2 * math.atan(math.tan(math.radians(30)) * 2)))
    # Mitsuba's default: a 50 mm focal length
    assert rt.ProjectorLight((0, 0, 0), (0, 0, 1)).x_fov == pytest.approx(34.0221, abs=1e-3)   # square: diagonal 46.8


@pytest.mark.parametrize("make,needle", [
    (lambda: rt.ProjectorLight((0, 0, 0), (0, 0, 1), fov=-10), "fov"),
    (lambda: rt.ProjectorLight((0, 0, 0), (0, 0, 1), fov=float("nan")), "fov"),
    (lambda: rt.ProjectorLight((0, 0, 0), (0, 0, 1), fov=180), "fov"),
    (lambda: rt.ProjectorLight((0, 0, 0), (0, 0, 1), scale=-1), "scale"),
    (lambda: rt.ProjectorLight((0, 0, 0), (0, 0, 1), scale=float("nan")), "scale"),
    (lambda: rt.ProjectorLight((0, 0, 0), (0, 0, 1), fov_axis="z"), "fov_axis"),
    (lambda: rt.ProjectorLight((0, 0, 0), (0, 1, 0), fov=40), "up"),
    (lambda: rt.ProjectorLight((0, 0, 0), (0, 0, 1), "tex.png"), "irradiance"),
    (lambda: rt.ProjectorLight((0, 0, 0), (0, 0, 1), -1.0), "irradiance"),
    (lambda: rt.ProjectorLight((0, 0, 0), (0, 0, 1), rt.Bitmap(-np.ones((2, 2)))), "irradiance"),
    (lambda: rt.SpotLight((0, 0, 0), (0, 0, 1), texture=0.5), "texture"),
    (lambda: rt.SpotLight((0, 0, 0), (0, 0, 1), texture={"type": "bitmap"}), "texture"),
    (lambda: rt.SpotLight((0, 0, 0), (0, 1, 0), texture=rt.Checkerboard()), "up"),
])
def test_bad_input_is_refused(make, needle):
    with pytest.raises(ValueError, match=needle):
        make()


def test_a_missing_texture_file_is_named():
    # Bitmap's own contract (image_files.read_image): a file that cannot be opened is the OS's
    # error; the importer turns it into its ValueError with the place (test below)
    with pytest.raises(OSError, match="missing.png"):
        rt.ProjectorLight((0, 0, 0), (0, 0, 1), rt.Bitmap("/nonexistent/missing.png"))


def test_untextured_spot_keeps_its_description():
    s = rt.SpotLight((0, 3, 0), (0, -1, 0), 5, cutoff_angle=30)   # up parallel: fine without a texture
    assert set(s.describe()) == {"type", "position", "direction", "intensity", "cutoff_angle", "beam_width"}


# --------------------------------------------------------------------------- import and translation
def test_import_refuses_a_constant_spot_texture_and_a_missing_file(tmp_path):
    xml = tmp_path / "s.xml"
    for emitter, needle in [
        ('<emitter type="spot"><rgb name="texture" value="0.5"/></emitter>', "spot texture"),
        ('<emitter type="projector"><texture type="bitmap" name="irradiance">'
         '<string name="filename" value="nope.png"/></texture></emitter>', "nope.png"),
        ('<emitter type="projector"><float name="fov" value="30"/><string name="focal_length" value="20mm"/>'
         '</emitter>', "both fov and focal_length"),
    ]:
        xml.write_text(_scene_xml(_DIRECT, emitter))
        with pytest.raises(ValueError, match=needle):
            from_mitsuba(xml)


def test_import_reads_the_projector(tmp_path):
    _png(tmp_path / "tex.png", shape=(4, 8))
    xml = tmp_path / "s.xml"
    xml.write_text(_scene_xml(_DIRECT, """<emitter type="projector">
        <texture type="bitmap" name="irradiance"><string name="filename" value="tex.png"/></texture>
        <string name="focal_length" value="35mm"/><float name="scale" value="3"/>
        <transform name="to_world"><lookat origin="0, 2, 2" target="0, 0, 0" up="0, 1, 0"/><scale value="2"/>
        </transform></emitter>"""))
    (p,) = from_mitsuba(xml).lights
    assert isinstance(p, rt.ProjectorLight) and p.aspect == 2.0
    assert p.scale == pytest.approx(6.0)   # the uniform scale of to_world folded in
    np.testing.assert_allclose(p.direction, np.array([0, -1, -1]) / math.sqrt(2), atol=1e-6)
    np.testing.assert_allclose(p.position, (0, 4, 4), atol=1e-6)   # the scale after look_at moves it too


def test_round_trips_through_xml_and_dict(tmp_path):
    lights = _lights()   # the dict's bitmaps are files (the importer reads bitmaps from files)
    lights[0] = dataclasses.replace(lights[0], irradiance=rt.Bitmap(_png(tmp_path / "t.png")))
    scene = _scene(lights)
    back = from_mitsuba(to_xml(scene, tmp_path / "s.xml"))
    assert [type(x) for x in back.lights] == [type(x) for x in scene.lights]
    for a, b in zip(scene.lights, back.lights):
        pts = np.random.default_rng(0).uniform(-2, 2, (200, 3)) * (1, 0, 1)
        np.testing.assert_allclose(b.arriving(pts), a.arriving(pts), rtol=1e-5, atol=1e-6)
    d = to_mitsuba(scene)
    assert sorted(v["type"] for k, v in d.items() if k.startswith("light_")) == ["projector", "projector", "spot"]
    again = from_mitsuba(d)
    for a, b in zip(scene.lights, again.lights):
        pts = np.random.default_rng(1).uniform(-2, 2, (200, 3)) * (1, 0, 1)
        np.testing.assert_allclose(b.arriving(pts), a.arriving(pts), rtol=1e-5, atol=1e-6)


def test_translated_scene_agrees_with_mitsuba():
    scene = dataclasses.replace(_scene(_lights()), max_depth=3)
    ours = rt.render(scene, spp=SPP, strategy="mis", seed=1, threads=2)
    mit = render_mitsuba(scene, spp=SPP, seed=1, batches=16, threads=2)
    a = agreement(ours, mit)
    assert a.agrees, a.describe()
