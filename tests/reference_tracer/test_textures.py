"""Textures (Mitsuba's ``checkerboard`` and ``bitmap``) on reflectances, judged by Mitsuba.

Three kinds of check:

- **First-hit parity** (``benchmarks.parity``): the albedo AOV at every pixel centre, ours
  (the core's texture lookup at its texture coordinates: ``reference_tracer.probe``) against
  Mitsuba's ``eval_diffuse_reflectance``, to 1e-4 relative. It shows each shape's texture
  coordinates (sphere, rectangle, triangle, mesh with and without UVs, cube, flipped normals,
  rotations) and each lookup (filters, wrap modes, ``to_uv``) exactly, without noise.
- **Renders** of small XML scenes, imported with ``from_mitsuba`` and rendered by both
  (``benchmarks.gate.agreement``, as ``tests/mitsuba_scenes/test_published_scenes.py``): per channel the
  whole image's z and the share of pixel values with ``|z| > 4``. Agreement: every
  ``|global z| <= 4`` and at most 1% of pixel values beyond 4. False-positive rate of one
  scene, for agreeing renders: about 3 x 6.3e-5 ~ 2e-4 from the global z (normal
  approximation) plus a negligible share term (0.006% expected against a 1% limit), so about
  1e-3 over the five scenes here; seeds are fixed, so a pass is reproducible.
- **Bad input**: files and values that are refused with a ``ValueError`` naming them.

Images are generated in the tests (a few texels), never shipped.
"""
from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import numpy as np
import pytest

import reference_tracer as rt
from benchmarks.gate.agreement import agreement
from benchmarks.parity import run_parity
from mitsuba_scenes import from_mitsuba, render_mitsuba, to_mitsuba, to_xml
from mitsuba_scenes.importer import UnsupportedSceneError
from mitsuba_xml import path_integrator, scene_xml
from reference_tracer import probe
from reference_tracer.image_files import read_image, srgb_to_linear
from reference_tracer.material_textures import reflectance_of

pytestmark = pytest.mark.usefixtures("fresh_registries")

RNG = np.random.default_rng(46)
IMAGE = RNG.uniform(0.02, 0.98, (5, 7, 3))           # odd sizes: an axis swap cannot hide
CHECKER = rt.Checkerboard((0.1, 0.2, 0.3), (0.8, 0.7, 0.6), to_uv=np.diag([6.0, 4.0, 1.0]))


def _rotation(axis, degrees) -> tuple:
    a = np.radians(degrees)
    x, y, z = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    c, s = np.cos(a), np.sin(a)
    m = np.eye(4)
    m[:3, :3] = [[c + x * x * (1 - c), x * y * (1 - c) - z * s, x * z * (1 - c) + y * s],
                 [y * x * (1 - c) + z * s, c + y * y * (1 - c), y * z * (1 - c) - x * s],
                 [z * x * (1 - c) - y * s, z * y * (1 - c) + x * s, c + z * z * (1 - c)]]
    return tuple(map(tuple, m))


def _bitmap(filter="bilinear", wrap="repeat", to_uv=((2, 0.3, 0.1), (0, 1.5, -0.2), (0, 0, 1))):
    return rt.Bitmap(IMAGE, filter=filter, wrap=wrap, to_uv=to_uv)


# A pyramid: four triangles around an apex, with UVs beyond the unit square (wrapping).
PYRAMID_V = np.array([[-1, -1, 0.2], [1, -1, 0], [1, 1, 0.1], [-1, 1, 0], [0, 0, -0.5]], dtype=float)
PYRAMID_F = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
PYRAMID_UV = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0.5]]) * 1.3 - 0.1


def _scene(*shapes, width=48, height=40) -> rt.Scene:
    cam = rt.Camera(lookfrom=(0.3, 0.5, -3), lookat=(0, 0, 0), width=width, height=height, vfov=45)
    return rt.Scene(camera=cam, shapes=list(shapes), background=(0.5, 0.5, 0.5))


