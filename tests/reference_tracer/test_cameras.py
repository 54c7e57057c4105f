"""Mitsuba's ``thinlens`` and ``orthographic`` sensors (``Camera(aperture_radius=...,
focus_distance=...)``, ``Camera(projection="orthographic", view_height=...)``, clip planes).

Checked against ``mi.load_file`` of the same XML with the published scenes' agreement screen
(``benchmarks.gate.agreement``), the wavefront integrator against the scalar one bit for
bit, the pinhole's arguments and hashes against what they were before the options, and the
importer and translation against each other."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import reference_tracer as rt
from benchmarks.gate.agreement import agreement
from mitsuba_scenes import from_mitsuba, get_scene, render_mitsuba, to_mitsuba, to_xml
from reference_tracer import probe

_ROOM = """
    <integrator type="path"><integer name="max_depth" value="4"/></integrator>
    <shape type="rectangle"><transform name="to_world"><scale value="4"/><rotate x="1" angle="-90"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.6, 0.5"/></bsdf></shape>
    <shape type="rectangle"><transform name="to_world"><rotate x="1" angle="90"/><translate y="3.5"/></transform>
        <emitter type="area"><rgb name="radiance" value="5"/></emitter></shape>
    <emitter type="constant"><rgb name="radiance" value="0.2"/></emitter>
"""


def _sphere(x, y, z, r, rgb):
    return (f'<shape type="sphere"><point name="center" value="{x}, {y}, {z}"/><float name="radius" value="{r}"/>'
            f'<bsdf type="diffuse"><rgb name="reflectance" value="{rgb}"/></bsdf></shape>')


def _thinlens_xml(tmp_path):
    """Spheres before, on and behind the plane in focus (distance 6 from the lens)."""
    xml = tmp_path / "thinlens.xml"
    xml.write_text(f"""<scene version="3.0.0">{_ROOM}
    <sensor type="thinlens"><float name="fov" value="40"/>
        <float name="aperture_radius" value="0.3"/><float name="focus_distance" value="6"/>
        <transform name="to_world"><lookat origin="0.5, 1.5, 6" target="0, 0.6, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="40"/><integer name="height" value="30"/>
            <rfilter type="box"/></film></sensor>
    {_sphere(-0.8, 0.5, 3, 0.5, "0.2, 0.5, 0.8")}
    {_sphere(0.3, 0.6, 0, 0.6, "0.8, 0.3, 0.2")}
    {_sphere(1.5, 0.8, -3, 0.8, "0.3, 0.8, 0.3")}
</scene>""")
    return xml


def _orthographic_xml(tmp_path):
    """A tilted view of a non-square film, 2 x 2.5 scaled (non-square pixels); one sphere lies
    before the near plane (unseen, but it shadows the floor), the far plane cuts the floor."""
    xml = tmp_path / "orthographic.xml"
    xml.write_text(f"""<scene version="3.0.0">{_ROOM}
    <sensor type="orthographic">
        <float name="near_clip" value="4"/><float name="far_clip" value="10"/>
        <transform name="to_world"><scale x="2" y="2.5"/>
            <lookat origin="1, 4, 6" target="0, 0.4, 0" up="0.2, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="40"/><integer name="height" value="24"/>
            <rfilter type="tent"/></film></sensor>
    {_sphere(0.6, 2.5, 3.5, 0.5, "0.2, 0.5, 0.8")}
    {_sphere(0, 0.6, 0, 0.6, "0.8, 0.3, 0.2")}
    {_sphere(-1.2, 0.5, -1.0, 0.5, "0.3, 0.8, 0.3")}
