"""Mitsuba's ``thindielectric``: a pane whose reflectance sums every internal round trip,
2R / (1 + R), and which passes the rest straight through. Checked against the closed form
(the pane seen against a uniform sky and a black ground), and against ``mi.load_file`` of
the same XML with the published scenes' agreement screen (``benchmarks.gate.agreement``:
every |global z| <= 4 and at most 1% of pixel values with |z| > 4; about 6e-5 per channel
under the normal approximation)."""
from __future__ import annotations

import numpy as np
import pytest

import reference_tracer as rt
from benchmarks.gate.agreement import agreement
from benchmarks.optics import fresnel_dielectric
from mitsuba_scenes import from_mitsuba, render_mitsuba, to_mitsuba
from mitsuba_xml import diffuse_floor, path_integrator, scene_xml


@pytest.mark.parametrize("side", [1.0, -1.0])
def test_pane_transmits_one_minus_its_reflectance_from_either_side(side):
    # A camera looks through a pane (normal along the view, either face toward it) at an
    # emitter behind it; the sky behind the camera is black. Every sample is the emitter
    # (transmitted) or black (reflected): the pixel mean is (1 - R') L, R' = 2R / (1 + R).
    eta = 1.5
    pane = rt.Quad((-5, -5, 0), (10, 0, 0), (0, 10, 0), rt.ThinDielectric(eta))
    if side < 0:
        pane = rt.Quad((-5, -5, 0), (0, 10, 0), (10, 0, 0), rt.ThinDielectric(eta))
    light = rt.Quad((-50, -50, -3), (100, 0, 0), (0, 100, 0), rt.DiffuseLight((2.0, 2.0, 2.0)))
    cam = rt.Camera(lookfrom=(0, 0, 4), lookat=(0, 0, 0), vup=(0, 1, 0), vfov=1.0, width=2, height=2)
    out = rt.render(rt.Scene(cam, [pane, light], max_depth=4), spp=20000, strategy="mis", seed=3, threads=1)
    r = fresnel_dielectric(1.0, eta)
    expected = 2.0 * (1.0 - 2.0 * r / (1.0 + r))
    se = np.sqrt(out.variance / out.spp).max()
    assert abs(out.mean.mean() - expected) < 5 * se + 1e-9, (out.mean.mean(), expected, se)


def test_bad_index_is_refused():
    for bad in (0.0, -1.0, float("nan"), "glass"):
        with pytest.raises(ValueError, match="ThinDielectric.ior"):
            rt.ThinDielectric(bad)


def test_translation_and_import_round_trip(tmp_path):
    assert to_mitsuba(rt.Scene(rt.Camera(lookfrom=(0, 0, 1), lookat=(0, 0, 0), width=4, height=4),
                               [rt.Sphere((0, 0, -1), 0.5, rt.ThinDielectric(1.33))]))["shape_000_sphere"]["bsdf"] == {
        "type": "thindielectric", "int_ior": pytest.approx(1.33), "ext_ior": 1.0}
    xml = tmp_path / "s.xml"
    xml.write_text('<scene version="3.0.0"><shape type="sphere"><bsdf type="thindielectric">'
                   '<string name="int_ior" value="water"/><float name="ext_ior" value="1.0"/></bsdf></shape>'
                   '<sensor type="perspective"><film type="hdrfilm"><integer name="width" value="4"/>'
                   '<integer name="height" value="4"/></film></sensor></scene>')
    (m,) = {s.material for s in from_mitsuba(xml).shapes}
    assert isinstance(m, rt.ThinDielectric) and m.ior == pytest.approx(1.333)
    xml.write_text(xml.read_text().replace('<float name="ext_ior" value="1.0"/>',
                                           '<rgb name="specular_transmittance" value="0.5"/>'))
    with pytest.raises(ValueError, match="thindielectric specular_transmittance"):
        from_mitsuba(xml)


def _panes_xml(tmp_path):
    """Tilted panes (seen from both faces) between the camera, a diffuse floor and a light."""
    xml = tmp_path / "scene.xml"
    xml.write_text(scene_xml(diffuse_floor() + """
    <shape type="rectangle"><transform name="to_world"><rotate y="1" angle="35"/><translate x="-0.6" y="0.8"/>
        </transform><bsdf type="thindielectric"/></shape>
    <shape type="rectangle"><transform name="to_world"><rotate y="1" angle="160"/><translate x="0.8" y="0.8"/>
        </transform><bsdf type="thindielectric"><float name="int_ior" value="2.0"/></bsdf></shape>
    <shape type="sphere"><point name="center" value="0, 0.5, -1"/><float name="radius" value="0.5"/>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.5, 0.8"/></bsdf></shape>
    <shape type="rectangle"><transform name="to_world"><rotate x="1" angle="90"/><translate y="3.5"/></transform>
        <emitter type="area"><rgb name="radiance" value="6"/></emitter></shape>
    <emitter type="constant"><rgb name="radiance" value="0.2"/></emitter>""",
        integrator=path_integrator(6), fov=45, origin="0, 2, 5", target="0, 0.7, 0", width=40, height=30))
    return xml


def test_panes_agree_with_mitsuba(tmp_path):
    xml = _panes_xml(tmp_path)
    scene = from_mitsuba(xml)
    ours = rt.render(scene, spp=4096, strategy="mis", seed=1, threads=2)
    mit = render_mitsuba(xml, spp=4096, seed=1, batches=16, threads=2)
    a = agreement(ours, mit, pixel_filter=scene.camera.filter)
    assert a.agrees, a.describe()


@pytest.mark.parametrize("strategy", ["uniform", "cosine", "mis", "light"])
def test_wavefront_equals_scalar_with_panes(tmp_path, strategy):
    scene = from_mitsuba(_panes_xml(tmp_path))
    scene = scene.with_camera_size(16, 12)
    a, b = (rt.render(scene, spp=8, strategy=strategy, seed=7, threads=2, integrator=i)
            for i in ("scalar", "wavefront"))
    assert np.array_equal(a.mean, b.mean) and np.array_equal(a.variance, b.variance)
