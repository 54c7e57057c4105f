"""Mitsuba's ``mask`` BSDF (opacity): ``rt.Mask`` around a material, judged by Mitsuba.

- **Renders** of one small XML scene, imported with ``from_mitsuba`` and rendered by both
  (``benchmarks.gate.agreement``, as ``tests/reference_tracer/test_thin_dielectric.py``: every ``|global z|
  <= 4`` and at most 1% of pixel values with ``|z| > 4``; about 2e-4 false alarms a render
  under the normal approximation, seeds fixed). Four masked planes over a diffuse floor lit
  by an area light and a constant emitter: a constant opacity, a checkerboard opacity
  (Mitsuba's ``eval_1``: colour means, cells swapped against its ``eval``), a bitmap opacity
  (an RGB PNG generated here: its luminance) around a ``twosided`` diffuse seen from the
  back, and a one-sided diffuse seen from its back (black, the null lobe passing). Under
  ``mis`` and ``cosine``; with ``max_depth`` 2, where the pass through a mask is the path's
  one bounce (the floor behind it black, the sky seen); under Mitsuba's ``direct``.
- **Wavefront equals scalar** bit for bit on the scene under every strategy.
- **Bad input**: refused with a ``ValueError`` naming it (the Python API refuses an opacity
  outside [0, 1] unless ``clip=True``; the importer clips, as Mitsuba's ``eval_opacity``).
- **Round trips**: the translation to Mitsuba (dict and XML) and back through the importer.
"""
from __future__ import annotations

import numpy as np
import pytest

import reference_tracer as rt
from benchmarks.gate.agreement import agreement
from mitsuba_scenes import from_mitsuba, render_mitsuba, to_mitsuba, to_xml
from mitsuba_xml import diffuse_floor, path_integrator, scene_xml

SPP = 4096


def _png(path, rng_seed=46):
    from PIL import Image

    px = np.random.default_rng(rng_seed).integers(0, 256, (6, 5, 3), dtype=np.uint8)
    Image.fromarray(px, mode="RGB").save(path)


_PLANE = """    <shape type="rectangle"><transform name="to_world"><scale value="0.5"/>{rotate}
        <rotate x="1" angle="-25"/><translate x="{x}" y="0.75"/></transform>
        <bsdf type="mask">{opacity}
            {bsdf}
        </bsdf></shape>
"""


def _scene_xml(tmp_path, *, max_depth=6, integrator="path", name="scene.xml"):
    _png(tmp_path / "alpha.png")
    diffuse = '<bsdf type="diffuse"><rgb name="reflectance" value="{}"/></bsdf>'
    planes = [
        dict(x=-1.65, rotate="", opacity='<float name="opacity" value="0.35"/>',
             bsdf=diffuse.format("0.8, 0.2, 0.2")),
        dict(x=-0.55, rotate="", bsdf=diffuse.format("0.2, 0.7, 0.3"),
             opacity='<texture type="checkerboard" name="opacity"><rgb name="color0" value="0.9, 0.6, 0.3"/>'
                     '<float name="color1" value="0.1"/><transform name="to_uv"><scale x="3" y="2"/></transform>'
                     '</texture>'),
        dict(x=0.55, rotate='<rotate y="1" angle="180"/>',
             bsdf='<bsdf type="twosided">' + diffuse.format("0.3, 0.3, 0.9") + "</bsdf>",
             opacity='<texture type="bitmap" name="opacity"><string name="filename" value="alpha.png"/></texture>'),
        dict(x=1.65, rotate='<rotate y="1" angle="180"/>', opacity='<float name="opacity" value="0.6"/>',
             bsdf=diffuse.format("0.9, 0.9, 0.2")),
    ]
    integ = (path_integrator(max_depth) if integrator == "path" else
             '<integrator type="direct"><integer name="emitter_samples" value="1"/>'
             '<integer name="bsdf_samples" value="1"/></integrator>')
    xml = tmp_path / name
    xml.write_text(scene_xml(diffuse_floor() + "".join(_PLANE.format(**p) for p in planes) + """\
    <shape type="rectangle"><transform name="to_world"><scale value="0.8"/><rotate x="1" angle="90"/>
        <translate y="3"/></transform>
        <emitter type="area"><rgb name="radiance" value="8"/></emitter></shape>
    <emitter type="constant"><rgb name="radiance" value="0.25"/></emitter>""",
        integrator=integ, fov=50, origin="0, 1.8, 4.5", target="0, 0.6, 0", width=40, height=24))
    return xml