PARITY = {
    "sphere checkerboard": lambda: rt.Sphere((0, 0, 0), 1, rt.Lambertian(CHECKER)),
    "rotated sphere checkerboard": lambda: rt.Sphere((0, 0, 0), 1, rt.Lambertian(CHECKER),
                                                     transform=_rotation((1, 2, 0.5), 40)),
    "rotated sphere plastic bitmap mirror": lambda: rt.Sphere((0, 0, 0), 1, rt.Plastic(_bitmap(wrap="mirror")),
                                                              transform=_rotation((0, 1, 0), 70)),
    "quad checkerboard": lambda: rt.Quad((-1, -1, 0), (2, 0, 0.3), (0, 2, 0), rt.Lambertian(CHECKER)),
    "flipped quad bitmap nearest clamp": lambda: rt.Quad(
        (-1, -1, 0), (2, 0, 0.3), (0, 2, 0), flip_normals=True,
        material=rt.Lambertian(_bitmap("nearest", "clamp", ((2, 0, -0.5), (0, 1.5, -0.2), (0, 0, 1))))),
    "quad bitmap repeat": lambda: rt.Quad((-1, -1, 0), (2, 0, 0.3), (0, 2, 0),
                                          rt.Lambertian(_bitmap(to_uv=np.diag([3.0, 3.0, 1.0])), two_sided=True)),
    "triangle checkerboard": lambda: rt.Triangle((-1, -1, 0), (1, -1, 0), (0, 1, 0),
                                                 rt.Lambertian(CHECKER, two_sided=True)),
    "mesh with uv": lambda: rt.Mesh(PYRAMID_V, PYRAMID_F, rt.Lambertian(_bitmap(), two_sided=True), uv=PYRAMID_UV),
    "flipped mesh with uv, nearest": lambda: rt.Mesh(PYRAMID_V, PYRAMID_F, flip_normals=True, uv=PYRAMID_UV,
                                                     material=rt.Lambertian(_bitmap("nearest"), two_sided=True)),
    "mesh without uv (barycentrics)": lambda: rt.Mesh(PYRAMID_V, PYRAMID_F, rt.Lambertian(CHECKER, two_sided=True)),
    "rotated box checkerboard": lambda: rt.Box((-0.7, -0.7, -0.7), (0.7, 0.7, 0.7), rt.Lambertian(CHECKER),
                                               transform=_rotation((1, 1, 0), 30)),
    "grey bitmap": lambda: rt.Quad((-1, -1, 0), (2, 0, 0), (0, 2, 0), rt.Lambertian(rt.Bitmap(IMAGE[..., 0]))),
}


@pytest.mark.parametrize("name", sorted(PARITY))
def test_first_hit_albedo_matches_mitsuba(name):
    shape = PARITY[name]()
    report = run_parity(_scene(shape), name=name)
    assert report.passed, (report.summary(), report.findings)
    assert report.counts["albedo"] == 0
    # the texture is seen (not one colour everywhere): the check has something to compare
    albedo = report.ours["albedo"][report.ours["shape"] == 0]
    assert len(np.unique(albedo.round(6), axis=0)) > 1


@pytest.mark.parametrize("name", ["rotated sphere checkerboard", "flipped quad bitmap nearest clamp", "mesh with uv"])
def test_parity_sees_a_shifted_texture(name):
    """The same scene in Mitsuba against ours with to_uv shifted by 0.1 in v: albedo differs."""
    scene = _scene(PARITY[name]())
    shape = scene.shapes[0]
    tex = reflectance_of(shape.material)
    shifted = (tex.to_uv[0], (tex.to_uv[1][0], tex.to_uv[1][1], tex.to_uv[1][2] + 0.1))
    wrong = (rt.Checkerboard(tex.color0, tex.color1, to_uv=shifted) if isinstance(tex, rt.Checkerboard)
             else rt.Bitmap(tex.data, filter=tex.filter, wrap=tex.wrap, to_uv=shifted))
    key = "diffuse_reflectance" if isinstance(shape.material, rt.Plastic) else "albedo"
    wrong_scene = dataclasses.replace(scene, shapes=[
        dataclasses.replace(shape, material=dataclasses.replace(shape.material, **{key: wrong}))])
    report = run_parity(wrong_scene, mitsuba=to_mitsuba(scene), name=name)
    assert not report.passed and report.counts["albedo"] > 50, report.summary()


