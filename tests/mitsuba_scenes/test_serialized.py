"""Mitsuba's ``serialized`` meshes: imported through Mitsuba's own loader, after the file's
header is checked (tests/test_untrusted_input.py), and judged against ``mi.load_file`` of the
same scene with the published scenes' agreement screen (``benchmarks.gate.agreement``: 4096
spp each, Mitsuba in 16 batches; every |global z| <= 4, at most 1% of pixel values with
|z| > 4: about 6e-5 per channel under the normal approximation)."""
from __future__ import annotations

import struct
import zlib

import numpy as np
import pytest

import reference_tracer as rt
from benchmarks.gate.agreement import agreement
from mitsuba_scenes import from_mitsuba, render_mitsuba
from mitsuba_xml import path_integrator, scene_xml


def _icosphere():
    t = (1 + 5 ** 0.5) / 2
    v = np.array([(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
                  (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)], dtype=float)
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    f = np.array([(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2),
                  (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5),
                  (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)])
    return v, f


def write_serialized(path, meshes):
    """Mitsuba's format, version 4: one zlib stream per mesh (flags, name, counts, positions,
    normals where given, uint32 indices) and the end-of-file dictionary of offsets."""
    out, offsets = b"", []
    for name, v, f, n in meshes:
        flags = 0x1000 | (0x0001 if n is not None else 0)
        body = struct.pack("<I", flags) + name.encode() + b"\x00" + struct.pack("<QQ", len(v), len(f))
        body += np.asarray(v, "<f4").tobytes() + (np.asarray(n, "<f4").tobytes() if n is not None else b"")
        body += np.asarray(f, "<u4").tobytes()
        offsets.append(len(out))
        out += struct.pack("<HH", 0x041C, 4) + zlib.compress(body)
    out += b"".join(struct.pack("<Q", o) for o in offsets) + struct.pack("<I", len(meshes))
    path.write_bytes(out)


def _scene(tmp_path):
    v, f = _icosphere()
    floor_v = np.array([(-3, 0, -3), (-3, 0, 3), (3, 0, 3), (3, 0, -3)], float)
    write_serialized(tmp_path / "meshes.serialized", [("floor", floor_v, [(0, 1, 2), (0, 2, 3)], None),
                                                       ("ball", v, f, v)])
    xml = tmp_path / "scene.xml"
    xml.write_text(scene_xml("""
    <shape type="serialized"><string name="filename" value="meshes.serialized"/>
        <integer name="shape_index" value="0"/><bsdf type="diffuse"/></shape>
    <shape type="serialized"><string name="filename" value="meshes.serialized"/>
        <integer name="shape_index" value="1"/>
        <transform name="to_world"><translate y="1"/></transform>
        <bsdf type="roughplastic"><rgb name="diffuse_reflectance" value="0.6, 0.3, 0.2"/></bsdf></shape>
    <shape type="rectangle"><transform name="to_world"><rotate x="1" angle="90"/><translate y="3.5"/></transform>
        <emitter type="area"><rgb name="radiance" value="5"/></emitter></shape>""",
        integrator=path_integrator(4), fov=45, origin="0, 2.5, 5", target="0, 0.6, 0", width=40, height=30))
    return xml


def test_serialized_meshes_import_with_their_normals_and_agree_with_mitsuba(tmp_path):
    xml = _scene(tmp_path)
    scene = from_mitsuba(xml)
    floor, ball = scene.shapes[0], scene.shapes[1]
    assert len(floor.faces) == 2 and floor.normals is None          # no normals stored, flat and planar
    assert len(ball.faces) == 20 and ball.normals is not None       # the file's normals: smooth
    ours = rt.render(scene, spp=4096, strategy="mis", seed=1, threads=2)
    mit = render_mitsuba(xml, spp=4096, seed=1, batches=16, threads=2)
    a = agreement(ours, mit, pixel_filter=scene.camera.filter)
    assert a.agrees, a.describe()


def test_serialized_refusals_name_the_problem(tmp_path):
    xml = _scene(tmp_path)
    bad = xml.read_text().replace('name="shape_index" value="1"', 'name="shape_index" value="5"')
    (tmp_path / "bad.xml").write_text(bad)
    with pytest.raises(ValueError, match="shape_index 5, but the file holds 2 mesh"):
        from_mitsuba(tmp_path / "bad.xml")
