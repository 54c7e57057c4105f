"""Smooth shading of triangle meshes with vertex normals, as Mitsuba 3 shades them.

The model (``reference_tracer.Mesh(normals=...)``): the shading normal is the normalised
barycentric interpolation of the vertex normals; it sets the BSDF frame, the side that
emits and reflects, and the cosine of light sampling on emitting meshes; rays leave along
the geometric normal; nothing reconciles the two normals (Mitsuba's src/render/mesh.cpp,
src/emitters/area.cpp). Here: the mesh model and its validation, the compiled arrays, the
core's hits, the loaders (``Mesh.load``, the importer) against Mitsuba's own loaders,
translation round trips, and renders judged by Mitsuba itself with the published scenes'
statistic (``benchmarks.gate.agreement``: 4096 spp each, Mitsuba in 16 batches).
Flat meshes stay on the flat path: tests/reference_tracer/test_wavefront.py and the suite's digests.
"""
from __future__ import annotations

import dataclasses
import functools
from pathlib import Path

import numpy as np
import pytest

import reference_tracer as rt
from mitsuba_scenes import from_mitsuba, render_mitsuba, to_mitsuba, to_xml
from mitsuba_scenes.variants import import_mitsuba
from benchmarks.gate.agreement import agreement
from mitsuba_xml import scene_xml
from reference_tracer._compile import compile_scene
from reference_tracer.render import core_scene
from reference_tracer.mesh import vertex_normals
from repo_paths import FIXTURES

NORMALS = FIXTURES / "normals"
SPP = 4096
WHITE = rt.Lambertian(0.6)


@pytest.fixture(scope="module")
def mi():
    return import_mitsuba()


def _cam(**kw):
    args = dict(lookfrom=(0, 1.5, -4), lookat=(0, 0.2, 0), vup=(0, 1, 0), vfov=40.0, width=16, height=12)
    args.update(kw)
    return rt.Camera(**args)


def _ico(subdivisions=1):
    import sys

    sys.path.insert(0, str(NORMALS))
    try:
        from make import icosphere
    finally:
        sys.path.remove(str(NORMALS))
    return icosphere(subdivisions)


# ------------------------------------------------------------------------------- the model

def test_normals_are_validated():
    v, f = np.eye(3), [[0, 1, 2]]
    with pytest.raises(ValueError, match=r"shape \(3, 3\)"):
        rt.Mesh(v, f, WHITE, normals=[[0, 0, 1]])
    with pytest.raises(ValueError, match=r"normals\[1\].*finite and non-zero"):
        rt.Mesh(v, f, WHITE, normals=[[0, 0, 1], [0, 0, 0], [0, 0, 1]])
    with pytest.raises(ValueError, match=r"normals\[2\].*finite and non-zero"):
        rt.Mesh(v, f, WHITE, normals=[[0, 0, 1], [0, 0, 1], [np.nan, 0, 1]])
    with pytest.raises(ValueError, match="array of numbers"):
        rt.Mesh(v, f, WHITE, normals=[["a", "b", "c"]] * 3)
    # a transform that flattens the mesh's plane keeps its area but collapses a normal
    flat = np.diag([1.0, 1.0, 0.0, 1.0])
    with pytest.raises(ValueError, match="vanishes under Mesh.transform"):
        rt.Mesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], f, WHITE, normals=[[1, 0, 0]] * 3,
                transform=tuple(map(tuple, flat)))
    m = rt.Mesh(v, f, WHITE, normals=[[0, 0, 3]] * 3)
    assert not m.normals.flags.writeable


def test_normals_follow_the_transform_as_normals_do():
    rng = np.random.default_rng(4)
    v, f = rng.normal(size=(3, 3)), [[0, 1, 2]]
    n = rng.normal(size=(3, 3))
    stretch = np.diag([1.0, 3.0, 0.5, 1.0])         # a non-uniform scale: not a rotation of n
    m = rt.Mesh(v, f, WHITE, normals=n, transform=tuple(map(tuple, stretch)))
    m = m.scale(2.0).rotate((1, 2, 3), 40).translate((1, 2, 3))
    lin = m.matrix[:3, :3]
    expect = n @ np.linalg.inv(lin)                 # rows: inv(lin).T @ n
    expect /= np.linalg.norm(expect, axis=1, keepdims=True)
    np.testing.assert_allclose(m.world_normals(), expect, atol=1e-12)
    flipped = dataclasses.replace(m, flip_normals=True)
    np.testing.assert_allclose(flipped.world_normals(), -expect, atol=1e-12)
    # the corner normals follow the winding that flip_normals reverses
    np.testing.assert_allclose(flipped.world_triangle_normals()[0], -expect[[0, 2, 1]], atol=1e-12)