def test_import_reads_every_plane(tmp_path):
    scene = from_mitsuba(_scene_xml(tmp_path))
    masks = [s.material for s in scene.shapes if isinstance(s.material, rt.Mask)]
    assert [type(m.opacity).__name__ for m in masks] == ["float", "Checkerboard", "Bitmap", "float"]
    assert masks[0].opacity == pytest.approx(0.35) and masks[3].opacity == pytest.approx(0.6)
    assert [m.material.two_sided for m in masks] == [False, False, True, False]
    # eval_1 of the checkerboard: the colours' means, color0 where the fractional parts differ
    uv = np.array([[0.1, 0.1], [0.2, 0.1]])   # after to_uv (3, 2): (0.3, 0.2) and (0.6, 0.2)
    assert masks[1].opacity.eval_1(uv) == pytest.approx([0.1, 0.6])
    assert masks[2].opacity.channels == 3 and masks[2].opacity.scalar().channels == 1


@pytest.mark.parametrize("strategy", ["mis", "cosine"])
def test_masked_planes_agree_with_mitsuba(tmp_path, strategy):
    xml = _scene_xml(tmp_path)
    scene = from_mitsuba(xml)
    ours = rt.render(scene, spp=SPP, strategy=strategy, seed=1, threads=2)
    mit = render_mitsuba(xml, spp=SPP, seed=1, batches=16, threads=2)
    a = agreement(ours, mit, pixel_filter=scene.camera.filter)
    assert a.agrees, a.describe()


def test_a_pass_through_a_mask_is_a_bounce(tmp_path):
    # max_depth 2: the camera ray and one more segment. Through a mask's null lobe that
    # segment reaches the floor, which then neither emits nor samples a light: black, while
    # the sky behind a plane stays visible.
    xml = _scene_xml(tmp_path, max_depth=2)
    scene = from_mitsuba(xml)
    assert scene.max_depth == 2
    ours = rt.render(scene, spp=SPP, strategy="mis", seed=2, threads=2)
    mit = render_mitsuba(xml, spp=SPP, seed=2, batches=16, threads=2)
    a = agreement(ours, mit, pixel_filter=scene.camera.filter)
    assert a.agrees, a.describe()
    deep = rt.render(scene.with_camera_size(20, 12), spp=64, strategy="mis", seed=2, threads=2)
    shallow = rt.render(from_mitsuba(_scene_xml(tmp_path, max_depth=6, name="deep.xml")).with_camera_size(20, 12),
                        spp=64, strategy="mis", seed=2, threads=2)
    assert deep.mean.sum() < shallow.mean.sum()


def test_direct_integrator_agrees_with_mitsuba(tmp_path):
    # Mitsuba's direct: its BSDF sample through the null lobe counts the emitter it meets
    # (weight 1, a Dirac lobe), and nothing else beyond the first surface.
    xml = _scene_xml(tmp_path, integrator="direct")
    scene = from_mitsuba(xml)
    assert scene.direct is not None
    ours = rt.render(scene, spp=SPP, strategy="mis", seed=3, threads=2)
    mit = render_mitsuba(xml, spp=SPP, seed=3, batches=16, threads=2)
    a = agreement(ours, mit, pixel_filter=scene.camera.filter)
    assert a.agrees, a.describe()


@pytest.mark.parametrize("strategy", rt.STRATEGIES)
def test_wavefront_equals_scalar(tmp_path, strategy):
    scene = from_mitsuba(_scene_xml(tmp_path)).with_camera_size(20, 12)
    a, b = (rt.render(scene, spp=8, strategy=strategy, seed=7, threads=2, integrator=i)
            for i in ("scalar", "wavefront"))
    assert np.array_equal(a.mean, b.mean) and np.array_equal(a.variance, b.variance)


