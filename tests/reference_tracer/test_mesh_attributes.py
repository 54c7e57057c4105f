"""Mitsuba's ``mesh_attribute`` texture: ``rt.MeshAttribute`` on a mesh's attributes, judged by Mitsuba.

- **Renders** of small XML scenes over a generated PLY, imported with ``from_mitsuba`` and
  rendered by both (``benchmarks.gate.agreement``, as ``tests/reference_tracer/test_mask.py``): float vertex
  colours (``r g b``, interpolated by the barycentrics), uchar vertex colours (``red green
  blue``, which Mitsuba 3.9.1 reads as 0 to 255: a ``scale`` of 1/255) and float face
  colours (one per face), under an area light (``path``) and a directional light
  (``direct``).
- **PLY attributes** as Mitsuba's ``ply`` makes them (the values Mitsuba's traverse gives).
- **First hit**: the albedo our probe gives is the attribute, interpolated or per face.
- **Wavefront equals scalar** bit for bit.
- **Bad input**: refused with a ``ValueError`` naming it.
- **Round trips**: the translation to Mitsuba (dict and XML) and back through the importer.
"""
from __future__ import annotations

import numpy as np
import pytest

import reference_tracer as rt
from benchmarks.gate.agreement import agreement
from mitsuba_scenes import from_mitsuba, render_mitsuba, to_mitsuba, to_xml
from mitsuba_xml import path_integrator, scene_xml

SPP = 4096
_RNG = np.random.default_rng(46)
# a 4 x 3 grid of vertices over [-1, 1]^2 (z = 0), 12 triangles, bumped in z so that faces differ
_GX, _GY = np.meshgrid(np.linspace(-1, 1, 4), np.linspace(-1, 1, 3))
VERTICES = np.stack([_GX.ravel(), _GY.ravel(), 0.15 * np.sin(3 * _GX.ravel() + _GY.ravel())], axis=1)
FACES = np.array([f for j in range(2) for i in range(3)
                  for f in ([4 * j + i, 4 * j + i + 1, 4 * j + i + 5], [4 * j + i, 4 * j + i + 5, 4 * j + i + 4])])
VERTEX_RGB = _RNG.uniform(0.05, 0.95, (len(VERTICES), 3)).astype(np.float32)
VERTEX_UCHAR = _RNG.integers(0, 256, (len(VERTICES), 3), dtype=np.uint8)
FACE_RGB = _RNG.uniform(0.05, 0.95, (len(FACES), 3)).astype(np.float32)


def write_ply(path, vertex_props=(), face_props=(), faces=FACES, list_type="int", face_count=3):
    """A binary PLY: positions, then ``vertex_props`` and ``face_props`` ((name, dtype, values) each)."""
    vdt = [("x", "<f4"), ("y", "<f4"), ("z", "<f4")] + [(n, t) for n, t, _ in vertex_props]
    v = np.zeros(len(VERTICES), dtype=vdt)
    v["x"], v["y"], v["z"] = VERTICES.T
    for n, _, values in vertex_props:
        v[n] = values
    fdt = [("n", "u1"), ("idx", f"<{'i4' if list_type == 'int' else 'u4'}", (face_count,))]
    fdt += [(n, t) for n, t, _ in face_props]
    f = np.zeros(len(faces), dtype=fdt)
    f["n"], f["idx"] = face_count, faces
    for n, _, values in face_props:
        f[n] = values
    names = {"<f4": "float", "u1": "uchar", "|u1": "uchar", "<f8": "double", "<u2": "ushort", "<i4": "int"}
    header = ("ply\nformat binary_little_endian 1.0\n"
              f"element vertex {len(v)}\nproperty float x\nproperty float y\nproperty float z\n"
              + "".join(f"property {names[t]} {n}\n" for n, t, _ in vertex_props)
              + f"element face {len(f)}\nproperty list uchar {list_type} vertex_indices\n"
              + "".join(f"property {names[t]} {n}\n" for n, t, _ in face_props) + "end_header\n")
    path.write_bytes(header.encode() + v.tobytes() + f.tobytes())
    return path


def _plys(tmp_path):
    return {
        "float_vertex": write_ply(tmp_path / "fv.ply", [(c, "<f4", VERTEX_RGB[:, k]) for k, c in enumerate("rgb")]),
        "uchar_vertex": write_ply(tmp_path / "uv.ply",
                                  [(c, "u1", VERTEX_UCHAR[:, k]) for k, c in enumerate(("red", "green", "blue"))]),
        "float_face": write_ply(tmp_path / "ff.ply", face_props=[(c, "<f4", FACE_RGB[:, k]) for k, c in enumerate("rgb")]),
    }