def test_a_flat_mesh_compiles_as_before_and_keeps_its_hash():
    v, f = _ico(1)
    flat = rt.Scene(camera=_cam(), shapes=[rt.Mesh(v, f, WHITE)])
    args = compile_scene(flat)
    assert "smooth_triangles" not in args and "triangle_normals" not in args
    smooth_mesh = rt.Mesh(v, f, WHITE, normals=v)
    assert smooth_mesh.describe()["mesh_sha256"] != flat.shapes[0].describe()["mesh_sha256"]
    import hashlib

    assert flat.shapes[0].describe()["mesh_sha256"] == hashlib.sha256(v.tobytes() + f.tobytes()).hexdigest()


def test_compiled_normals_belong_to_their_triangles():
    v, f = _ico(1)
    tri = rt.Triangle((5, 0, 0), (6, 0, 0), (5, 1, 0), WHITE)
    smooth = rt.Mesh(v, f, WHITE, normals=v, flip_normals=True).translate((0, 0, 3))
    scene = rt.Scene(camera=_cam(), shapes=[tri, rt.Mesh(v, f, WHITE), smooth])
    args = compile_scene(scene)
    first = 1 + len(f)
    np.testing.assert_array_equal(args["smooth_triangles"], np.arange(first, first + len(f)))
    corners = args["triangle_normals"].reshape(-1, 3, 3)
    np.testing.assert_allclose(corners, -(v / np.linalg.norm(v, axis=1, keepdims=True))[f[:, [0, 2, 1]]])


# ------------------------------------------------------------------------------- the core

@pytest.mark.parametrize("query", ["scalar", "stream", "wavefront"])
def test_hits_carry_the_interpolated_normal(query):
    v, f = _ico(1)
    n = v + np.random.default_rng(0).normal(scale=0.2, size=v.shape)   # not the sphere's own
    mesh = rt.Mesh(v, f, WHITE, normals=n)
    scene = rt.Scene(camera=_cam(), shapes=[mesh, rt.Sphere((3, 0, 0), 0.5, WHITE)])
    c = core_scene(scene)
    rng = np.random.default_rng(1)
    o = rng.normal(size=(2000, 3)) * 0.3 + (0, 0, -3)
    target = rng.uniform(-1, 1, size=(2000, 3)) * (0.8, 0.8, 0) + (0, 0, 0)
    target[:50] = (3, 0, 0)                          # some rays hit the sphere (flat)
    d = target - o
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    hit = c.intersect(np.ascontiguousarray(o), np.ascontiguousarray(d), batch=query == "stream",
                      wavefront=query == "wavefront")
    prim = hit["prim"]
    on_mesh = prim >= 1                              # primitive 0: the sphere
    assert on_mesh.sum() > 1000 and (prim == 0).sum() > 10
    tri = mesh.world_triangles()[prim[on_mesh] - 1]
    corner = mesh.world_triangle_normals()[prim[on_mesh] - 1]
    p = hit["point"][on_mesh]
    # barycentrics of the hit point, then Mitsuba's normalize(b0 n0 + b1 n1 + b2 n2)
    e1, e2, dp = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0], p - tri[:, 0]
    d11, d12, d22 = (np.einsum("ij,ij->i", a, b) for a, b in ((e1, e1), (e1, e2), (e2, e2)))
    d1, d2 = np.einsum("ij,ij->i", dp, e1), np.einsum("ij,ij->i", dp, e2)
    den = d11 * d22 - d12 * d12
    b1, b2 = (d22 * d1 - d12 * d2) / den, (d11 * d2 - d12 * d1) / den
    expect = (1 - b1 - b2)[:, None] * corner[:, 0] + b1[:, None] * corner[:, 1] + b2[:, None] * corner[:, 2]
    expect /= np.linalg.norm(expect, axis=1, keepdims=True)
    np.testing.assert_allclose(hit["shading_normal"][on_mesh], expect, atol=1e-9)
    # geometric normals are the triangles' own; the sphere's shading normal is its normal
    g = np.cross(e1, e2)
    np.testing.assert_allclose(hit["normal"][on_mesh], g / np.linalg.norm(g, axis=1, keepdims=True), atol=1e-12)
    np.testing.assert_array_equal(hit["shading_normal"][prim == 0], hit["normal"][prim == 0])