@pytest.mark.parametrize("filter", rt.bitmap.FILTER_TYPES)
@pytest.mark.parametrize("wrap", rt.bitmap.WRAP_MODES)
def test_core_lookup_is_the_python_texture(filter, wrap):
    """The core's value at each hit is Bitmap.eval at the core's texture coordinates (the
    Python model the docs describe), across several periods of the image each way."""
    tex = rt.Bitmap(IMAGE, filter=filter, wrap=wrap, to_uv=((3.5, 0.4, -1.3), (-0.2, 2.5, -0.7), (0, 0, 1)))
    scene = _scene(rt.Quad((-1.5, -1.5, 0), (3, 0, 0), (0, 3, 0), rt.Lambertian(tex)), width=64, height=64)
    cam = scene.camera
    yy, xx = np.mgrid[0:64, 0:64]
    o, d = probe.camera_rays(cam, xx.ravel() + 0.5, yy.ravel() + 0.5)
    hit = probe.core_scene(scene).intersect(o, d)
    valid = np.isfinite(hit["t"])
    assert valid.mean() > 0.5
    uv = np.asarray(hit["uv"])[valid]
    np.testing.assert_allclose(np.asarray(hit["reflectance"])[valid], tex.eval(uv), rtol=1e-6, atol=1e-7)


def test_checkerboard_cells_and_mean():
    c = rt.Checkerboard(0.25, (0.5, 0.75, 1.0))
    values = c.eval([[0.25, 0.25], [0.75, 0.25], [0.25, 0.75], [0.75, 0.75], [-0.25, 0.25]])[:, 2]
    assert values.tolist() == [0.25, 1.0, 1.0, 0.25, 1.0]
    assert c.mean() == pytest.approx(0.5 * (0.25 + 0.75))


def test_srgb_decoding_is_mitsubas():
    """8-bit texels decoded as Dr.Jit's srgb_to_linear does (its rational fit), within 1e-6
    of the exact sRGB curve."""
    x = np.arange(256) / 255.0
    exact = np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)
    np.testing.assert_allclose(srgb_to_linear(x), exact, atol=1e-6)


# ------------------------------------------------------------------------------------------
# Renders of XML scenes, both renderers

SPP = 4096


def _scene_xml(body: str) -> str:
    """A sky and a small sphere light, then ``body``; 28 x 24 pixels."""
    return scene_xml("""\
    <emitter type="constant"><rgb name="radiance" value="0.8, 0.9, 1.0"/></emitter>
    <shape type="sphere">
        <point name="center" x="-1.5" y="2.5" z="-1"/><float name="radius" value="0.3"/>
        <emitter type="area"><rgb name="radiance" value="12, 11, 9"/></emitter>
    </shape>
""" + body, integrator=path_integrator(4), fov=40, origin="0.4, 1.6, -3.2", target="0, 0.1, 0",
                     sampler='<sampler type="independent"><integer name="sample_count" value="16"/></sampler>',
                     width=28, height=24)


# the floor: a rectangle in the xz plane, two units wide
_FLOOR = """    <shape type="rectangle">
        <transform name="to_world"><scale value="1.5"/><rotate x="1" angle="-90"/>
            <rotate y="1" angle="20"/></transform>
        {bsdf}
    </shape>
"""
_GREY_FLOOR = _FLOOR.format(bsdf='<bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf>')

SCENES = {
    "checkerboard quad": _scene_xml(_FLOOR.format(bsdf="""<bsdf type="diffuse">
            <texture type="checkerboard" name="reflectance">
                <rgb name="color0" value="0.1, 0.15, 0.2"/><rgb name="color1" value="0.85, 0.7, 0.5"/>
                <transform name="to_uv"><scale x="5" y="3"/><translate x="0.1"/></transform>
            </texture>
        </bsdf>""") + """    <shape type="sphere">
        <point name="center" x="0" y="0.5" z="0"/><float name="radius" value="0.5"/>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.6"/></bsdf>
    </shape>
"""),
    "checkerboard sphere": _scene_xml(_GREY_FLOOR + """    <texture type="checkerboard" id="checks">
        <rgb name="color0" value="0.05, 0.3, 0.6"/><rgb name="color1" value="0.9, 0.8, 0.3"/>
        <transform name="to_uv"><scale x="8" y="4"/></transform>
    </texture>
    <shape type="sphere">
        <transform name="to_world"><scale value="0.5"/><rotate x="1" angle="50"/><rotate z="1" angle="25"/>
            <translate x="-0.45" y="0.5"/></transform>
        <bsdf type="plastic"><ref name="diffuse_reflectance" id="checks"/></bsdf>
    </shape>
    <shape type="sphere">
        <transform name="to_world"><scale value="0.4"/><rotate y="1" angle="-30"/>
            <translate x="0.6" y="0.4" z="-0.3"/></transform>
        <bsdf type="roughconductor">
            <string name="material" value="Au"/><float name="alpha" value="0.3"/>
            <ref name="specular_reflectance" id="checks"/>
        </bsdf>
    </shape>
"""),
}