#: (ply, attribute name, scale) of each case
CASES = {"float_vertex": ("fv.ply", "vertex_color", 1.0), "uchar_vertex": ("uv.ply", "vertex_color", 1 / 255),
         "float_face": ("ff.ply", "face_color", 1.0)}


def _scene_xml(tmp_path, case, *, integrator="path", name="scene.xml"):
    _plys(tmp_path)
    ply, attr, scale = CASES[case]
    if integrator == "path":
        integ = path_integrator(5)
        light = """<shape type="rectangle"><transform name="to_world"><scale value="0.7"/><rotate x="1" angle="180"/>
        <translate x="0.3" y="0.2" z="2.2"/></transform><emitter type="area"><rgb name="radiance" value="9"/></emitter>
    </shape>
    <emitter type="constant"><rgb name="radiance" value="0.2"/></emitter>"""
    else:
        integ = ('<integrator type="direct"><integer name="emitter_samples" value="1"/>'
                 '<integer name="bsdf_samples" value="1"/></integrator>')
        light = """<emitter type="directional"><vector name="direction" x="0.3" y="0.4" z="-1"/>
        <rgb name="irradiance" value="3"/></emitter>"""
    xml = tmp_path / name
    xml.write_text(scene_xml(f"""
    <shape type="ply"><string name="filename" value="{ply}"/>
        <bsdf type="twosided"><bsdf type="diffuse"><texture type="mesh_attribute" name="reflectance">
            <string name="name" value="{attr}"/><float name="scale" value="{scale!r}"/></texture></bsdf></bsdf>
    </shape>
    {light}""", integrator=integ, fov=45, origin="0.4, -2.6, 2.6", target="0, 0, 0", up="0, 0, 1",
        width=32, height=24))
    return xml


# ------------------------------------------------------------------------- PLY attributes

def test_ply_attributes_as_mitsuba_reads_them(tmp_path):
    import mitsuba as mi

    from mitsuba_scenes.variants import import_mitsuba

    import_mitsuba()
    plys = _plys(tmp_path)
    odd = write_ply(tmp_path / "odd.ply", [("q_x", "<u2", np.arange(len(VERTICES)) * 5000),
                                           ("w_r", "<f8", np.linspace(0, 1, len(VERTICES))),
                                           ("w_g", "<f8", np.linspace(1, 0, len(VERTICES))),
                                           ("w_b", "<f8", np.full(len(VERTICES), 0.5))],
                    face_props=[("s_0", "<i4", np.arange(len(FACES)) * 1000)])
    for path in [*plys.values(), odd]:
        ours = rt.Mesh.load(path, rt.Lambertian(0.5), face_normals=True).attributes
        params = mi.traverse(mi.load_dict({"type": "ply", "filename": str(path), "face_normals": True}))
        theirs = {k: np.array(params[k]) for k in params.keys()
                  if k.startswith(("vertex_", "face_")) and k not in ("vertex_positions", "vertex_normals",
                                                                        "vertex_texcoords")}
        assert sorted(ours) == sorted(theirs), path.name
        for k, a in ours.items():
            np.testing.assert_allclose(a.ravel(), theirs[k], rtol=2e-6, atol=1e-7, err_msg=f"{path.name} {k}")
    uchar = rt.Mesh.load(plys["uchar_vertex"], rt.Lambertian(0.5)).attributes["vertex_color"]
    assert uchar.max() > 1 and np.array_equal(uchar, VERTEX_UCHAR.astype(np.float32))  # 0 to 255, as Mitsuba


def test_import_reads_the_attribute(tmp_path):
    for case, (ply, attr, scale) in CASES.items():
        scene = from_mitsuba(_scene_xml(tmp_path, case, name=f"{case}.xml"))
        mesh = next(s for s in scene.shapes if isinstance(s, rt.Mesh))
        tex = mesh.material.material.albedo if isinstance(mesh.material, rt.Mask) else mesh.material.albedo
        assert isinstance(tex, rt.MeshAttribute) and tex.name == attr and tex.scale == pytest.approx(scale)
        assert mesh.attributes[attr].shape == ((len(VERTICES) if attr.startswith("vertex") else len(FACES)), 3)


# ------------------------------------------------------------------------- agreement

@pytest.mark.parametrize("case", sorted(CASES))
def test_area_light_agrees_with_mitsuba(tmp_path, case):
    xml = _scene_xml(tmp_path, case)
    scene = from_mitsuba(xml)
    ours = rt.render(scene, spp=SPP, strategy="mis", seed=1, threads=2)
    mit = render_mitsuba(xml, spp=SPP, seed=1, batches=16, threads=2)
    a = agreement(ours, mit, pixel_filter=scene.camera.filter)
    assert a.agrees, a.describe()