def test_flat_scenes_report_no_shading_normal():
    v, f = _ico(1)
    c = core_scene(rt.Scene(camera=_cam(), shapes=[rt.Mesh(v, f, WHITE)]))
    hit = c.intersect(np.array([[0.0, 0, -3]]), np.array([[0.0, 0, 1]]))
    assert "shading_normal" not in hit and hit["prim"][0] >= 0


def test_the_core_refuses_bad_normal_arrays():
    v, f = _ico(0)
    args = compile_scene(rt.Scene(camera=_cam(), shapes=[rt.Mesh(v, f, WHITE, normals=v)]))
    from reference_tracer import _core

    bad = dict(args, triangle_normals=np.zeros_like(args["triangle_normals"]))
    with pytest.raises(ValueError, match="finite and non-zero"):
        _core.Scene(**bad)
    twice = dict(args, smooth_triangles=np.zeros_like(args["smooth_triangles"]))
    with pytest.raises(ValueError, match="listed twice"):
        _core.Scene(**twice)
    out = dict(args, smooth_triangles=args["smooth_triangles"] + 1000)
    with pytest.raises(ValueError, match="out of range"):
        _core.Scene(**out)
    with pytest.raises(ValueError, match="come together"):
        _core.Scene(**{k: a for k, a in args.items() if k != "triangle_normals"})


# ------------------------------------------------------------------------------- loaders

def _mitsuba_mesh(mi, path, **props):
    mesh = mi.load_dict({"type": Path(path).suffix[1:], "filename": str(path), **props})
    params = mi.traverse(mesh)
    v = np.array(params["vertex_positions"], dtype=np.float64).reshape(-1, 3)
    f = np.array(params["faces"], dtype=np.int64).reshape(-1, 3)
    n = np.array(params["vertex_normals"], dtype=np.float64).reshape(-1, 3) if mesh.has_vertex_normals() else None
    return v, f, n


OBJ_WITH_VN = """# a position used with two different normals becomes two vertices, as in Mitsuba
v 0 0 0
v 1 0 0
v 0 1 0
v 1 1 0.2
vt 0 0
vn 0 0 1
vn 0.3 0 1
vn 0 0.2 1
f 1//1 2//2 3//1
f 2/1/3 4//2 3//1 # a comment after the corners; 4 and 3 keep vt 1 (Mitsuba)
f 2//3 1 4 # 1 and 4 keep normal 3
f 1//2 3//3 4//1
"""

OBJ_WITHOUT_VN = """v 0 0 0
v 1 0 0
v 0 1 0
v 1 1 0.7
v 0.5 0.5 -0.4
vt 0 0
vt 1 1
f 1 2 5
f 2 4 5
f 4/1 3/2 5
f 3/2 1 5 2
"""


@pytest.mark.parametrize("text", [OBJ_WITH_VN, OBJ_WITHOUT_VN], ids=["vn", "computed"])
def test_obj_loads_as_mitsuba_loads_it(tmp_path, text, mi):
    path = tmp_path / "m.obj"
    path.write_text(text)
    ours = rt.Mesh.load(path, WHITE)
    v, f, n = _mitsuba_mesh(mi, path)
    np.testing.assert_array_equal(ours.faces, f)
    np.testing.assert_allclose(ours.vertices, v, atol=1e-6)
    unit = ours.normals / np.linalg.norm(ours.normals, axis=1, keepdims=True)
    np.testing.assert_allclose(unit, n, atol=1e-6)
    assert rt.Mesh.load(path, WHITE, face_normals=True).normals is None
    assert _mitsuba_mesh(mi, path, face_normals=True)[2] is None


@pytest.mark.parametrize("with_normals", [True, False])
def test_ply_loads_as_mitsuba_loads_it(tmp_path, with_normals, mi):
    from mitsuba_scenes.translate import write_ply

    v, f = _ico(1)
    v = v * (1.0, 0.6, 1.3)
    n = np.roll(v, 1, axis=1) if with_normals else None    # normals unlike the faces'
    path = tmp_path / "m.ply"
    write_ply(path, v, f, n)
    ours = rt.Mesh.load(path, WHITE)
    mv, mf, mn = _mitsuba_mesh(mi, path)
    np.testing.assert_array_equal(ours.faces, mf)
    np.testing.assert_allclose(ours.vertices, mv, atol=1e-6)
    unit = ours.normals / np.linalg.norm(ours.normals, axis=1, keepdims=True)
    np.testing.assert_allclose(unit, mn, atol=1e-5)
    if not with_normals:
        np.testing.assert_allclose(vertex_normals(v, f), mn, atol=1e-5)