_MESH_SCENE = _scene_xml(_GREY_FLOOR + """\
    <shape type="obj">
        <string name="filename" value="pyramid.obj"/>
        <transform name="to_world"><rotate x="1" angle="-90"/><translate y="0.5"/></transform>
        <bsdf type="twosided"><bsdf type="diffuse">
            <texture type="bitmap" name="reflectance">
                <string name="filename" value="texels.png"/>
                <string name="filter_type" value="{filter}"/>
                <string name="wrap_mode" value="mirror"/>
                <boolean name="raw" value="{raw}"/>
            </texture>
        </bsdf></bsdf>
    </shape>
""")


def _write_png(path: Path, pixels: np.ndarray) -> None:
    from PIL import Image

    Image.fromarray(pixels).save(path)


PNG_PIXELS = RNG.integers(10, 250, (6, 9, 3), dtype=np.uint8)


def _mesh_folder(tmp_path: Path, *, raw: bool, filter="bilinear") -> Path:
    """The pyramid as an OBJ with ``vt`` (beyond the unit square: the wrap mode shows) and
    a 9x6 PNG beside it; the XML's path."""
    lines = [f"v {x} {y} {z}" for x, y, z in PYRAMID_V * [0.7, 0.7, 1.0]]
    lines += [f"vt {u} {v}" for u, v in PYRAMID_UV * 1.5]
    lines += [f"f {a + 1}/{a + 1} {b + 1}/{b + 1} {c + 1}/{c + 1}" for a, b, c in PYRAMID_F]
    (tmp_path / "pyramid.obj").write_text("\n".join(lines) + "\n")
    _write_png(tmp_path / "texels.png", PNG_PIXELS)
    xml = tmp_path / "scene.xml"
    xml.write_text(_MESH_SCENE.format(raw=str(raw).lower(), filter=filter))
    return xml


def _agreement(path: Path, scene: rt.Scene | None = None, *, seed: int = 1):
    scene = from_mitsuba(path) if scene is None else scene
    ours = rt.render(scene, spp=SPP, strategy="mis", seed=seed, threads=2)
    mit = render_mitsuba(path, spp=SPP, seed=seed, batches=16, threads=2)
    assert ours.mean.shape == mit.mean.shape == (24, 28, 3)
    return agreement(ours, mit, pixel_filter=scene.camera.filter)


@pytest.mark.parametrize("name", sorted(SCENES))
def test_render_agrees_with_mitsuba(name, tmp_path):
    path = tmp_path / "scene.xml"
    path.write_text(SCENES[name])
    a = _agreement(path)
    assert a.agrees, a.describe()


@pytest.mark.parametrize("raw, filter", [(False, "bilinear"), (True, "bilinear"), (False, "nearest")])
def test_bitmap_on_obj_mesh_agrees_with_mitsuba(raw, filter, tmp_path):
    """An OBJ with ``vt`` (flipped on loading, as Mitsuba's default) and a PNG, sRGB-decoded
    or raw, mirrored beyond the unit square."""
    path = _mesh_folder(tmp_path, raw=raw, filter=filter)
    scene = from_mitsuba(path)
    mesh = next(s for s in scene.shapes if isinstance(s, rt.Mesh))
    assert mesh.uv is not None and mesh.material.albedo.raw is raw
    a = _agreement(path, scene)
    assert a.agrees, a.describe()


def test_agreement_sees_srgb_taken_as_raw(tmp_path):
    """Ours reads the PNG raw (value / 255), Mitsuba decodes it from sRGB: they disagree."""
    path = _mesh_folder(tmp_path, raw=True)
    scene = from_mitsuba(path)
    path.write_text(_MESH_SCENE.format(raw="false", filter="bilinear"))   # Mitsuba's file: sRGB
    a = _agreement(path, scene)
    assert not a.agrees, a.describe()