@pytest.mark.parametrize("case", sorted(CASES))
def test_directional_light_direct_agrees_with_mitsuba(tmp_path, case):
    xml = _scene_xml(tmp_path, case, integrator="direct")
    scene = from_mitsuba(xml)
    assert scene.direct is not None
    ours = rt.render(scene, spp=SPP, strategy="mis", seed=3, threads=2)
    mit = render_mitsuba(xml, spp=SPP, seed=3, batches=16, threads=2)
    a = agreement(ours, mit, pixel_filter=scene.camera.filter)
    assert a.agrees, a.describe()


# ------------------------------------------------------------------------- first hit, wavefront

def _grid(texture, attributes, *, flip=False):
    cam = rt.Camera(lookfrom=(0, 0, 2.2), lookat=(0, 0, 0), vup=(0, 1, 0), vfov=60, width=24, height=16)
    mesh = rt.Mesh(VERTICES, FACES, rt.Lambertian(texture), flip_normals=flip, attributes=attributes)
    light = rt.Quad((-1, -1, 2.5), (0, 2, 0), (2, 0, 0), rt.DiffuseLight((5, 5, 5)))
    return rt.Scene(cam, [mesh, light], background=(0.1, 0.1, 0.1))


@pytest.mark.parametrize("flip", [False, True])
def test_first_hit_albedo_is_the_attribute(flip):
    from reference_tracer.probe import first_hit_aovs

    attrs = {"vertex_color": VERTEX_RGB, "face_grey": FACE_RGB[:, :1]}
    for tex in (rt.MeshAttribute("vertex_color", 0.5), rt.MeshAttribute("face_grey")):
        scene = _grid(tex, attrs, flip=flip)
        aovs = first_hit_aovs(scene)
        hit = aovs["shape"] == 0
        assert hit.sum() > 100
        albedo = aovs["albedo"][hit]
        if tex.name == "face_grey":  # constant per face: the values of the faces themselves
            assert np.all(np.min(np.abs(albedo[:, :1] - FACE_RGB[None, :, 0].astype(np.float64)), axis=1) < 1e-7)
            assert np.array_equal(albedo[:, 0], albedo[:, 1])
        else:  # interpolated: within the corner values' range, and not one of them
            assert albedo.min() >= 0.5 * VERTEX_RGB.min() - 1e-6 and albedo.max() <= 0.5 * VERTEX_RGB.max() + 1e-6
            assert len(np.unique(np.round(albedo, 5), axis=0)) > 50


@pytest.mark.parametrize("name,flip", [("vertex_color", False), ("vertex_color", True), ("face_color", False),
                                       ("face_grey", True)])
def test_first_hit_albedo_matches_mitsuba(name, flip):
    """The albedo AOV at every pixel centre, ours and Mitsuba's (the scene translated with
    its attribute: ``benchmarks.parity``), on a mesh seen from its front."""
    from benchmarks.parity import run_parity

    attrs = {"vertex_color": VERTEX_RGB, "face_color": FACE_RGB, "face_grey": FACE_RGB[:, 1:2]}
    cam = rt.Camera(lookfrom=(0.3, 0.4, -2.6 if flip else 2.6), lookat=(0, 0, 0), width=40, height=32, vfov=50)
    mesh = rt.Mesh(VERTICES, FACES, rt.Lambertian(rt.MeshAttribute(name, 0.8)), flip_normals=flip, attributes=attrs)
    report = run_parity(rt.Scene(camera=cam, shapes=[mesh], background=(0.5, 0.5, 0.5)), name=name)
    assert report.passed, (report.summary(), report.findings)
    assert report.counts["albedo"] == 0
    albedo = report.ours["albedo"][report.ours["shape"] == 0]
    assert len(np.unique(albedo.round(6), axis=0)) > 5


