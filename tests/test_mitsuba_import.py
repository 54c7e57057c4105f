"""from_mitsuba: Mitsuba's own Cornell box, XML round trips, and the unsupported listing."""
from __future__ import annotations

import numpy as np
import pytest

import reference_tracer as rt
from mitsuba_scenes import from_mitsuba, get_scene, render_mitsuba, to_mitsuba, to_xml
from mitsuba_scenes.variants import import_mitsuba
from mitsuba_stats import compare


@pytest.fixture(scope="module")
def mi():
    return import_mitsuba()


def _mitsuba_cornell(mi, size=16):
    d = mi.cornell_box()
    d["sensor"]["film"]["rfilter"] = {"type": "box"}
    d["sensor"]["film"]["width"] = d["sensor"]["film"]["height"] = size
    return d


def test_mitsuba_cornell_box_imports_and_agrees(mi):
    d = _mitsuba_cornell(mi)
    scene = from_mitsuba(d)
    assert len(scene.shapes) == 8 and scene.max_depth == 8 and scene.rr_depth == 5
    assert sum(isinstance(s, rt.Box) for s in scene.shapes) == 2
    light = [s for s in scene.shapes if s.material.emits]
    assert len(light) == 1 and light[0].material.albedo is not None
    spp = 64
    ours = rt.render(scene, spp=spp, strategy="mis", seed=3, threads=2)
    mit = render_mitsuba(d, spp=spp, seed=3, batches=spp, threads=2)
    res = compare(ours.mean, ours.variance, spp, mit.mean, mit.variance, spp)
    assert res.ok, res.message


@pytest.mark.parametrize("name", ["cornell_mesh", "cornell_glass", "glossy_plates", "furnace"])
def test_xml_round_trip(name, mi, tmp_path):
    scene = get_scene(name, width=10, height=8)
    path = to_xml(scene, tmp_path / "scene.xml")
    back = from_mitsuba(path)
    assert [type(s) for s in back.shapes] == [type(s) for s in scene.shapes]
    assert (back.max_depth, back.rr_depth) == (scene.max_depth, scene.rr_depth)
    for a, b in zip(scene.shapes, back.shapes):
        assert type(a.material) is type(b.material)
    np.testing.assert_allclose(back.camera.vfov, scene.camera.vfov, rtol=1e-6)
    # The re-exported scene renders as the original in Mitsuba (same seed).
    img = lambda s: np.array(mi.render(mi.load_dict(to_mitsuba(s)), spp=8, seed=5))  # noqa: E731
    np.testing.assert_allclose(img(back), img(scene), rtol=1e-4, atol=1e-5)


def test_fov_axis_variants_import(mi):
    d = _mitsuba_cornell(mi)
    d["sensor"]["film"]["width"], d["sensor"]["film"]["height"] = 32, 16
    vf = {}
    for axis in ("x", "y", "smaller", "larger", "diagonal"):
        d["sensor"]["fov_axis"] = axis
        vf[axis] = from_mitsuba(d).camera.vfov
    assert vf["y"] == pytest.approx(39.3077) and vf["smaller"] == pytest.approx(39.3077)
    assert vf["x"] == pytest.approx(vf["larger"]) and vf["x"] < vf["diagonal"] < vf["y"] or vf["diagonal"] < vf["x"]
    t = np.tan(np.radians(39.3077) / 2)
    assert np.tan(np.radians(vf["x"]) / 2) == pytest.approx(t / 2)


def test_unsupported_scene_lists_everything(mi):
    d = mi.cornell_box()       # gaussian filter: unsupported on its own
    d["white"] = {"type": "plastic"}
    d["integrator"] = {"type": "volpath"}
    d["env"] = {"type": "envmap", "filename": "sky.exr"}
    d["red"] = {"type": "diffuse", "reflectance": {"type": "checkerboard"}}
    with pytest.raises(ValueError) as err:
        from_mitsuba(d)
    msg = str(err.value)
    for needle in ("plastic", "volpath", "envmap", "gaussian", "checkerboard", 'dictionary node "white"',
                   'dictionary node "env"'):
        assert needle in msg, (needle, msg)


def test_mesh_without_face_normals_gets_mitsubas_computed_normals(mi, tmp_path):
    """A PLY without normals and face_normals=false: Mitsuba computes vertex normals (the
    angle-weighted face normals) and shades it smooth; the import takes the same normals."""
    from reference_tracer.shapes import vertex_normals

    scene = get_scene("cornell_mesh", width=8, height=8)
    path = to_xml(scene, tmp_path / "m.xml")
    path.write_text(path.read_text().replace('name="face_normals" value="true"', 'name="face_normals" value="false"'))
    imported = [s for s in from_mitsuba(path).shapes if isinstance(s, rt.Mesh)]
    assert len(imported) == 1 and imported[0].normals is not None
    mesh = [s for s in mi.load_file(str(path)).shapes() if s.has_vertex_normals()]
    theirs = np.array(mi.traverse(mesh[0])["vertex_normals"], dtype=np.float64).reshape(-1, 3)
    np.testing.assert_allclose(imported[0].world_normals(), theirs, atol=1e-6)
    np.testing.assert_allclose(vertex_normals(imported[0].vertices, imported[0].faces), theirs, atol=1e-5)


def test_dielectric_ior_ratio_and_defaults(mi):
    d = _mitsuba_cornell(mi)
    d["glass"] = {"type": "sphere", "radius": 0.3, "bsdf": {"type": "dielectric", "int_ior": 1.5, "ext_ior": 1.25}}
    d["plain"] = {"type": "sphere", "center": [0.5, 0.5, 0], "radius": 0.1}
    s = from_mitsuba(d)
    glass, plain = s.shapes[-2:]
    assert glass.material.ior == pytest.approx(1.2)
    assert plain.material == rt.Lambertian(0.5)