def test_importer_normals_are_mitsubas_under_any_transform(tmp_path, mi):
    """Vertex normals through a non-uniform, mirroring to_world: the importer takes Mitsuba's
    (the loader's inverse transpose), and our Mesh.transform gives the same."""
    path = tmp_path / "m.obj"
    path.write_text(OBJ_WITH_VN)
    matrix = np.array([[0.0, 2.0, 0.0, 1.0], [-0.5, 0.0, 0.3, 2.0], [0.0, 0.0, -1.5, 0.5], [0, 0, 0, 1]])
    xml = tmp_path / "s.xml"
    rows = " ".join(repr(float(x)) for x in matrix.ravel())
    xml.write_text(scene_xml(f"""\
  <shape type="obj"><string name="filename" value="m.obj"/>
    <transform name="to_world"><matrix value="{rows}"/></transform></shape>""", width=4, height=4))
    imported = from_mitsuba(xml).shapes[0]
    _, _, n = _mitsuba_mesh(mi, path, to_world=mi.ScalarTransform4f(matrix.tolist()))
    np.testing.assert_allclose(imported.world_normals(), n, atol=1e-6)
    ours = dataclasses.replace(rt.Mesh.load(path, WHITE), transform=tuple(map(tuple, matrix)))
    np.testing.assert_allclose(ours.world_normals(), n, atol=1e-6)


def test_importer_face_normals_and_flip(tmp_path):
    v, _ = _ico(1)
    (tmp_path / "ico.obj").write_text((NORMALS / "ico.obj").read_text())
    shapes = "".join(f"""  <shape type="obj"><string name="filename" value="ico.obj"/>{extra}</shape>
""" for extra in ("", '<boolean name="face_normals" value="true"/>', '<boolean name="flip_normals" value="true"/>'))
    xml = tmp_path / "s.xml"
    xml.write_text(scene_xml(shapes, width=4, height=4))
    smooth, flat, flipped = from_mitsuba(xml).shapes
    unit = smooth.vertices / np.linalg.norm(smooth.vertices, axis=1, keepdims=True)   # the file's vn
    assert len(smooth.vertices) == len(v)
    np.testing.assert_allclose(smooth.world_normals(), unit, atol=1e-6)
    assert flat.normals is None
    assert flipped.flip_normals and np.allclose(flipped.world_normals(), -unit, atol=1e-6)


def test_importer_refuses_undefined_normals(tmp_path):
    from mitsuba_scenes.translate import write_ply

    write_ply(tmp_path / "zero.ply", np.eye(3), [[0, 1, 2]], [[0, 0, 1], [0, 0, 0], [0, 0, 1]])
    (tmp_path / "partial.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2 3\nf 1 2//1 3\n")
    xml = tmp_path / "s.xml"
    xml.write_text("""<scene version="3.0.0">
  <sensor type="perspective"><film type="hdrfilm"><integer name="width" value="4"/>
    <integer name="height" value="4"/><rfilter type="box"/></film></sensor>
  <shape type="ply"><string name="filename" value="zero.ply"/></shape>
  <shape type="obj"><string name="filename" value="partial.obj"/></shape>
</scene>
""")
    with pytest.raises(ValueError) as exc:
        from_mitsuba(xml)
    msg = str(exc.value)
    assert "(2 found)" in msg, msg
    assert "vertex normal 1 is [nan, nan, nan], not a unit vector" in msg and "s.xml (line 4" in msg
    assert "partial.obj line 6: a face whose first corner has no normal index" in msg and "s.xml (line 5" in msg


# ------------------------------------------------------------------------------- translation

def _smooth_scene():
    v, f = _ico(1)
    floor = rt.Quad((-3, -1, -3), (0, 0, 6), (6, 0, 0), rt.Lambertian(0.5))
    light = rt.Quad((-1, 2.5, -1), (2, 0, 0), (0, 0, 2), rt.DiffuseLight((8, 7, 6)))
    ball = rt.Mesh(v, f, rt.Lambertian((0.7, 0.5, 0.3)), normals=v).scale(0.8).translate((-0.6, -0.2, 0))
    # an emitting mesh, non-uniformly scaled and flipped: its normals face inward, it lights
    # the inside of its own shell and shows its inside through the gaps of the front faces
    shell = rt.Mesh(v, f, rt.DiffuseLight((1.0, 2.0, 3.0)), normals=v, flip_normals=True,
                    transform=((0.5, 0, 0, 0.9), (0, 0.3, 0, 0.3), (0, 0, 0.4, 0.5), (0, 0, 0, 1)))
    return rt.Scene(camera=_cam(width=24, height=16), shapes=[floor, light, ball, shell], max_depth=4,
                    background=(0.05, 0.05, 0.05))