</scene>""")
    return xml


@pytest.mark.parametrize("make_xml", [_thinlens_xml, _orthographic_xml], ids=["thinlens", "orthographic"])
def test_agrees_with_mitsuba(tmp_path, make_xml):
    xml = make_xml(tmp_path)
    scene = from_mitsuba(xml)
    ours = rt.render(scene, spp=4096, strategy="mis", seed=1, threads=2)
    mit = render_mitsuba(xml, spp=4096, seed=1, batches=16, threads=2)
    a = agreement(ours, mit, pixel_filter=scene.camera.filter)
    assert a.agrees, a.describe()


def test_the_imported_cameras_are_what_the_files_say(tmp_path):
    lens = from_mitsuba(_thinlens_xml(tmp_path)).camera
    assert lens.is_thin_lens and lens.aperture_radius == pytest.approx(0.3) and lens.focus_distance == 6.0
    assert (lens.near_clip, lens.far_clip) == (pytest.approx(0.01), 1e4)  # Mitsuba's defaults
    ortho = from_mitsuba(_orthographic_xml(tmp_path)).camera
    assert ortho.is_orthographic and ortho.vfov is None
    # x: 2 * scale x; y: 2 * scale y / aspect
    assert ortho.view_size == pytest.approx((4.0, 2 * 2.5 / (40 / 24)), rel=1e-6)
    assert ortho.near_clip == pytest.approx(4.0, rel=1e-6) and ortho.far_clip == pytest.approx(10.0, rel=1e-6)


def test_out_of_focus_is_blurred_and_in_focus_is_sharp():
    # A thin lens blurs a sphere in front of the plane in focus; a sphere on it stays as the
    # pinhole sees it (the mean image is the pinhole's where everything is in focus).
    white = rt.Lambertian(0.8)
    shapes = [rt.Sphere((0, 0, 0), 0.5, white)]
    pin = rt.Camera(lookfrom=(0, 0, -5), lookat=(0, 0, 0), vfov=20, width=24, height=24)
    sharp = dataclasses.replace(pin, aperture_radius=0.2, focus_distance=4.5)  # the sphere's near face
    blurred = dataclasses.replace(pin, aperture_radius=0.2, focus_distance=1.0)
    imgs = {k: rt.render(rt.Scene(c, shapes, max_depth=1, background=1.0), spp=256, seed=2, threads=2).mean
            for k, c in (("pin", pin), ("sharp", sharp), ("blurred", blurred))}
    edge = lambda im: np.abs(np.diff(im[..., 0], axis=1)).max()  # noqa: E731
    # (seen: pinhole 0.85, in focus 0.80, out of focus 0.14)
    assert edge(imgs["pin"]) > 0.7 and edge(imgs["sharp"]) > 0.6 and edge(imgs["blurred"]) < 0.3


def _scenes():
    base = get_scene("cornell_box", width=20, height=14)
    c = base.camera
    lens = dataclasses.replace(c, aperture_radius=30.0, focus_distance=900.0)
    ortho = rt.Camera((200, 300, -800), (278, 278, 0), (0.1, 1, 0), width=20, height=14,
                      projection="orthographic", view_height=450.0, view_width=500.0, near_clip=500.0,
                      far_clip=1700.0)
    clipped = dataclasses.replace(c, near_clip=850.0, far_clip=1300.0)
    return {k: dataclasses.replace(base, camera=cam) for k, cam in
            (("thinlens", lens), ("orthographic", ortho), ("clipped_pinhole", clipped))}


@pytest.mark.parametrize("strategy", ["uniform", "cosine", "light", "mixture", "mis"])
@pytest.mark.parametrize("name", ["thinlens", "orthographic", "clipped_pinhole"])
def test_wavefront_equals_scalar(name, strategy):
    scene = _scenes()[name]
    a, b = (rt.render(scene, spp=6, strategy=strategy, seed=7, threads=2, integrator=i)
            for i in ("scalar", "wavefront"))
    assert np.array_equal(a.mean, b.mean) and np.array_equal(a.variance, b.variance)
    assert a.rays == b.rays


def test_wavefront_equals_scalar_with_the_direct_integrator():
    scene = dataclasses.replace(_scenes()["thinlens"], direct=rt.Direct(1, 1))
    a, b = (rt.render(scene, spp=4, strategy="mis", seed=3, threads=2, integrator=i) for i in ("scalar", "wavefront"))
    assert np.array_equal(a.mean, b.mean)


def test_the_pinhole_is_unchanged():
    # A pinhole scene keeps its content hash (cached references stay valid). Its images: the
    # wavefront and regression tests compare them, and this build's equalled the one before
    # the options bit for bit (cornell_box and glossy_plates, both integrators, mis and cosine).
    scene = get_scene("cornell_box", width=48, height=36)
    assert scene.camera.is_pinhole
    assert scene.content_hash() == "7fc7faabe5a0782d" + scene.content_hash()[16:]
    assert set(scene.describe()["camera"]) == {"lookfrom", "lookat", "vup", "vfov", "width", "height"}
    assert scene.camera.vfov == 40.0 and rt.Camera((0, 0, -1), (0, 0, 0)).vfov == 40.0
    # an option at its default is the same camera and the same hash
    same = dataclasses.replace(scene.camera, aperture_radius=0.0, near_clip=0.0, far_clip=math.inf)
    assert same == scene.camera and dataclasses.replace(scene, camera=same).content_hash() == scene.content_hash()


def test_options_change_the_hash():
    hashes = {k: s.content_hash() for k, s in _scenes().items()}
    hashes["pinhole"] = get_scene("cornell_box", width=20, height=14).content_hash()
    assert len(set(hashes.values())) == 4
    cam = rt.Camera((0, 0, -5), (0, 0, 0), width=4, height=4, projection="orthographic", view_height=2.0)
    assert cam.with_size(8, 4).view_size == (4.0, 2.0)  # the width follows the aspect


def test_far_clip_cuts_and_near_clip_hides():
    # A black sphere at distance 4-6 in front of a background of radiance 1: far_clip 3 sees
    # only the background, and so does near_clip 7 (rays start behind the sphere).
    shapes = [rt.Sphere((0, 0, 0), 1.0, rt.Lambertian(0.5))]
    base = rt.Camera((0, 0, -5), (0, 0, 0), vfov=5, width=4, height=4)
    for cam, expected in ((base, 0.0), (dataclasses.replace(base, far_clip=3.0), 1.0),
                          (dataclasses.replace(base, near_clip=7.0), 1.0)):
        img = rt.render(rt.Scene(cam, shapes, max_depth=1, background=1.0), spp=8, seed=1, threads=1).mean
        assert np.allclose(img, expected), (cam, img.mean())
    ortho = rt.Camera((0, 0, -5), (0, 0, 0), width=4, height=4, projection="orthographic", view_height=0.2,
                      far_clip=3.9)
    aovs = probe.first_hit_aovs(rt.Scene(ortho, shapes))
    assert np.isinf(aovs["t"]).all()
    aovs = probe.first_hit_aovs(rt.Scene(dataclasses.replace(ortho, far_clip=4.1), shapes))
    assert np.isfinite(aovs["t"]).all() and np.allclose(aovs["t"], 4.0, atol=0.01)


def test_probe_rays_match_the_renders():
    # An orthographic camera's first hits through the probe equal a render's at one sample
    # per pixel of a scene whose colour is the hit's (an emitter seen directly).
    cam = rt.Camera((0.3, 0.2, -5), (0, 0, 0), (0.1, 1, 0), width=8, height=6, projection="orthographic",
                    view_height=3.0, near_clip=1.0)
    shapes = [rt.Sphere((0, 0, 0), 1.0, rt.DiffuseLight(2.0))]
    aovs = probe.first_hit_aovs(rt.Scene(cam, shapes))
    hit = np.isfinite(aovs["t"])
    assert 0 < hit.sum() < hit.size
    lens = dataclasses.replace(rt.Camera((0, 0, -5), (0, 0, 0), width=4, height=4), aperture_radius=0.1,
                               focus_distance=5.0)
    with pytest.raises(ValueError, match="thin lens"):
        probe.first_hit_aovs(rt.Scene(lens, shapes))
    with pytest.raises(ValueError, match="lens"):
        probe.camera_rays(lens, [1.0], [1.0])
    o, d = probe.camera_rays(lens, [2.0], [2.0], lens=[[0.5, 0.5]])  # the aperture's centre
    assert np.allclose(o, [[0, 0, -5]]) and np.allclose(d, [[0, 0, 1]])
    o, d = probe.camera_rays(lens, [2.0, 2.0], [2.0, 2.0], lens=[[1.0, 0.5], [0.5, 0.0]])
    assert np.allclose(np.linalg.norm(o - [0, 0, -5], axis=1), 0.1)  # the aperture's rim
    assert np.allclose(o + 5.0 / d[:, 2:] * d, [[0, 0, 0]] * 2)  # through the point in focus


@pytest.mark.parametrize("kwargs, match", [
    (dict(aperture_radius=-0.1, focus_distance=1.0), "aperture_radius"),
    (dict(aperture_radius=float("nan"), focus_distance=1.0), "aperture_radius"),
    (dict(aperture_radius=0.1), "needs focus_distance"),
    (dict(aperture_radius=0.1, focus_distance=0.0), "focus_distance"),
    (dict(aperture_radius=0.1, focus_distance=float("nan")), "focus_distance"),
    (dict(aperture_radius=0.1, focus_distance=-2.0), "focus_distance"),
    (dict(aperture_radius=0.1, focus_distance=math.inf), "focus_distance"),
    (dict(focus_distance=2.0), "thin lens"),
    (dict(projection="fisheye"), "projection"),
    (dict(projection=None), "projection"),
    (dict(projection="orthographic"), "needs view_height"),
    (dict(projection="orthographic", view_height=0.0), "view_height"),
    (dict(projection="orthographic", view_height=1.0, view_width=-1.0), "view_width"),
    (dict(projection="orthographic", view_height=1.0, vfov=30.0), "vfov"),
    (dict(projection="orthographic", view_height=1.0, aperture_radius=0.1, focus_distance=1.0), "no lens"),
    (dict(view_height=1.0), "orthographic"),
    (dict(near_clip=-1.0), "near_clip"),
    (dict(near_clip=math.inf), "near_clip"),
    (dict(far_clip=float("nan")), "far_clip"),
    (dict(near_clip=2.0, far_clip=2.0), "far_clip"),
    (dict(far_clip="far"), "far_clip"),
])
def test_bad_input_is_refused(kwargs, match):
    kwargs = {"lookfrom": (0, 0, -5), "lookat": (0, 0, 0), "width": 4, "height": 4, **kwargs}
    with pytest.raises(ValueError, match=match):
        rt.Camera(**kwargs)


def test_the_core_refuses_bad_cameras_too():
    # Cameras that slipped past validation (fields set behind its back) reach the core's own checks.
    scene = get_scene("cornell_box", width=4, height=4)
    for bad in (dict(aperture_radius=-1.0, near_clip=0.5),
                dict(aperture_radius=1.0, focus_distance=0.0),
                dict(near_clip=2.0, far_clip=1.0)):
        cam = dataclasses.replace(scene.camera)
        for k, v in bad.items():
            object.__setattr__(cam, k, v)
        with pytest.raises(ValueError):
            probe.core_scene(dataclasses.replace(scene, camera=cam), cached=False)


@pytest.mark.parametrize("name", ["thinlens", "orthographic", "clipped_pinhole"])
def test_translation_round_trip(tmp_path, name):
    scene = _scenes()[name]
    xml = to_xml(scene, tmp_path / "s.xml")
    back = from_mitsuba(xml).camera
    c = scene.camera
    assert back.projection == c.projection and back.width == c.width and back.height == c.height
    np.testing.assert_allclose(back.lookfrom, c.lookfrom, rtol=1e-6)
    np.testing.assert_allclose(back.basis(), c.basis(), atol=1e-6)
    assert back.aperture_radius == pytest.approx(c.aperture_radius, rel=1e-6)
    if c.near_clip == 0.0:  # Mitsuba needs near_clip > 0: one far below any feature
        assert 0 < back.near_clip < 1e-3 and back.far_clip > 4000
    else:
        assert back.near_clip == pytest.approx(c.near_clip, rel=1e-6)
        assert back.far_clip == pytest.approx(c.far_clip, rel=1e-6)
    if c.is_orthographic:
        assert back.view_size == pytest.approx(c.view_size, rel=1e-6)
    else:
        assert back.vfov == pytest.approx(c.vfov, rel=1e-6)
        assert back.focus_distance == (None if c.focus_distance is None else
                                       pytest.approx(c.focus_distance, rel=1e-6))
    d = to_mitsuba(scene, variant="scalar_rgb")["sensor"]
    assert d["type"] == {"thinlens": "thinlens", "orthographic": "orthographic"}.get(name, "perspective")


def test_translation_without_clip_planes_clips_nothing():
    lens = dataclasses.replace(_scenes()["thinlens"], camera=dataclasses.replace(
        _scenes()["thinlens"].camera, near_clip=0.0, far_clip=math.inf))
    d = to_mitsuba(lens, variant="scalar_rgb")["sensor"]
    assert d["near_clip"] < 1e-3 and d["far_clip"] > 4000 and d["aperture_radius"] == 30.0


def _sensor_xml(tmp_path, sensor_body, kind="orthographic"):
    xml = tmp_path / "s.xml"
    xml.write_text(f'<scene version="3.0.0"><shape type="sphere"/><sensor type="{kind}">{sensor_body}'
                   '<film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="4"/>'
                   '<rfilter type="box"/></film></sensor></scene>')
    return xml


def test_importer_reads_mitsuba_defaults(tmp_path):
    cam = from_mitsuba(_sensor_xml(tmp_path, "")).camera  # identity to_world
    assert cam.view_size == pytest.approx((2.0, 1.0)) and cam.near_clip == pytest.approx(0.01)
    assert cam.far_clip == pytest.approx(1e4) and np.allclose(cam.basis()[0], [0, 0, 1])
    lens = from_mitsuba(_sensor_xml(tmp_path, '<float name="aperture_radius" value="0.5"/>', "thinlens")).camera
    assert lens.focus_distance == pytest.approx(1e4)  # Mitsuba's default: far_clip
    # a zero aperture is Mitsuba's float epsilon: a pinhole, whose default planes clip nothing
    # of this scene (the camera sits inside the unit sphere): the plain pinhole
    pin = from_mitsuba(_sensor_xml(tmp_path, '<float name="aperture_radius" value="0"/>', "thinlens")).camera
    assert pin.is_pinhole
    cam = from_mitsuba(_sensor_xml(tmp_path, "", "perspective")).camera  # and its hash has no planes either
    assert cam.is_pinhole and set(cam.describe()) == {"lookfrom", "lookat", "vup", "vfov", "width", "height"}


def _clip_xml(tmp_path, sensor_body, shape, kind="perspective"):
    """An 8 x 4 camera at the origin looking down +z (fov 90 along x) and one shape."""
    xml = tmp_path / "clip.xml"
    xml.write_text(f'<scene version="3.0.0">{shape}<sensor type="{kind}"><float name="fov" value="90"/>'
                   f'{sensor_body}<transform name="to_world"><lookat origin="0, 0, 0" target="0, 0, 1" '
                   'up="0, 1, 0"/></transform><film type="hdrfilm"><integer name="width" value="8"/>'
                   '<integer name="height" value="4"/><rfilter type="box"/></film></sensor></scene>')
    return xml


def _rect(z, scale=1.0):
    """A rectangle facing the camera at depth ``z``, ``2 scale`` wide."""
    return (f'<shape type="rectangle"><transform name="to_world"><scale value="{scale}"/>'
            f'<translate z="{z}"/></transform></shape>')


@pytest.mark.parametrize("sensor_body, shape, near, far", [
    # Mitsuba's defaults (0.01, 10^4) clip nothing here: the plain pinhole (the core's fast path)
    ("", _rect(3.0), 0.0, math.inf),
    # planes given in the file that clip nothing are dropped as well
    ('<float name="near_clip" value="1"/><float name="far_clip" value="100"/>', _rect(3.0), 0.0, math.inf),
    # the default near plane hides a surface nearer than 0.01: it is kept (and so is no far plane)
    ("", _rect(0.005, 0.01), 0.01, math.inf),
    # ... and one off the view's axis, before the near plane and in view, farther than 0.01 from
    # the eye (0.0124) but within the frustum's corner distance (0.01 sqrt(1 + 1 + 1/4) = 0.015)
    ("", '<shape type="sphere"><point name="center" x="0.0085" y="0" z="0.009"/><float name="radius" '
         'value="1e-5"/></shape>', 0.01, math.inf),
    # a surface beyond the default far plane keeps it
    ("", _rect(2e4, 1e4), 0.0, 1e4),
    # a near plane that cuts the rectangle, a far plane that cuts nothing
    ('<float name="near_clip" value="5"/><float name="far_clip" value="50"/>', _rect(3.0), 5.0, math.inf),
])
def test_importer_keeps_a_pinholes_clip_planes_only_where_they_clip(tmp_path, sensor_body, shape, near, far):
    cam = from_mitsuba(_clip_xml(tmp_path, sensor_body, shape)).camera
    assert cam.near_clip == pytest.approx(near, rel=1e-6) and cam.far_clip == pytest.approx(far, rel=1e-6)
    assert cam.is_pinhole == (near == 0.0 and far == math.inf)


def test_importer_keeps_the_clip_planes_of_a_thin_lens(tmp_path):
    # a thin lens is never the plain pinhole: its planes stay what the file says
    lens = from_mitsuba(_clip_xml(tmp_path, '<float name="aperture_radius" value="0.1"/>', _rect(3.0),
                                  "thinlens")).camera
    assert lens.near_clip == pytest.approx(0.01) and lens.far_clip == pytest.approx(1e4)


@pytest.mark.parametrize("body, kind, match", [
    ('<float name="fov" value="30"/>', "orthographic", "orthographic' parameter 'fov'"),
    ('<transform name="to_world"><matrix value="1 0.5 0 0 0 1 0 0 0 0 1 0 0 0 0 1"/></transform>', "orthographic",
     "shear"),
    ('<transform name="to_world"><scale x="-1"/></transform>', "orthographic", "mirrored"),
    ("", "thinlens", "without aperture_radius"),
    ('<float name="aperture_radius" value="0.1"/><float name="focus_distance" value="-1"/>', "thinlens",
     "focus_distance"),
    ('<float name="aperture_radius" value="0.1"/><transform name="to_world"><scale value="2"/></transform>',
     "thinlens", "rigid"),
    ('<float name="near_clip" value="5"/><float name="far_clip" value="4"/>', "orthographic", "near_clip"),
    ("", "radiancemeter", "only 'perspective', 'thinlens', 'orthographic'"),
])
def test_importer_refuses(tmp_path, body, kind, match):
    with pytest.raises(ValueError, match=match):
        from_mitsuba(_sensor_xml(tmp_path, body, kind))