def test_interpolation_matches_the_barycentrics():
    # one triangle seen head-on, its corners pure red, green and blue: the centre pixel's
    # albedo is the barycentric mix at the centre ray's hit
    from reference_tracer.probe import first_hit_aovs

    v = np.array([[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [0.0, 1.0, 0.0]])
    cam = rt.Camera(lookfrom=(0, 0, 3), lookat=(0, 0, 0), vup=(0, 1, 0), vfov=30, width=1, height=1)
    mesh = rt.Mesh(v, [[0, 1, 2]], rt.Lambertian(rt.MeshAttribute("vertex_color")),
                   attributes={"vertex_color": np.eye(3)})
    aovs = first_hit_aovs(rt.Scene(cam, [mesh]))
    # the hit (0, 0): barycentrics (0.25, 0.25, 0.5)
    np.testing.assert_allclose(aovs["albedo"][0, 0], [0.25, 0.25, 0.5], atol=1e-9)


@pytest.mark.parametrize("strategy", rt.STRATEGIES)
def test_wavefront_equals_scalar(strategy):
    attrs = {"vertex_color": VERTEX_RGB, "face_color": FACE_RGB}
    for tex in (rt.MeshAttribute("vertex_color"), rt.MeshAttribute("face_color", 0.9)):
        scene = _grid(tex, attrs)
        a, b = (rt.render(scene, spp=8, strategy=strategy, seed=7, threads=2, integrator=i)
                for i in ("scalar", "wavefront"))
        assert np.array_equal(a.mean, b.mean) and np.array_equal(a.variance, b.variance)


def test_a_mask_reads_a_one_channel_attribute():
    attrs = {"vertex_alpha": np.linspace(0, 1, len(VERTICES))}
    scene = _grid(rt.Checkerboard(), attrs)
    mesh = rt.Mesh(VERTICES, FACES, rt.Mask(rt.Lambertian(0.7), rt.MeshAttribute("vertex_alpha")), attributes=attrs)
    scene = rt.Scene(scene.camera, [mesh, scene.shapes[1]], background=(0.1, 0.1, 0.1))
    a, b = (rt.render(scene, spp=4, seed=7, threads=2, integrator=i) for i in ("scalar", "wavefront"))
    assert np.array_equal(a.mean, b.mean) and a.mean.sum() > 0


# ------------------------------------------------------------------------- bad input

def _render_small(scene):
    return rt.render(scene, spp=1, seed=0, threads=1)


def test_bad_input_is_refused(tmp_path):
    with pytest.raises(ValueError, match="start with 'vertex_' or 'face_'"):
        rt.MeshAttribute("color")
    with pytest.raises(ValueError, match="scale must be finite"):
        rt.MeshAttribute("vertex_color", float("nan"))
    with pytest.raises(ValueError, match="must be finite"):
        rt.Mesh(VERTICES, FACES, rt.Lambertian(0.5), attributes={"vertex_color": np.full((len(VERTICES), 3), np.nan)})
    with pytest.raises(ValueError, match="one row per vertex"):
        rt.Mesh(VERTICES, FACES, rt.Lambertian(0.5), attributes={"vertex_color": np.zeros((3, 3))})
    with pytest.raises(ValueError, match="start with 'vertex_' or 'face_'"):
        rt.Mesh(VERTICES, FACES, rt.Lambertian(0.5), attributes={"colour": np.zeros((len(VERTICES), 3))})
    # missing, wrong channel count, out of range, on a shape without attributes
    with pytest.raises(ValueError, match="no attribute 'vertex_color'"):
        _render_small(_grid(rt.MeshAttribute("vertex_color"), {"face_color": FACE_RGB}))
    with pytest.raises(ValueError, match="2 channels"):
        _render_small(_grid(rt.MeshAttribute("vertex_uv"), {"vertex_uv": np.zeros((len(VERTICES), 2))}))
    with pytest.raises(ValueError, match=r"reflectance must lie in \[0, 1\]"):
        _render_small(_grid(rt.MeshAttribute("vertex_color", 2.0), {"vertex_color": VERTEX_RGB}))
    with pytest.raises(ValueError, match="only a Mesh has them"):
        cam = rt.Camera(lookfrom=(0, 0, 3), lookat=(0, 0, 0), width=4, height=4)
        _render_small(rt.Scene(cam, [rt.Sphere((0, 0, 0), 1, rt.Lambertian(rt.MeshAttribute("vertex_color")))]))
    with pytest.raises(ValueError, match="opacity: 3 channels"):
        mesh = rt.Mesh(VERTICES, FACES, rt.Mask(rt.Lambertian(0.5), rt.MeshAttribute("vertex_color")),
                       attributes={"vertex_color": VERTEX_RGB})
        _render_small(rt.Scene(_grid(0.5, None).camera, [mesh]))
    with pytest.raises(ValueError, match="no mean"):
        _render_small(_grid(0.5, None).__class__(
            _grid(0.5, None).camera,
            [rt.Mesh(VERTICES, FACES, rt.Plastic(rt.MeshAttribute("vertex_color")),
                     attributes={"vertex_color": VERTEX_RGB})]))


def test_bad_ply_colours_are_refused(tmp_path):
    # a colour property that is a list, faces that are not triangles under face colours, NaN
    bad_list = tmp_path / "list.ply"
    bad_list.write_bytes(b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                         b"property float z\nproperty list uchar float r\nproperty float g\nproperty float b\n"
                         b"element face 1\nproperty list uchar int vertex_indices\nend_header\n"
                         b"0 0 0 2 0.5 0.5 0.5 0.5\n1 0 0 2 0.5 0.5 0.5 0.5\n0 1 0 2 0.5 0.5 0.5 0.5\n3 0 1 2\n")
    nan = write_ply(tmp_path / "nan.ply", [(c, "<f4", np.where(np.arange(len(VERTICES)) == 2, np.nan, 0.5))
                                           for c in "rgb"])
    quads = np.array([[0, 1, 5, 4], [1, 2, 6, 5]])
    quad = write_ply(tmp_path / "quad.ply", face_props=[(c, "<f4", [0.5, 0.5]) for c in "rgb"], faces=quads,
                     face_count=4)
    for path, why in ((bad_list, "property vertex 'r' is a list"), (nan, "not finite"), (quad, "not all triangles")):
        with pytest.raises(ValueError, match=why):
            rt.Mesh.load(path, rt.Lambertian(0.5))


def test_importer_refuses_what_it_cannot_render(tmp_path):
    xml = _scene_xml(tmp_path, "float_vertex")
    text = xml.read_text()
    (tmp_path / "missing.xml").write_text(text.replace('value="vertex_color"', 'value="vertex_foo"'))
    with pytest.raises(ValueError, match="no attribute 'vertex_foo'"):
        from_mitsuba(tmp_path / "missing.xml")
    (tmp_path / "sphere.xml").write_text(text.replace('<shape type="ply"><string name="filename" value="fv.ply"/>',
                                                      '<shape type="sphere">'))
    with pytest.raises(ValueError, match="mesh_attribute texture on a 'sphere'"):
        from_mitsuba(tmp_path / "sphere.xml")


# ------------------------------------------------------------------------- round trips

@pytest.mark.parametrize("case", sorted(CASES))
def test_round_trip_through_mitsuba(tmp_path, case):
    import mitsuba as mi

    scene = from_mitsuba(_scene_xml(tmp_path, case))
    mesh = next(s for s in scene.shapes if isinstance(s, rt.Mesh))
    ply, attr, scale = CASES[case]
    # the dict: the attribute added to Mitsuba's mesh
    loaded = mi.load_dict(to_mitsuba(scene))
    mshape = next(s for s in loaded.shapes() if isinstance(s, mi.Mesh) and s.vertex_count() == len(VERTICES))
    np.testing.assert_array_equal(np.array(mi.traverse(mshape)[attr]), mesh.attributes[attr].ravel())
    # the XML: a PLY whose properties Mitsuba's ply groups back into the attribute, read back
    out = to_xml(scene, tmp_path / "out.xml")
    back = from_mitsuba(out)
    bmesh = next(s for s in back.shapes if isinstance(s, rt.Mesh))
    np.testing.assert_array_equal(bmesh.attributes[attr], mesh.attributes[attr])
    btex = bmesh.material.albedo
    assert isinstance(btex, rt.MeshAttribute) and btex.name == attr and btex.scale == pytest.approx(scale)
    small = back.with_camera_size(16, 12)
    a = rt.render(small, spp=4, seed=2, threads=2)
    b = rt.render(scene.with_camera_size(16, 12), spp=4, seed=2, threads=2)
    np.testing.assert_allclose(a.mean, b.mean, rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("extra", ["", "property uchar red\nproperty uchar green\nproperty uchar blue\n"])
def test_ascii_ply_loads(tmp_path, extra):
    """An ASCII PLY's face list (trimesh's "<u1, ($LIST,)<i4", which numpy 2.4 refuses with a
    ValueError) is the faces, never an attribute; vertex colours beside it are read."""
    colours = " 255 0 0" if extra else ""
    path = tmp_path / "tri.ply"
    path.write_text("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                    f"{extra}element face 1\nproperty list uchar int vertex_indices\nend_header\n"
                    f"0 0 0{colours}\n1 0 0{colours}\n0 1 0{colours}\n3 0 1 2\n")
    mesh = rt.Mesh.load(path, rt.Lambertian(0.5))
    assert mesh.faces.tolist() == [[0, 1, 2]]
    assert mesh.vertices.tolist() == [[0, 0, 0], [1, 0, 0], [0, 1, 0]]
    if extra:  # 8-bit colours as Mitsuba 3.9.1 reads them: not divided by 255 (it warns)
        assert mesh.attributes["vertex_color"].tolist() == [[255.0, 0.0, 0.0]] * 3
    else:
        assert not mesh.attributes