def test_scalar_and_wavefront_agree_bit_for_bit_with_textures():
    scene = _scene(PARITY["rotated sphere plastic bitmap mirror"](), PARITY["quad checkerboard"](), width=16,
                   height=12)
    a = rt.render(scene, spp=16, seed=5, threads=1, integrator="scalar")
    b = rt.render(scene, spp=16, seed=5, threads=1, integrator="wavefront")
    assert np.array_equal(a.mean, b.mean)


@pytest.mark.parametrize("strategy", ["cosine", "mis"])
def test_wavefront_packs_of_textured_and_masked_ggx_equal_scalar(strategy):
    # The wavefront integrator scatters plain-GGX conductors a pack at a time: a textured
    # one must take its texture's value at the hit, a masked one its null lobe, as the
    # scalar integrator does.
    ggx = rt.RoughConductor(CHECKER, alpha=0.3, two_sided=True)
    masked = rt.Mask(rt.RoughConductor((0.9, 0.8, 0.7), alpha=0.2), opacity=CHECKER)
    light = rt.Quad((-3, 3, -3), (6, 0, 0), (0, 0, 6), rt.DiffuseLight((4.0, 4.0, 4.0)))
    scene = _scene(rt.Sphere((0, 0, 0), 1, ggx), rt.Quad((-2, -1, -2), (4, 0, 0), (0, 0.2, 4), masked),
                   rt.Quad((-3, -1.5, -3), (0, 0, 6), (6, 0, 0), rt.Lambertian(0.5)), light, width=16, height=12)
    a = rt.render(scene, spp=16, strategy=strategy, seed=5, threads=1, integrator="scalar")
    b = rt.render(scene, spp=16, strategy=strategy, seed=5, threads=1, integrator="wavefront")
    assert np.array_equal(a.mean, b.mean) and np.array_equal(a.variance, b.variance)


# ------------------------------------------------------------------------------------------
# The importer

_SENSOR = """    <sensor type="perspective"><film type="hdrfilm"><integer name="width" value="8"/>
        <integer name="height" value="6"/><rfilter type="box"/></film></sensor>
"""


def _xml(tmp_path: Path, body: str) -> Path:
    path = tmp_path / "scene.xml"
    path.write_text('<scene version="3.0.0">\n' + body + "\n" + _SENSOR + "</scene>\n")
    return path


def test_import_texture_by_reference_is_one_object(tmp_path):
    _write_png(tmp_path / "t.png", PNG_PIXELS)
    path = _xml(tmp_path, """
    <texture type="bitmap" id="t"><string name="filename" value="t.png"/>
        <string name="filter_type" value="nearest"/><string name="wrap_mode" value="clamp"/>
        <transform name="to_uv"><scale x="2" y="3"/></transform></texture>
    <shape type="sphere"><bsdf type="diffuse"><ref name="reflectance" id="t"/></bsdf></shape>
    <shape type="rectangle"><bsdf type="conductor"><ref name="specular_reflectance" id="t"/></bsdf></shape>""")
    scene = from_mitsuba(path)
    a, b = (s.material.albedo for s in scene.shapes)
    assert a is b and isinstance(a, rt.Bitmap)
    assert (a.filter, a.wrap, a.raw, a.width, a.height, a.channels) == ("nearest", "clamp", False, 9, 6, 3)
    assert a.to_uv == ((2.0, 0.0, 0.0), (0.0, 3.0, 0.0))
    np.testing.assert_allclose(a.data, read_image(tmp_path / "t.png"))
    assert isinstance(scene.shapes[1].material, rt.Metal)


def test_import_checkerboard_defaults():
    scene = from_mitsuba({"type": "scene", "sensor": {"type": "perspective"}, "s": {"type": "sphere", "bsdf": {
        "type": "plastic", "diffuse_reflectance": {"type": "checkerboard"}}}})
    tex = scene.shapes[0].material.diffuse_reflectance
    assert tex.color0 == (0.4, 0.4, 0.4) and tex.color1 == (0.2, 0.2, 0.2)