def test_translation_gives_mitsuba_our_normals(tmp_path, mi):
    scene = _smooth_scene()
    d = to_mitsuba(scene)
    meshes = [d[k] for k in d if k.startswith("shape_") and isinstance(d[k], mi.Mesh)]
    assert len(meshes) == 2 and all(m.has_vertex_normals() for m in meshes)
    for mesh, ours in zip(meshes, scene.shapes[2:]):
        n = np.array(mi.traverse(mesh)["vertex_normals"], dtype=np.float64).reshape(-1, 3)
        np.testing.assert_allclose(n, ours.world_normals(), atol=1e-6)
    # XML: PLY files with normals; imported back, the same shading
    to_xml(scene, tmp_path / "s.xml")
    assert "face_normals" not in (tmp_path / "s.xml").read_text()
    back = from_mitsuba(tmp_path / "s.xml")
    for again, ours in zip(back.shapes[2:], scene.shapes[2:]):
        np.testing.assert_allclose(again.world_triangles(), ours.world_triangles(), atol=1e-5)
        np.testing.assert_allclose(again.world_triangle_normals(), ours.world_triangle_normals(), atol=1e-6)
    # a flat mesh stays flat through the XML
    flat = dataclasses.replace(scene, shapes=[*scene.shapes[:2], dataclasses.replace(scene.shapes[2], normals=None)])
    to_xml(flat, tmp_path / "f.xml")
    assert "face_normals" in (tmp_path / "f.xml").read_text()
    assert from_mitsuba(tmp_path / "f.xml").shapes[2].normals is None


def test_translated_smooth_scene_agrees_with_mitsuba():
    from mitsuba_stats import compare

    scene = _smooth_scene()
    ours = rt.render(scene, spp=256, strategy="mis", seed=2, threads=2)
    mit = render_mitsuba(scene, spp=256, seed=2, batches=16, threads=2)
    res = compare(ours.mean, ours.variance, 256, mit.mean, mit.variance, 256)
    assert res.ok, res.message


# ------------------------------------------------------------------------------- renders

@functools.lru_cache(maxsize=None)
def _mitsuba_render(name):
    return render_mitsuba(NORMALS / f"{name}.xml", spp=SPP, seed=1, batches=16, threads=2)


@pytest.mark.parametrize("name", ["sphere", "mismatch"])
def test_smooth_meshes_agree_with_mitsuba(name):
    scene = from_mitsuba(NORMALS / f"{name}.xml")
    assert any(isinstance(s, rt.Mesh) and s.normals is not None for s in scene.shapes)
    ours = rt.render(scene, spp=SPP, strategy="mis", seed=1, threads=2)
    assert ours.nonfinite_samples == 0
    mit = _mitsuba_render(name)
    a = agreement(ours, mit, pixel_filter=scene.camera.filter)
    assert a.agrees, a.describe()


def test_the_agreement_test_sees_flat_shading():
    """The same statistic with the mismatch scene's meshes shaded flat: it fails."""
    scene = from_mitsuba(NORMALS / "mismatch.xml")
    flat = dataclasses.replace(scene, shapes=[dataclasses.replace(s, normals=None) if isinstance(s, rt.Mesh) else s
                                              for s in scene.shapes])
    ours = rt.render(flat, spp=SPP, strategy="mis", seed=1, threads=2)
    mit = _mitsuba_render("mismatch")
    assert not agreement(ours, mit, pixel_filter=scene.camera.filter).agrees


def test_first_hit_parity_sees_shading_normals():
    """``rtbench parity`` compares our shading normal with Mitsuba's ``sh_frame.n``: a smooth
    scene has parity, and the same scene shaded flat on Mitsuba's side does not."""
    from benchmarks.parity import run_parity

    scene = _smooth_scene()
    report = run_parity(scene, name="smooth")
    assert report.passed, (report.summary(), report.findings)
    flat = dataclasses.replace(scene, shapes=[dataclasses.replace(s, normals=None) if isinstance(s, rt.Mesh) else s
                                              for s in scene.shapes])
    report = run_parity(scene, mitsuba=to_mitsuba(flat), name="flat")
    assert not report.passed and report.counts["normal"] > 0