def test_untouched_materials_render_as_before():
    # a scene without masks passes no mask columns' effect: the nested material alone, and
    # a mask of opacity 1 renders exactly as its material (the null lobe never drawn)
    cam = rt.Camera(lookfrom=(0, 1, 3), lookat=(0, 0.3, 0), width=12, height=8)
    light = rt.Quad((-0.5, 2, -0.5), (0, 0, 1), (1, 0, 0), rt.DiffuseLight(6))
    floor = rt.Quad((-2, 0, 2), (4, 0, 0), (0, 0, -4), rt.Lambertian(0.6))

    def scene(m):
        return rt.Scene(cam, [floor, light, rt.Sphere((0, 0.4, 0), 0.4, m)], background=0.1)

    for m in (rt.Lambertian((0.3, 0.5, 0.7)), rt.Plastic(0.4), rt.RoughConductor(0.8, 0.2)):
        a = rt.render(scene(m), spp=8, strategy="mis", seed=5, threads=1)
        b = rt.render(scene(rt.Mask(m, 1.0)), spp=8, strategy="mis", seed=5, threads=1)
        assert np.array_equal(a.mean, b.mean), type(m).__name__


def test_opacity_zero_is_invisible():
    # opacity 0: always the null lobe (weight 1), so every pixel is the sky behind the pane
    cam = rt.Camera(lookfrom=(0, 0, 3), lookat=(0, 0, 0), width=8, height=8, vfov=20)
    sky = 0.5
    pane = rt.Quad((-2, -2, 1), (4, 0, 0), (0, 4, 0), rt.Mask(rt.Lambertian(0.9), 0.0))
    out = rt.render(rt.Scene(cam, [pane], background=sky), spp=4, strategy="mis", seed=1, threads=1)
    assert np.allclose(out.mean, sky)


# ------------------------------------------------------------------------------ bad input

@pytest.mark.parametrize("bad", [float("nan"), -0.1, 1.5, float("inf"), "half", None, True])
def test_bad_opacity_is_refused(bad):
    with pytest.raises(ValueError, match="Mask.opacity"):
        rt.Mask(rt.Lambertian(0.5), bad)


def test_clip_clips_as_mitsuba_and_still_refuses_nan():
    assert rt.Mask(rt.Lambertian(0.5), -0.5, clip=True).opacity == 0.0
    assert rt.Mask(rt.Lambertian(0.5), 7.0, clip=True).opacity == 1.0
    with pytest.raises(ValueError, match="finite"):
        rt.Mask(rt.Lambertian(0.5), float("nan"), clip=True)
    with pytest.raises(ValueError, match=r"values in \[0.1, 2\]"):
        rt.Mask(rt.Lambertian(0.5), rt.Checkerboard(0.1, 2.0))
    assert isinstance(rt.Mask(rt.Lambertian(0.5), rt.Checkerboard(0.1, 2.0), clip=True).opacity, rt.Checkerboard)


def test_bad_nested_material_is_refused():
    with pytest.raises(ValueError, match="emitter"):
        rt.Mask(rt.DiffuseLight(1.0), 0.5)
    with pytest.raises(ValueError, match="Mask around a Mask"):
        rt.Mask(rt.Mask(rt.Lambertian(0.5), 0.5), 0.5)
    with pytest.raises(ValueError, match="must be a material"):
        rt.Mask("diffuse", 0.5)


def _one_shape(tmp_path, bsdf, *, emitter=""):
    xml = tmp_path / "one.xml"
    xml.write_text(scene_xml(f'<shape type="rectangle">{bsdf}{emitter}</shape>', width=4, height=4, rfilter=None))
    return xml


def test_importer_refuses_what_mitsuba_refuses(tmp_path):
    with pytest.raises(ValueError, match="mask without a nested BSDF"):
        from_mitsuba(_one_shape(tmp_path, '<bsdf type="mask"><float name="opacity" value="0.5"/></bsdf>'))
    with pytest.raises(ValueError, match="mask with 2 nested BSDFs"):
        from_mitsuba(_one_shape(tmp_path, '<bsdf type="mask"><bsdf type="diffuse"/><bsdf type="conductor"/></bsdf>'))
    with pytest.raises(ValueError, match="area emitter on a 'mask' BSDF"):
        from_mitsuba(_one_shape(tmp_path, '<bsdf type="mask"><bsdf type="diffuse"/></bsdf>',
                                emitter='<emitter type="area"><rgb name="radiance" value="1"/></emitter>'))
    with pytest.raises(ValueError, match="mask opacity NaN"):
        from_mitsuba(_one_shape(tmp_path, '<bsdf type="mask"><float name="opacity" value="nan"/>'
                                          '<bsdf type="diffuse"/></bsdf>'))


