"""Lights that are not shapes: the environment map (Mitsuba's ``envmap``) and the delta lights
(``point``, ``spot``, ``directional``).

* The scene model refuses bad input with the field named; image files are untrusted (their
  header is checked before decoding; a FIFO, a folder, a lying or truncated file is refused).
* Our RGBE reader gives Mitsuba's own values; an EnvMap's lookup is Mitsuba's (its texels,
  padding, orientation and rotation).
* Furnace: a white diffuse sphere inside a constant environment map converges to the closed
  form (a convex object: one bounce), under every strategy.
* The wavefront integrator equals the scalar one bit for bit with these lights too.
* Agreement with Mitsuba (``benchmarks.gate.agreement``, as the published scenes: 4096 spp
  each, fixed seeds, Mitsuba in 16 batches of 256; every channel's |global z| <= 4, three
  tests at alpha 6e-5 each under the normal approximation, and at most 1% of pixel values
  with |z| > 4, about 0.006% expected of agreeing images: glossy highlights of small
  lights are skewed at this budget and filtered neighbours correlated, hence the margin): an envmap read from OpenEXR and from RGBE, rotated, beside diffuse and rough
  metal; point, spot (default and explicit beam) and directional lights with the path and
  the direct integrators; Mitsuba's own ``hello.xml`` (direct, 4 emitter samples, two point
  lights: its delta-light weighting reproduced); a scene of every light translated by
  ``to_mitsuba``.
* Import (parameters, refusals with file and line) and translation (XML round trip).
"""
from __future__ import annotations

import dataclasses
import math
import os

import numpy as np
import pytest

import reference_tracer as rt
from benchmarks.cli import main
from benchmarks.gate.agreement import agreement
from benchmarks.parity import run_parity
from mitsuba_scenes import from_mitsuba, render_mitsuba, to_mitsuba, to_xml
from mitsuba_xml import diffuse_floor, path_integrator, scene_xml
from reference_tracer import probe
from reference_tracer.render import BLIND_TO_DELTA_LIGHTS
from repo_paths import FIXTURES

PUBLISHED = FIXTURES / "published"
SPP = 4096


@pytest.fixture(scope="module")
def mi():
    from mitsuba_scenes.variants import import_mitsuba

    return import_mitsuba()