def test_xml_round_trip_keeps_textures(tmp_path):
    scene = _scene(PARITY["mesh with uv"](), PARITY["rotated sphere checkerboard"](), width=20, height=16)
    path = to_xml(scene, tmp_path / "round.xml")
    back = from_mitsuba(path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["round.xml", "round_shape_000_mesh.ply",
                                                          "round_texture_0.exr"]
    report = run_parity(back, mitsuba=path, name="round trip")
    assert report.passed, report.findings
    ours, theirs = probe.first_hit_aovs(scene), probe.first_hit_aovs(back)
    np.testing.assert_allclose(ours["albedo"], theirs["albedo"], atol=2e-6)


@pytest.mark.parametrize("body, words", [
    ('<shape type="sphere"><bsdf type="roughconductor"><texture type="checkerboard" name="alpha"/></bsdf></shape>',
     "textured roughness is not supported"),
    ('<shape type="sphere"><bsdf type="plastic"><texture type="checkerboard" name="specular_reflectance"/>'
     "</bsdf></shape>", "only constant values here"),
    ('<shape type="sphere"><bsdf type="diffuse"><texture type="bitmap" name="reflectance">'
     '<string name="filename" value="missing.png"/></texture></bsdf></shape>', "missing.png"),
    ('<shape type="sphere"><bsdf type="diffuse"><texture type="bitmap" name="reflectance">'
     '<string name="filename" value="../outside.png"/></texture></bsdf></shape>', "outside the scene's folder"),
    ('<shape type="sphere"><bsdf type="diffuse"><texture type="bitmap" name="reflectance">'
     '<string name="filename" value="t.png"/><string name="wrap_mode" value="wrap"/></texture></bsdf></shape>',
     "Bitmap.wrap must be one of"),
    ('<shape type="sphere"><bsdf type="diffuse"><texture type="bitmap" name="reflectance">'
     '<string name="filename" value="t.png"/><string name="filter_type" value="bicubic"/></texture></bsdf></shape>',
     "Bitmap.filter must be one of"),
    ('<shape type="sphere"><bsdf type="diffuse"><texture type="checkerboard" name="reflectance">'
     '<rgb name="color0" value="2, 0, 0"/></texture></bsdf></shape>', "a reflectance must lie in [0, 1]"),
    ('<shape type="sphere"><bsdf type="diffuse"><texture type="bitmap" name="reflectance">'
     '<string name="filename" value="notes.png"/></texture></bsdf></shape>', "not an image of a supported format"),
])
def test_import_refuses_with_the_reason(tmp_path, body, words):
    (tmp_path / "sub").mkdir()
    _write_png(tmp_path / "outside.png", PNG_PIXELS)
    _write_png(tmp_path / "sub" / "t.png", PNG_PIXELS)
    (tmp_path / "sub" / "notes.png").write_text("not an image\n")
    with pytest.raises(UnsupportedSceneError) as err:
        from_mitsuba(_xml(tmp_path / "sub", body))
    assert words in str(err.value) and "scene.xml (line 2" in str(err.value), str(err.value)


def test_import_refuses_an_obj_corner_without_texture_coordinates(tmp_path):
    path = _mesh_folder(tmp_path, raw=False)
    text = (tmp_path / "pyramid.obj").read_text().replace("f 1/1 2/2 5/5", "f 1 2/2 5/5")
    (tmp_path / "pyramid.obj").write_text(text)
    with pytest.raises(UnsupportedSceneError, match="no texture coordinate index"):
        from_mitsuba(path)


# ------------------------------------------------------------------------------------------
# Bad input to the API and image files

@pytest.mark.parametrize("image, words", [
    (np.zeros((4, 4, 2)), "shape (H, W), (H, W, 1) or (H, W, 3)"),
    (np.zeros((0, 4, 3)), "shape (H, W), (H, W, 1) or (H, W, 3)"),
    (np.zeros(5), "shape (H, W), (H, W, 1) or (H, W, 3)"),
    (np.array([[0.1, np.nan], [0.2, 0.3]]), "must be finite"),
    (np.array([[0.1, np.inf], [0.2, 0.3]]), "must be finite"),
    ("no such file.png", "No such file"),
    ([["a", "b"]], "array of numbers"),
])
def test_bitmap_refuses_bad_images(image, words, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises((ValueError, OSError), match=None) as err:
        rt.Bitmap(image)
    assert words in str(err.value)


@pytest.mark.parametrize("kwargs, words", [
    ({"wrap": "wrap"}, "Bitmap.wrap must be one of"),
    ({"filter": "bicubic"}, "Bitmap.filter must be one of"),
    ({"raw": "yes"}, "Bitmap.raw must be True or False"),
    ({"to_uv": np.eye(2)}, "to_uv must be a (3, 3) or (4, 4) matrix"),
    ({"to_uv": [[1, 0, 0], [0, 1, 0], [1, 0, 1]]}, "must be affine"),
    ({"to_uv": [[1, 0, np.nan], [0, 1, 0], [0, 0, 1]]}, "must be finite"),
])
def test_bitmap_refuses_bad_parameters(kwargs, words):
    with pytest.raises(ValueError) as err:
        rt.Bitmap(IMAGE, **kwargs)
    assert words in str(err.value)


def test_reflectance_textures_must_lie_in_the_unit_range():
    with pytest.raises(ValueError, match=r"Lambertian.albedo: a Bitmap texture with values in \[0, 1.5\]"):
        rt.Lambertian(rt.Bitmap(np.array([[0.0, 1.5], [0.5, 0.5]])))
    with pytest.raises(ValueError, match="Plastic.diffuse_reflectance: a Checkerboard"):
        rt.Plastic(rt.Checkerboard(0.5, 1.2))
    with pytest.raises(ValueError):
        rt.Checkerboard((0.1, np.nan, 0.2))


@pytest.mark.parametrize("uv, words", [
    (np.zeros((4, 2)), "one row per vertex"),
    (np.zeros((5, 3)), "one row per vertex"),
    (np.full((5, 2), np.nan), "texture coordinates must be finite"),
])
def test_mesh_refuses_bad_texture_coordinates(uv, words):
    with pytest.raises(ValueError, match=None) as err:
        rt.Mesh(PYRAMID_V, PYRAMID_F, rt.Lambertian(CHECKER), uv=uv)
    assert words in str(err.value)


def test_image_files_are_checked_before_decoding(tmp_path):
    # a PNG header declaring 2^20 x 2^20 pixels: refused from its header, nothing allocated
    import struct
    import zlib

    ihdr = struct.pack(">IIBBBBB", 1 << 20, 1 << 20, 8, 2, 0, 0, 0)
    chunk = struct.pack(">I", len(ihdr)) + b"IHDR" + ihdr + struct.pack(">I", zlib.crc32(b"IHDR" + ihdr))
    (tmp_path / "huge.png").write_bytes(b"\x89PNG\r\n\x1a\n" + chunk)
    with pytest.raises(ValueError, match="more than the"):
        read_image(tmp_path / "huge.png")
    # a truncated PNG
    _write_png(tmp_path / "ok.png", PNG_PIXELS)
    (tmp_path / "cut.png").write_bytes((tmp_path / "ok.png").read_bytes()[:60])
    with pytest.raises(ValueError, match="not a readable PNG"):
        read_image(tmp_path / "cut.png")
    # a 16-bit PNG (Mitsuba keeps it at half precision)
    from PIL import Image

    Image.fromarray(np.full((3, 3), 40000, dtype=np.uint16)).save(tmp_path / "deep.png")
    with pytest.raises(ValueError, match="16-bit"):
        read_image(tmp_path / "deep.png")
    # an EXR with a NaN texel
    img = np.full((3, 3, 3), 0.5, dtype=np.float32)
    img[1, 1, 0] = np.nan
    rt.write_exr(tmp_path / "nan.exr", img)
    with pytest.raises(ValueError, match="not finite"):
        rt.Bitmap(tmp_path / "nan.exr")


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs")
def test_a_fifo_is_not_read(tmp_path):
    os.mkfifo(tmp_path / "pipe.png")
    with pytest.raises(ValueError, match="not a regular file"):
        read_image(tmp_path / "pipe.png")


def test_png_reads_as_mitsuba_reads_it(tmp_path):
    """The texels Mitsuba's bitmap stores (mi.Bitmap of the file, converted to linear
    float32) equal ours, sRGB decoded and raw."""
    from mitsuba_scenes.variants import import_mitsuba

    mi = import_mitsuba()
    _write_png(tmp_path / "t.png", PNG_PIXELS)
    b = mi.Bitmap(str(tmp_path / "t.png"))
    linear = np.array(b.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, srgb_gamma=False))
    np.testing.assert_allclose(read_image(tmp_path / "t.png"), linear, rtol=1e-6, atol=1e-7)   # 1 ulp: two float32 decodings
    np.testing.assert_array_equal(read_image(tmp_path / "t.png", raw=True),
                                  PNG_PIXELS.astype(np.float32) * np.float32(1.0 / 255.0))   # Mitsuba's decode()


def test_a_symbolic_link_out_of_the_scene_folder_is_refused(tmp_path):
    (tmp_path / "sub").mkdir()
    _write_png(tmp_path / "secret.png", PNG_PIXELS)
    (tmp_path / "sub" / "t.png").symlink_to(tmp_path / "secret.png")
    path = _xml(tmp_path / "sub", '<shape type="sphere"><bsdf type="diffuse"><texture type="bitmap" '
                                  'name="reflectance"><string name="filename" value="t.png"/></texture></bsdf></shape>')
    with pytest.raises(UnsupportedSceneError, match="outside the scene's folder"):
        from_mitsuba(path)


def test_mesh_load_reads_texture_coordinates_as_mitsuba(tmp_path):
    """Mesh.load of the OBJ (``vt`` flipped, Mitsuba's default) gives the coordinates the
    importer takes from Mitsuba's own loader, vertex for vertex."""
    path = _mesh_folder(tmp_path, raw=False)
    imported = next(s for s in from_mitsuba(path).shapes if isinstance(s, rt.Mesh))
    loaded = rt.Mesh.load(tmp_path / "pyramid.obj", rt.Lambertian(CHECKER))
    assert loaded.uv.shape == imported.uv.shape == (5, 2)
    np.testing.assert_allclose(loaded.uv, imported.uv, atol=1e-6)
    # vertices in the order the faces first use them (Mitsuba's): matched by position
    order = [int(np.argmin(np.linalg.norm(PYRAMID_V * [0.7, 0.7, 1.0] - v, axis=1))) for v in loaded.vertices]
    np.testing.assert_allclose(loaded.uv, np.column_stack([1.5 * PYRAMID_UV[order, 0],
                                                           1.0 - 1.5 * PYRAMID_UV[order, 1]]), atol=1e-12)
    flat = rt.Mesh.load(tmp_path / "pyramid.obj", rt.Lambertian(0.5))
    assert flat.uv is None   # untextured: nothing read, the mesh hashes as before


@pytest.mark.parametrize("light", ["point", "envmap"])
def test_textures_under_lights_that_are_not_shapes_agree_with_mitsuba(light):
    """A checkerboard floor and a bitmap plastic sphere lit by a point light or an
    environment map (the scene translated to Mitsuba); both integrators give one image."""
    floor = rt.Quad((-2, 0, -2), (4, 0, 0), (0, 0, 4), rt.Lambertian(CHECKER), flip_normals=True)
    ball = rt.Sphere((0, 0.6, 0), 0.6, rt.Plastic(_bitmap(wrap="mirror", to_uv=np.diag([2.0, 3.0, 1.0]))))
    lights = [rt.PointLight((1, 3, -1), (8, 8, 8))] if light == "point" else [rt.EnvMap(np.full((8, 16, 3), 0.3))]
    cam = rt.Camera(lookfrom=(0.3, 1.5, -3), lookat=(0, 0, 0), width=28, height=24, vfov=45)
    scene = rt.Scene(camera=cam, shapes=[floor, ball], lights=lights, max_depth=4)
    ours = rt.render(scene, spp=SPP, strategy="mis", seed=1, threads=2)
    scalar = rt.render(scene, spp=16, strategy="mis", seed=2, threads=1, integrator="scalar")
    wavefront = rt.render(scene, spp=16, strategy="mis", seed=2, threads=1, integrator="wavefront")
    assert np.array_equal(scalar.mean, wavefront.mean)
    mit = render_mitsuba(scene, spp=SPP, seed=1, batches=16, threads=2)
    a = agreement(ours, mit, pixel_filter=scene.camera.filter)
    assert a.agrees, a.describe()