@pytest.mark.parametrize("value, expected", [("1.7", 1.0), ("-0.5", 0.0), ("0.25", 0.25)])
def test_importer_clips_the_opacity_as_mitsuba(tmp_path, value, expected):
    xml = _one_shape(tmp_path, f'<bsdf type="mask"><float name="opacity" value="{value}"/>'
                               '<bsdf type="diffuse"/></bsdf>')
    (m,) = [s.material for s in from_mitsuba(xml).shapes]
    assert isinstance(m, rt.Mask) and m.opacity == expected and isinstance(m.material, rt.Lambertian)


def test_importer_default_and_rgb_opacity(tmp_path):
    # no opacity: Mitsuba's 0.5; an rgb value: its eval_1, the mean of the channels
    xml = _one_shape(tmp_path, '<bsdf type="mask"><bsdf type="twosided"><bsdf type="diffuse"/></bsdf></bsdf>')
    (m,) = [s.material for s in from_mitsuba(xml).shapes]
    assert m.opacity == 0.5 and m.material.two_sided
    xml = _one_shape(tmp_path, '<bsdf type="mask"><rgb name="opacity" value="0.2, 0.4, 0.9"/>'
                               '<bsdf type="twosided"><bsdf type="diffuse"/></bsdf></bsdf>')
    (m,) = [s.material for s in from_mitsuba(xml).shapes]
    assert m.opacity == pytest.approx(0.5) and m.material.two_sided


def test_a_twosided_around_a_mask_is_refused_as_mitsuba_refuses_it(tmp_path):
    # the mask's pass-through is a transmission, which Mitsuba's twosided does not nest
    xml = _one_shape(tmp_path, '<bsdf type="twosided"><bsdf type="mask"><bsdf type="diffuse"/></bsdf></bsdf>')
    from mitsuba_scenes.variants import import_mitsuba

    with pytest.raises(RuntimeError, match="Only materials without a transmission component"):
        import_mitsuba().load_file(str(xml))
    with pytest.raises(ValueError, match=r"twosided around a mask, a BSDF that transmits: Mitsuba refuses it too"):
        from_mitsuba(xml)


# ------------------------------------------------------------------------------ round trips

def _mask_scene(opacity, tmp_path=None):
    cam = rt.Camera(lookfrom=(0, 1, 3), lookat=(0, 0.3, 0), width=8, height=6)
    return rt.Scene(cam, [rt.Quad((-1, 0, 1), (2, 0, 0), (0, 0, -2),
                                  rt.Mask(rt.Plastic(0.4, two_sided=True), opacity))], background=0.3)


def test_translation_to_a_mitsuba_dict():
    d = to_mitsuba(_mask_scene(0.3))
    (bsdf,) = [v["bsdf"] for k, v in d.items() if k.startswith("shape_")]
    assert bsdf["type"] == "mask" and bsdf["opacity"] == pytest.approx(0.3)
    assert bsdf["bsdf"]["type"] == "twosided" and bsdf["bsdf"]["bsdf"]["type"] == "plastic"
    import mitsuba as mi

    from mitsuba_scenes.variants import select_variant

    mi.set_variant(select_variant())
    from mitsuba_scenes.translate.dictionary import mitsuba_values

    assert "Mask" in str(mi.load_dict(mitsuba_values(mi, bsdf)))


@pytest.mark.parametrize("opacity", [0.3, rt.Checkerboard(0.2, (0.9, 0.5, 0.7), to_uv=np.diag([3.0, 2.0, 1.0])),
                                     rt.Bitmap(np.random.default_rng(1).uniform(0, 1, (4, 3, 3)),
                                               filter="nearest")])
def test_xml_round_trip(tmp_path, opacity):
    scene = _mask_scene(opacity)
    path = to_xml(scene, tmp_path / "mask.xml", spp=4)
    (m,) = [s.material for s in from_mitsuba(path).shapes]
    assert isinstance(m, rt.Mask) and isinstance(m.material, rt.Plastic) and m.material.two_sided
    if isinstance(opacity, float):
        assert m.opacity == pytest.approx(opacity)
    else:
        uv = np.random.default_rng(2).uniform(0, 1, (50, 2))
        assert m.opacity.eval_1(uv) == pytest.approx(opacity.eval_1(uv), abs=1e-6)