def _env_image(seed=1, shape=(16, 32)):
    rng = np.random.default_rng(seed)
    img = rng.uniform(0.05, 0.6, (*shape, 3)).astype(np.float32)
    img[3:5, 20:23] = (40.0, 30.0, 20.0)   # a sun
    img[shape[0] // 2:] *= 0.3              # a darker ground
    return img


def _camera(**kw):
    return rt.Camera(lookfrom=(0, 1.5, 5), lookat=(0, 0.5, 0), vfov=40, width=kw.get("width", 24),
                     height=kw.get("height", 18))


def _shapes():
    return [rt.Quad((-2, 0, 2), (4, 0, 0), (0, 0, -4), rt.Lambertian((0.7, 0.6, 0.5))),
            rt.Sphere((-0.6, 0.6, 0), 0.6, rt.Lambertian(0.8)),
            rt.Sphere((0.7, 0.5, 0.3), 0.5, rt.RoughConductor(1.0, alpha=0.2))]


# --------------------------------------------------------------------------- scene model
@pytest.mark.parametrize("make,needle", [
    (lambda: rt.EnvMap(np.full((4, 8, 3), np.nan)), "finite"),
    (lambda: rt.EnvMap(np.full((4, 8, 3), -1.0)), ">= 0"),
    (lambda: rt.EnvMap(np.zeros((4, 8, 2))), "shape"),
    (lambda: rt.EnvMap(np.zeros((0, 8, 3))), "shape"),
    (lambda: rt.EnvMap(np.array([["a"]])), "numbers"),
    (lambda: rt.EnvMap(np.ones((4, 8, 3)), scale=-1), "EnvMap.scale"),
    (lambda: rt.EnvMap(np.ones((4, 8, 3)), scale=math.inf), "EnvMap.scale"),
    (lambda: rt.EnvMap(np.ones((4, 8, 3)), to_world=np.diag([2.0, 2.0, 2.0])), "rotation"),
    (lambda: rt.EnvMap(np.ones((4, 8, 3)), to_world=np.eye(2)), "3x3 or 4x4"),
    (lambda: rt.EnvMap(np.ones((4, 8, 3)), to_world=[[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 1, 1]]), "affine"),
    (lambda: rt.PointLight((0, 0, math.nan), 1), "PointLight.position"),
    (lambda: rt.PointLight((0, 0, 0), -1), "PointLight.intensity"),
    (lambda: rt.PointLight((0, 0, 0), 1e39), "PointLight.intensity"),
    (lambda: rt.SpotLight((0, 0, 0), (0, 0, 0), 1), "SpotLight.direction"),
    (lambda: rt.SpotLight((0, 0, 0), (0, 0, 1), 1, cutoff_angle=0), "SpotLight.cutoff_angle"),
    (lambda: rt.SpotLight((0, 0, 0), (0, 0, 1), 1, cutoff_angle=200), "SpotLight.cutoff_angle"),
    (lambda: rt.SpotLight((0, 0, 0), (0, 0, 1), 1, cutoff_angle=20, beam_width=30), "SpotLight.beam_width"),
    (lambda: rt.DirectionalLight((0, 0, 0), 1), "DirectionalLight.direction"),
    (lambda: rt.DirectionalLight((0, 0, 1), (1, 1)), "DirectionalLight.irradiance"),
])
def test_bad_lights_are_refused_naming_the_field(make, needle):
    with pytest.raises(ValueError, match=needle):
        make()


def test_a_scene_has_one_environment():
    env = rt.EnvMap(np.ones((2, 4, 3)))
    cam = _camera()
    with pytest.raises(ValueError, match="one environment"):
        rt.Scene(cam, _shapes(), lights=[env, rt.EnvMap(np.ones((2, 4, 3)))])
    with pytest.raises(ValueError, match="background must be black"):
        rt.Scene(cam, _shapes(), lights=[env], background=0.5)
    with pytest.raises(ValueError, match="sequence of lights"):
        rt.Scene(cam, _shapes(), lights=env)
    with pytest.raises(ValueError, match=r"Scene.lights\[1\]"):
        rt.Scene(cam, _shapes(), lights=[env, "sun"])
    scene = rt.Scene(cam, _shapes(), lights=[rt.PointLight((0, 3, 0), 1), env])
    assert scene.environment is env and scene.delta_lights == [scene.lights[0]]
    assert scene.with_camera_size(8, 6).lights == scene.lights


def test_scenes_without_these_lights_keep_their_hash():
    scene = rt.Scene(_camera(), _shapes(), background=0.5)
    assert "lights" not in scene.describe()
    lit = dataclasses.replace(scene, background=0.0, lights=[rt.EnvMap(np.ones((2, 4, 3)))])
    other = dataclasses.replace(scene, background=0.0, lights=[rt.EnvMap(np.full((2, 4, 3), 2.0))])
    assert lit.content_hash() != other.content_hash() != scene.content_hash()
    assert lit.content_hash() == dataclasses.replace(lit).content_hash()


@pytest.mark.parametrize("strategy", BLIND_TO_DELTA_LIGHTS)
def test_strategies_blind_to_delta_lights_are_refused(strategy):
    scene = rt.Scene(_camera(), _shapes(), lights=[rt.PointLight((0, 3, 0), 5)])
    with pytest.raises(ValueError, match="cannot see the scene's delta lights"):
        rt.render(scene, spp=1, strategy=strategy)
    # the environment map alone is seen by every strategy
    rt.render(rt.Scene(_camera(), _shapes(), lights=[rt.EnvMap(np.ones((2, 4, 3)))]), spp=1, strategy=strategy)


def test_envmap_pixels_are_padded_and_alpha_dropped_as_mitsuba_does():
    env = rt.EnvMap(np.array([[1.0, 2.0]]))                    # 1 x 2 grey
    assert env.pixels.shape == (3, 2, 3) and env.pixels.dtype == np.float32
    np.testing.assert_array_equal(env.pixels[..., 0], [[1, 2], [1, 2], [1, 2]])
    rgba = np.concatenate([np.ones((4, 8, 3)), np.full((4, 8, 1), 0.25)], axis=2)
    np.testing.assert_array_equal(rt.EnvMap(rgba).pixels, np.ones((4, 8, 3), np.float32))
    assert not env.pixels.flags.writeable


# --------------------------------------------------------------------------- untrusted files
def _write_rgbe_flat(path, h, w, declared=None, body=None):
    dh, dw = declared or (h, w)
    head = f"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {dh} +X {dw}\n".encode()
    if body is None:
        body = np.tile(np.array([128, 64, 32, 129], np.uint8), h * w).tobytes()
    path.write_bytes(head + body)
    return path


def test_hdr_files_read_as_mitsuba_reads_them(tmp_path, mi):
    rng = np.random.default_rng(4)
    for w in (5, 40):   # 5: flat scanlines (too narrow for run-length encoding); 40: encoded
        img = (rng.uniform(0, 3, (6, w, 3)) ** 4).astype(np.float32)
        img[2, :] = 0.0                                   # a black run
        path = tmp_path / f"m{w}.hdr"
        mi.Bitmap(img).write(str(path))
        ours = rt.read_hdr(path)
        theirs = np.array(mi.Bitmap(str(path)), dtype=np.float32)
        assert ours.shape == theirs.shape == (6, w, 3)
        np.testing.assert_array_equal(ours, theirs)
        # RGBE keeps 8 bits of mantissa under the pixel's largest channel's exponent
        assert np.all(np.abs(ours - img) <= 2 ** -6 * img.max(axis=2, keepdims=True))


def test_untrusted_image_files_are_refused_before_decoding(tmp_path):
    # a header that declares far more pixels than the file holds or we read
    big = _write_rgbe_flat(tmp_path / "big.hdr", 1, 1, declared=(1 << 20, 1 << 20))
    with pytest.raises(ValueError, match="more than"):
        rt.EnvMap(big)
    short = _write_rgbe_flat(tmp_path / "short.hdr", 4, 4, body=b"\x01\x02")
    with pytest.raises(ValueError, match="truncated"):
        rt.EnvMap(short)
    bad_rle = _write_rgbe_flat(tmp_path / "rle.hdr", 2, 16, body=bytes([2, 2, 0, 16, 200, 1]))
    with pytest.raises(ValueError, match="run past"):
        rt.EnvMap(bad_rle)
    flipped = tmp_path / "flip.hdr"
    flipped.write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n+Y 2 +X 2\n" + bytes(16))
    with pytest.raises(ValueError, match="orientation"):
        rt.EnvMap(flipped)
    xyz = tmp_path / "xyz.hdr"
    xyz.write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n-Y 2 +X 2\n" + bytes(16))
    with pytest.raises(ValueError, match="xyze"):
        rt.EnvMap(xyz)
    not_rgbe = tmp_path / "x.hdr"
    not_rgbe.write_bytes(b"\x89PNG\r\n")
    with pytest.raises(ValueError, match="not a Radiance"):
        rt.EnvMap(not_rgbe)
    exr = tmp_path / "big.exr"
    rt.write_exr(exr, np.ones((4, 4, 3)))
    from reference_tracer import envmap

    old = envmap.MAX_ENVMAP_PIXELS
    envmap.MAX_ENVMAP_PIXELS = 8
    try:
        with pytest.raises(ValueError, match="more than"):
            rt.EnvMap(exr)
    finally:
        envmap.MAX_ENVMAP_PIXELS = old
    damaged = tmp_path / "damaged.exr"
    damaged.write_bytes(exr.read_bytes()[:60])
    with pytest.raises(ValueError, match="cannot be read|damaged"):
        rt.EnvMap(damaged)
    with pytest.raises(ValueError, match="only .exr"):
        rt.EnvMap(tmp_path / "sky.png")
    with pytest.raises(ValueError, match="cannot open"):
        rt.EnvMap(tmp_path / "missing.exr")
    (tmp_path / "folder.exr").mkdir()
    with pytest.raises(ValueError, match="not a regular file"):
        rt.EnvMap(tmp_path / "folder.exr")
    fifo = tmp_path / "fifo.hdr"
    os.mkfifo(fifo)
    with pytest.raises(ValueError, match="not a regular file"):
        rt.EnvMap(fifo)


def test_envmap_lookup_is_mitsubas(tmp_path, mi):
    """The radiance of escaping rays in many directions, through a rotated, scaled map read
    from OpenEXR, against Mitsuba's envmap eval of the same file (float32 there)."""
    img = _env_image(seed=2, shape=(7, 12))
    path = tmp_path / "env.exr"
    rt.write_exr(path, img)
    angle = math.radians(35)
    rot = np.array([[math.cos(angle), 0, math.sin(angle)], [0, 1, 0], [-math.sin(angle), 0, math.cos(angle)]])
    env = rt.EnvMap(path, scale=1.5, to_world=rot)
    assert env.source == path
    core = probe.core_scene(rt.Scene(_camera(), [], lights=[env]))
    d = np.random.default_rng(0).normal(size=(300, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    ours = core.background(np.ascontiguousarray(d))
    tw = np.eye(4)
    tw[:3, :3] = rot
    emitter = mi.load_dict({"type": "envmap", "filename": str(path), "scale": 1.5,
                            "to_world": mi.ScalarTransform4f(tw.tolist())})
    theirs = []
    for x, y, z in d:   # one direction at a time: the same code in scalar and JIT variants
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(-float(x), -float(y), -float(z))
        theirs.append(np.ravel(np.array(emitter.eval(si), dtype=np.float64))[:3])
    np.testing.assert_allclose(ours, np.array(theirs), rtol=2e-4, atol=1e-5)


# --------------------------------------------------------------------------- furnace and wavefront
@pytest.mark.parametrize("image", [np.full((1, 1, 3), 2.0), np.full((6, 10, 3), 2.0)], ids=["1x1", "6x10"])
def test_furnace_diffuse_sphere_in_a_constant_envmap(image):
    """Albedo 0.8 (then 1) inside a uniform map of radiance 2: a convex object receives the
    environment over its whole hemisphere, so every pixel on it is albedo * 2 at any depth.
    Every strategy; the sphere's pixels pooled, |z| <= 4 (cosine is exact: its weight is the
    albedo and every escaping ray sees 2)."""
    cam = rt.Camera(lookfrom=(0, 0, -4), lookat=(0, 0, 0), vfov=30, width=16, height=16)
    for albedo in (0.8, 1.0):
        scene = rt.Scene(cam, [rt.Sphere((0, 0, 0), 1.0, rt.Lambertian(albedo))], lights=[rt.EnvMap(image)])
        for strategy in rt.STRATEGIES:
            r = rt.render(scene, spp=512, strategy=strategy, seed=3, threads=2)
            inner = r.mean[4:12, 4:12, 0].astype(np.float64)
            se = math.sqrt(float(r.variance[4:12, 4:12, 0].sum()) / 512) / inner.size
            assert abs(inner.mean() - 2 * albedo) <= 4 * se + 1e-6 * albedo, (strategy, albedo, inner.mean(), se)
            assert np.all(r.mean[0, 0] == 2.0)                               # the map itself, seen directly


def _all_lights_scene(width=20, height=18, **kw):
    lights = [rt.EnvMap(_env_image(), scale=0.5, to_world=[[0.6, 0, 0.8], [0, 1, 0], [-0.8, 0, 0.6]]),
              rt.PointLight((1, 2.5, 1), (4, 3, 2)),
              rt.SpotLight((-1.5, 3, 1), (0.5, -1, -0.3), 20, cutoff_angle=30, beam_width=10),
              rt.DirectionalLight((-0.4, -1, -0.3), (1, 0.8, 0.6))]
    shapes = _shapes() + [rt.Mesh([(-1.5, 0.01, 1.0), (-0.5, 0.01, 1.5), (-1.0, 0.8, 1.2)], [[0, 1, 2]],
                                  rt.Plastic((0.3, 0.5, 0.7)), normals=[(0, 1, 0.3), (0.2, 1, 0), (0, 1, 0)])]
    return rt.Scene(_camera(width=width, height=height), shapes, lights=lights, **kw)


# delta lights: only the strategies that can see them (the others refuse such scenes, above)
@pytest.mark.parametrize("subset,strategy", [("envmap", s) for s in rt.STRATEGIES]
                         + [(subset, s) for subset in ("delta", "all") for s in ("mis", "light")])
def test_wavefront_equals_scalar_with_these_lights(subset, strategy):
    scene = _all_lights_scene()
    lights = {"envmap": scene.lights[:1], "delta": scene.lights[1:], "all": scene.lights}[subset]
    scene = dataclasses.replace(scene, lights=lights, max_depth=6, rr_depth=2)
    a, b = (rt.render(scene, spp=6, strategy=strategy, seed=11, threads=2, moments=True, integrator=i)
            for i in ("scalar", "wavefront"))
    assert np.array_equal(a.mean, b.mean) and np.array_equal(a.variance, b.variance) and a.rays == b.rays
    assert a.nonfinite_samples == 0 and a.mean.max() > 0


@pytest.mark.usefixtures("fresh_registries")
def test_a_sweep_refuses_blind_strategies_before_rendering(tmp_path, capsys):
    """``rtbench curves`` with a strategy that cannot see a scene's delta lights: one line,
    exit 2 (bad input), nothing rendered or written."""
    xml = tmp_path / "point.xml"
    xml.write_text(_scene_xml(_PATH, _EMITTERS["point"][1]))
    out = tmp_path / "store"
    code = main(["curves", "--scene", str(xml), "--strategies", "cosine,mis", "--spps", "1", "--seeds", "1",
                 "--width", "8", "--out", str(out), "--reference-spp", "16"])
    err = capsys.readouterr().err
    assert code == 2 and "strategies ['cosine'] cannot see the point, spot or directional lights" in err, err
    assert not out.exists()


def test_delta_lights_reach_every_strategy_that_samples_lights():
    """With direct light only (max_depth 2), ``light`` and ``mis`` estimate the same image."""
    scene = dataclasses.replace(_all_lights_scene(width=16, height=12), max_depth=2)
    a = rt.render(scene, spp=1024, strategy="mis", seed=1, threads=2)
    b = rt.render(scene, spp=1024, strategy="light", seed=2, threads=2)
    same = agreement(a, b)
    assert same.agrees, same.describe()


def test_point_light_over_a_plane_is_the_closed_form():
    """A Lambertian plane under a point light: L = albedo / pi * I cos / d^2 at every pixel
    (the camera looks straight down; each pixel's samples jitter over its footprint, so the
    pixel is the mean of that over the pixel, computed here by quadrature)."""
    albedo, intensity, height = 0.6, 5.0, 2.0
    cam = rt.Camera(lookfrom=(0, 4, 0), lookat=(0, 0, 0), vup=(0, 0, 1), vfov=20, width=4, height=4)
    scene = rt.Scene(cam, [rt.Quad((-5, 0, 5), (10, 0, 0), (0, 0, -10), rt.Lambertian(albedo))],
                     lights=[rt.PointLight((0.3, height, 0.1), intensity)], max_depth=2)
    r = rt.render(scene, spp=4096, strategy="mis", seed=0, threads=2)
    # the film point -> the plane point, as the pinhole camera maps it
    half = math.tan(math.radians(10))
    fwd, right, up = np.array([0, -1, 0.0]), np.cross([0, -1, 0.0], [0, 0, 1.0]), np.array([0, 0, 1.0])
    expected = np.zeros((4, 4))
    t = (np.arange(64) + 0.5) / 64
    for y in range(4):
        for x in range(4):
            sx = (2 * (x + t[:, None]) / 4 - 1) * half
            sy = (1 - 2 * (y + t[None, :]) / 4) * half
            d = fwd + sx[..., None] * right + sy[..., None] * up
            p = np.array([0, 4, 0]) + d * (4 / -d[..., 1:2])
            to = np.array([0.3, height, 0.1]) - p
            dist2 = (to ** 2).sum(-1)
            expected[y, x] = (albedo / math.pi * intensity * (to[..., 1] / np.sqrt(dist2)) / dist2).mean()
    z = (r.mean[..., 0] - expected) / np.sqrt(r.variance[..., 0] / 4096)
    assert np.all(np.abs(z) <= 4), z
    np.testing.assert_allclose(r.mean[..., 0], expected, rtol=3e-3)
    for light in (rt.DirectionalLight((0, -1, 0), 2.0),):   # a directional light: albedo / pi * E
        s = dataclasses.replace(scene, lights=[light])
        np.testing.assert_allclose(rt.render(s, spp=4, strategy="light", seed=0).mean, albedo / math.pi * 2.0,
                                   rtol=1e-7)   # float32 images


def test_direct_integrator_reproduces_mitsubas_delta_light_weighting():
    """Mitsuba 3.9.1's ``direct`` adds each delta light's sample without dividing it by
    ``emitter_samples``: with n of them a point light counts n times. Reproduced (and
    documented); area lights and the environment are averaged as they should be."""
    base = rt.Scene(_camera(width=8, height=6), _shapes()[:2], lights=[rt.PointLight((1, 2.5, 1), 4)],
                    direct=rt.Direct(1, 0))
    one = rt.render(base, spp=2048, strategy="mis", seed=1, threads=2)
    three = rt.render(dataclasses.replace(base, direct=rt.Direct(3, 0)), spp=2048, strategy="mis", seed=2, threads=2)
    tripled = rt.ImageEstimate(mean=3 * one.mean, variance=9 * one.variance, spp=one.spp)
    assert agreement(three, tripled).agrees and not agreement(three, one).agrees
    env = dataclasses.replace(base, lights=[rt.EnvMap(np.ones((2, 4, 3)))])
    e1 = rt.render(env, spp=2048, strategy="mis", seed=1, threads=2)
    e3 = rt.render(dataclasses.replace(env, direct=rt.Direct(3, 0)), spp=2048, strategy="mis", seed=2, threads=2)
    assert agreement(e1, e3).agrees


# --------------------------------------------------------------------------- agreement with Mitsuba
def _scene_xml(integrator: str, emitters: str) -> str:
    """A floor, a diffuse ball and a rough metal one, lit by ``emitters`` alone."""
    return scene_xml(diffuse_floor(4) + """\
    <shape type="sphere"><point name="center" x="-0.6" y="0.6" z="0"/><float name="radius" value="0.6"/>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.8"/></bsdf></shape>
    <shape type="sphere"><point name="center" x="0.8" y="0.5" z="0.4"/><float name="radius" value="0.5"/>
        <bsdf type="roughconductor"><float name="alpha" value="0.2"/></bsdf></shape>
    """ + emitters, integrator='<default name="integrator" value="path"/>' + integrator, fov=45,
                     origin="0, 3, 5", target="0, 0.5, 0", width=32, height=24)


_PATH = path_integrator(4)
_ENVMAP = """<emitter type="envmap"><string name="filename" value="{file}"/><float name="scale" value="0.8"/>
        <transform name="to_world"><rotate y="1" angle="70"/><rotate x="1" angle="20"/></transform></emitter>"""
_EMITTERS = {
    "envmap_exr": (_PATH, _ENVMAP.format(file="env.exr")),
    "envmap_hdr": (_PATH, _ENVMAP.format(file="env.hdr")),
    "point": (_PATH, '<emitter type="point"><point name="position" x="1" y="2.5" z="1"/>'
                     '<rgb name="intensity" value="10, 8, 6"/></emitter>'),
    "spot": (_PATH, """<emitter type="spot"><rgb name="intensity" value="30, 20, 10"/>
        <float name="cutoff_angle" value="35"/><float name="beam_width" value="15"/>
        <transform name="to_world"><lookat origin="1.5, 3, 1" target="-0.3, 0, -0.2" up="0, 1, 0"/></transform></emitter>"""),
    "spot_defaults_scaled": (_PATH, """<emitter type="spot"><rgb name="intensity" value="30, 20, 10"/>
        <transform name="to_world"><lookat origin="1.5, 3, 1" target="-0.3, 0, -0.2" up="0, 1, 0"/>
        <scale value="2"/></transform></emitter>"""),
    "directional_constant": (_PATH, """<emitter type="directional"><vector name="direction" x="-0.4" y="-1" z="-0.3"/>
        <rgb name="irradiance" value="2, 1.5, 1"/></emitter>
        <emitter type="constant"><rgb name="radiance" value="0.1, 0.1, 0.2"/></emitter>"""),
    "direct_delta_envmap": ('<integrator type="direct"><integer name="emitter_samples" value="2"/>'
                            '<integer name="bsdf_samples" value="1"/></integrator>',
                            _ENVMAP.format(file="env.exr") + """
        <emitter type="directional"><rgb name="irradiance" value="2, 1.5, 1"/>
            <transform name="to_world"><rotate x="1" angle="120"/><rotate y="1" angle="30"/></transform></emitter>
        <emitter type="point"><point name="position" x="-1" y="1.5" z="1.5"/><rgb name="intensity" value="2"/></emitter>"""),
}


@pytest.mark.parametrize("name", sorted(_EMITTERS))
def test_lights_agree_with_mitsuba(tmp_path, mi, name):
    img = _env_image()
    rt.write_exr(tmp_path / "env.exr", img)
    mi.Bitmap(img).write(str(tmp_path / "env.hdr"))
    integrator, emitters = _EMITTERS[name]
    xml = tmp_path / "scene.xml"
    xml.write_text(_scene_xml(integrator, emitters))
    scene = from_mitsuba(xml)
    assert len(scene.lights) >= 1
    mit = render_mitsuba(xml, spp=SPP, seed=1, batches=16, threads=2)
    # the direct integrator's `light`: its emitter samples alone (Mitsuba's bsdf_samples=0 there, but
    # in expectation the same image); the path integrator's is direct light only, biased on purpose
    for strategy in ("mis", "light") if scene.direct is not None else ("mis",):
        ours = rt.render(scene, spp=SPP, strategy=strategy, seed=1, threads=2)
        a = agreement(ours, mit, pixel_filter=scene.camera.filter)
        assert a.agrees, (strategy, a.describe())


def test_mitsubas_hello_scene_agrees():
    """Mitsuba's own ``scenes/hello.xml`` (mitsuba-data; tests/fixtures/published/SOURCES.md):
    the ``direct`` integrator with 4 emitter samples and no BSDF samples, two point lights, a
    teapot PLY without normals (Mitsuba's computed vertex normals shade it smooth), a sensor without ``fov`` (Mitsuba's 50 mm default),
    imported unmodified at a small film."""
    path = PUBLISHED / "mitsuba" / "scenes" / "hello.xml"
    scene = from_mitsuba(path, film_size=(32, 24))
    assert scene.direct == rt.Direct(4, 0) and len(scene.delta_lights) == 2
    ours = rt.render(scene, spp=SPP, strategy="mis", seed=1, threads=2)
    mit = render_mitsuba(path, spp=SPP, seed=1, batches=16, threads=2, film_size=(32, 24))
    a = agreement(ours, mit, pixel_filter=scene.camera.filter)
    assert a.agrees, a.describe()


def test_translated_lights_agree_with_mitsuba():
    scene = _all_lights_scene(width=24, height=18, max_depth=4)
    ours = rt.render(scene, spp=SPP, strategy="mis", seed=1, threads=2)
    mit = render_mitsuba(scene, spp=SPP, seed=1, batches=16, threads=2)
    a = agreement(ours, mit)
    assert a.agrees, a.describe()


@pytest.mark.usefixtures("fresh_registries")
def test_first_hit_aovs_agree_with_mitsuba_under_an_envmap():
    """``rtbench parity``'s check: what a camera ray that escapes sees (the map, rotated and
    scaled) and every first hit, ours against Mitsuba's at each pixel centre."""
    report = run_parity(_all_lights_scene(width=24, height=18), name="lights")
    assert report.passed, (report.summary(), report.findings)


# --------------------------------------------------------------------------- import and translation
def test_lights_round_trip_through_xml(tmp_path):
    scene = _all_lights_scene()
    path = to_xml(scene, tmp_path / "s.xml")
    assert (tmp_path / "s_light_000.exr").is_file()
    back = from_mitsuba(path)
    assert [type(x) for x in back.lights] == [type(x) for x in scene.lights]
    env, env_back = scene.lights[0], back.lights[0]
    np.testing.assert_array_equal(env.pixels, env_back.pixels)
    np.testing.assert_allclose(env.to_world, env_back.to_world, atol=1e-6)
    assert env_back.scale == pytest.approx(env.scale)
    for a, b in zip(scene.lights[1:], back.lights[1:]):
        for key, value in a.describe().items():
            np.testing.assert_allclose(np.asarray(b.describe()[key], dtype=float) if key != "type" else 0,
                                       np.asarray(value, dtype=float) if key != "type" else 0, rtol=1e-6, atol=1e-7)
    d = to_mitsuba(dataclasses.replace(scene, shapes=scene.shapes[:3]))   # (no mesh: the dict's meshes are objects)
    assert {v["type"] for k, v in d.items() if k.startswith("light_")} == {"envmap", "point", "spot", "directional"}
    np.testing.assert_array_equal(from_mitsuba(d).lights[0].pixels, env.pixels)   # the dict's bitmap, read back


def test_import_reads_emitter_parameters(tmp_path):
    rt.write_exr(tmp_path / "sky.exr", _env_image(shape=(4, 8)))
    xml = tmp_path / "s.xml"
    xml.write_text(_scene_xml(_PATH, """
        <emitter type="envmap"><string name="filename" value="sky.exr"/><boolean name="mis_compensation" value="true"/>
            <float name="sampling_weight" value="2"/></emitter>
        <emitter type="point"><transform name="to_world"><translate x="1" y="2" z="3"/></transform></emitter>
        <emitter type="spot"><float name="cutoff_angle" value="40"/>
            <transform name="to_world"><lookat origin="0, 3, 0" target="0, 0, 0" up="0, 0, 1"/></transform></emitter>
        <emitter type="directional"><vector name="direction" x="0" y="-2" z="0"/></emitter>"""))
    scene = from_mitsuba(xml)
    env, point, spot, sun = scene.lights
    assert env.pixels.shape == (4, 8, 3) and env.scale == 1.0 and env.to_world == ((1, 0, 0), (0, 1, 0), (0, 0, 1))
    assert point == rt.PointLight((1, 2, 3), 1.0)
    assert spot.position == (0, 3, 0) and spot.direction == pytest.approx((0, -1, 0))
    assert spot.cutoff_angle == 40 and spot.beam_width == 30 and spot.intensity == (1, 1, 1)
    assert sun == rt.DirectionalLight((0, -1, 0), 1.0)


@pytest.mark.parametrize("emitters,needle", [
    ('<emitter type="projector"><transform name="to_world"><scale x="2"/></transform></emitter>',
     "not a similarity"),
    ('<emitter type="spot"><rgb name="texture" value="0.5"/></emitter>', "spot texture"),
    ('<emitter type="envmap"><string name="filename" value="nowhere.exr"/></emitter>', "envmap: EnvMap: cannot open"),
    ('<emitter type="envmap"><string name="filename" value="sky.png"/></emitter>', "only .exr"),
    ('<emitter type="envmap"><string name="filename" value="sky.exr"/>'
     '<transform name="to_world"><scale x="2"/></transform></emitter>', "rotation"),
    ('<emitter type="envmap"><string name="filename" value="sky.exr"/></emitter>'
     '<emitter type="constant"/>', "a second environment emitter"),
    ('<emitter type="spot"><transform name="to_world"><scale x="2"/></transform></emitter>', "not a similarity"),
    ('<emitter type="directional"><transform name="to_world"><scale z="3"/></transform></emitter>', "scales its +z"),
    ('<emitter type="point"><point name="position" x="0" y="1" z="0"/><float name="radius" value="1"/></emitter>',
     "parameter 'radius'"),
    ('<emitter type="spot"><float name="cutoff_angle" value="10"/><float name="beam_width" value="20"/></emitter>',
     "SpotLight.beam_width"),
    ('<emitter type="envmap"><string name="filename" value="nan.exr"/></emitter>', "must be finite (no NaN"),
    ('<emitter type="envmap"><string name="filename" value="sky.exr"/><float name="scale" value="-1"/></emitter>',
     "EnvMap.scale must be >= 0"),
    ('<emitter type="envmap"><string name="filename" value="sky.exr"/><float name="scale" value="nan"/></emitter>',
     "EnvMap.scale must be finite"),
    ('<emitter type="envmap"><string name="filename" value="sky.exr"/></emitter>'
     '<emitter type="envmap"><string name="filename" value="sky.exr"/></emitter>', "envmap after envmap"),
    ('<emitter type="point"><rgb name="intensity" value="nan"/></emitter>', "PointLight.intensity must be finite"),
    ('<emitter type="spot"><float name="cutoff_angle" value="nan"/></emitter>', "SpotLight.cutoff_angle"),
    ('<emitter type="directional"><vector name="direction" x="0" y="0" z="0"/></emitter>', "non-zero vector"),
])
def test_import_refuses_what_it_does_not_model_with_file_and_line(tmp_path, mi, emitters, needle):
    rt.write_exr(tmp_path / "sky.exr", _env_image(shape=(4, 8)))
    bad = _env_image(shape=(4, 8))
    bad[1, 2, 0] = np.nan
    mi.Bitmap(bad).write(str(tmp_path / "nan.exr"))   # our writer refuses NaN; Mitsuba's does not
    xml = tmp_path / "s.xml"
    xml.write_text(_scene_xml(_PATH, emitters))
    with pytest.raises(ValueError) as err:
        from_mitsuba(xml)
    msg = str(err.value)
    assert needle in msg and f"{xml} (line" in msg, msg


@pytest.mark.parametrize("channels", [2, 5])
def test_import_refuses_a_dict_bitmap_of_the_wrong_shape(mi, channels):
    d = {"type": "scene", "sensor": {"type": "perspective"},
         "sky": {"type": "envmap", "bitmap": mi.Bitmap(np.ones((4, 8, channels), np.float32))}}
    with pytest.raises(ValueError, match=r"got shape \(4, 8, %d\) \(dictionary node \"sky\"\)" % channels):
        from_mitsuba(d)


def test_sensor_without_fov_takes_mitsubas_focal_length(mi, tmp_path):
    """No ``fov``: Mitsuba's 50 mm focal length on a 36 x 24 mm film, a diagonal field of view
    (``parse_fov``); ``focal_length`` sets another."""
    for extra, size in (("", (32, 24)), ('<string name="focal_length" value="28mm"/>', (20, 30))):
        xml = tmp_path / "cam.xml"
        xml.write_text(f"""<scene version="3.0.0"><sensor type="perspective">{extra}
            <film type="hdrfilm"><integer name="width" value="{size[0]}"/><integer name="height" value="{size[1]}"/>
            </film></sensor><shape type="sphere"/></scene>""")
        ours = from_mitsuba(xml).camera.vfov
        x_fov = float(np.ravel(mi.traverse(mi.load_file(str(xml)).sensors()[0])["x_fov"])[0])
        expected = math.degrees(2 * math.atan(math.tan(math.radians(x_fov) / 2) * size[1] / size[0]))
        assert ours == pytest.approx(expected, rel=1e-5)
