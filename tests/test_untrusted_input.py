"""A results store, a scene file and a mesh are untrusted input (``SECURITY.md``).

Each test plays an attacker's store or file against the command a user runs on it and
asserts what must never happen: code executed, a file touched outside the output folder,
a read outside the store, a hang (every subprocess has a timeout), markup or escape
sequences passed through, a silently wrong image, an allocation before a check; and that
the user gets the documented exit status with one line naming the file.
"""
from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

import reference_tracer as rt
from benchmarks.cli import main
from benchmarks.store import RESULTS, SUMMARY, append_record, read_records, record_key, write_image

from harness_util import ROOT
from mitsuba_xml import scene_xml
from report_store import make_store


def _rewrite(store: Path, fn) -> None:
    """Apply ``fn(record) -> record`` to every record and summary row of a store."""
    lines = [json.loads(x) for x in (store / RESULTS).read_text().splitlines() if x.strip()]
    (store / RESULTS).write_text("".join(json.dumps(fn(r)) + "\n" for r in lines))
    summ = json.loads((store / SUMMARY).read_text())
    summ["rows"] = [fn(r) for r in summ["rows"]]
    (store / SUMMARY).write_text(json.dumps(summ))


def _small_store(path: Path) -> Path:
    return make_store(path, scenes=("spheres",), strategies=("mis",), spps=(1, 2, 4, 8), seeds=(0,), size=8,
                      mitsuba=False, duplicate=False)


def _files_under(folder: Path) -> set:
    return {p for p in folder.rglob("*")}


def _rtbench(*args, timeout=120, cwd=ROOT) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "benchmarks.cli", *map(str, args)], cwd=cwd, capture_output=True,
                          text=True, timeout=timeout)


# ---------------------------------------------------------------------------------- 1. no code from a store

def test_compare_never_imports_the_scene_file_a_store_names(tmp_path):
    """A record of this very build naming a Python payload as its ``scene_source``: the
    tail-reference lookup of ``rtbench compare`` must not import it."""
    from benchmarks.compare import estimator_knowledge

    marker = tmp_path / "pwned"
    payload = tmp_path / "b" / "evil.py"
    payload.parent.mkdir()
    payload.write_text(f"open({str(marker)!r}, 'w').write('ran')\n"
                       "import reference_tracer as rt\n"
                       "def build(width=8, height=8):\n    raise SystemExit\n")
    record = {"scene": "evil", "renderer": "ours", "strategy": "mis", "spp": 4, "seed": 0, "width": 8,
              "height": 8, "build": rt.build_id(), "scene_source": str(payload), "scene_hash": "0" * 16}
    knowledge = estimator_knowledge(tail_spp=64, threads=1)
    note = knowledge(("evil", "ours", "mis", 8, 8), [record]).note
    assert not marker.exists()
    assert note.startswith("none:") and "--scene" in note


def test_compare_cli_with_a_payload_store_runs_no_code(tmp_path):
    """End to end: ``rtbench compare A B`` where B names a payload (relative to the current
    folder, as an attacker ships it inside B) and carries this build's id."""
    a = _small_store(tmp_path / "a")
    b = _small_store(tmp_path / "b")
    marker = tmp_path / "pwned"
    (b / "evil.py").write_text(f"open({str(marker)!r}, 'w').write('ran')\n")
    build = rt.build_id()

    def hostile(r, **extra):  # a scene only the payload defines; images with variances: a verdict is due
        if r.get("image"):
            r = dict(r, stats_image=r["image"], stats_variance_image="references/spheres_variance.exr")
        return dict(r, build=build, scene="evil", **extra)

    _rewrite(b, lambda r: hostile(r, scene_source="b/evil.py"))
    _rewrite(a, hostile)
    proc = _rtbench("compare", a, b, "--out", tmp_path / "page", "--quiet", "--tail-spp", "16", "--threads", "1",
                    cwd=tmp_path)
    assert not marker.exists(), proc.stderr
    assert proc.returncode in (0, 1), proc.stderr


# ---------------------------------------------------------------------------------- 2. no write outside

@pytest.mark.parametrize("hostile", ["../../escaped", "ABSOLUTE", "a/b/../../c", ".hidden"])
def test_report_writes_only_inside_its_output_folder(tmp_path, hostile):
    if hostile == "ABSOLUTE":  # an absolute path, under this test's folder so that nothing else is touched
        hostile = str(tmp_path / "escaped-abs")
    store = _small_store(tmp_path / "s")
    _rewrite(store, lambda r: dict(r, scene=hostile))
    out = tmp_path / "deep" / "out"
    before = _files_under(tmp_path) - _files_under(out)
    code = main(["report", str(store), "--out", str(out), "--format", "html,svg,pdf,csv", "--quiet"])
    assert code == 0
    outside = {p for p in _files_under(tmp_path) - _files_under(out) - before if p not in (out, out.parent)}
    assert outside == set(), outside
    plots = sorted(p.name for p in (out / "plots").iterdir())
    assert plots and all(not name.startswith(".") and "/" not in name for name in plots)


# ---------------------------------------------------------------------------------- 3. no read outside, no hang

def _secret_exr(tmp_path) -> Path:
    secret = tmp_path / "secret.exr"
    rt.write_exr(secret, np.full((8, 8, 3), 7.0))
    return secret


@pytest.mark.parametrize("where", ["absolute", "dotdot", "symlink"])
def test_report_reads_no_image_outside_the_store(tmp_path, where):
    store = _small_store(tmp_path / "s")
    secret = _secret_exr(tmp_path)
    if where == "symlink":
        os.symlink(secret, store / "images" / "link.exr")
        rel = "images/link.exr"
    else:
        rel = str(secret) if where == "absolute" else "../secret.exr"
    _rewrite(store, lambda r: dict(r, image=rel) if "image" in r else r)
    meta = json.loads((store / "meta.json").read_text())
    meta["references"]["spheres"]["path"] = rel
    (store / "meta.json").write_text(json.dumps(meta))
    from reports.store import load_store

    st = load_store(store)
    with pytest.raises(ValueError, match="folder|symbolic link"):
        st.read_image(rel)
    page = tmp_path / "out"
    assert main(["report", str(store), "--out", str(page), "--quiet"]) == 0
    md = (page / "summary.md").read_text()
    assert "could not be read" in md   # listed as a problem of the store, never shown


def test_a_fifo_in_the_store_does_not_hang_the_report(tmp_path):
    store = _small_store(tmp_path / "s")
    os.mkfifo(store / "images" / "fifo.exr")
    _rewrite(store, lambda r: dict(r, image="images/fifo.exr"))
    os.unlink(store / "meta.json")
    os.mkfifo(store / "meta.json")
    proc = _rtbench("report", store, "--out", tmp_path / "out", "--quiet", timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "not a regular file" in (tmp_path / "out" / "summary.md").read_text()


def test_an_exr_header_declaring_a_huge_image_is_refused_before_decoding(tmp_path):
    import OpenEXR

    path = tmp_path / "big.exr"
    rt.write_exr(path, np.zeros((4, 4, 3)))
    with pytest.raises(ValueError, match="pixels"):
        rt.read_exr(path, max_pixels=8)
    assert OpenEXR  # the decoder is there; the header alone decided


# ---------------------------------------------------------------------------------- 4. escaped per medium

HOSTILE_NAME = "<script>alert(1)</script>|*x*[l](http://e)=HYPERLINK(\"http://e\")\x1b[2J\x1b]0;t\x07"


def test_text_outputs_escape_store_fields(tmp_path, capsys):
    store = _small_store(tmp_path / "s")
    _rewrite(store, lambda r: dict(r, scene=HOSTILE_NAME, strategy="=cmd|' /C calc'!A0"))
    out = tmp_path / "out"
    assert main(["report", str(store), "--out", str(out), "--format", "html,csv"]) == 0
    printed = capsys.readouterr()
    assert "\x1b" not in printed.out + printed.err
    md = (out / "summary.md").read_text()
    assert "<script>" not in md and "[l](http" not in md and "\x1b" not in md
    page = (out / "index.html").read_text()
    assert "<script>alert(1)" not in page
    import csv

    for name in ("curves.csv", "summary.csv"):
        rows = list(csv.reader((out / name).open()))
        assert rows[1:], name
        for row in rows[1:]:
            assert not any(cell.startswith(("=", "+", "@")) for cell in row), (name, row)
        assert "\x1b" not in (out / name).read_text() and "\\x1b[2J" in (out / name).read_text(), name


def test_error_lines_carry_no_terminal_escapes(tmp_path):
    proc = _rtbench("render", "--scene", tmp_path / "no\x1b]0;title\x07such.xml")
    assert proc.returncode == 2 and "such.xml" in proc.stderr
    assert "\x1b" not in proc.stderr and "\x07" not in proc.stderr and "\\x1b" in proc.stderr


# ---------------------------------------------------------------------------------- 5. one writer at a time

def test_concurrent_write_reference_records_each_job_once(tmp_path):
    store = tmp_path / "ref"
    code = ("import sys; from benchmarks.gate.store_reference import write_reference_store; "
            "write_reference_store(['cornell_box'], sys.argv[1], spp=64, width=8, threads=1)")
    procs = [subprocess.Popen([sys.executable, "-c", code, str(store)], cwd=ROOT, stderr=subprocess.PIPE, text=True)
             for _ in range(2)]
    for p in procs:
        assert p.wait(timeout=300) == 0, p.stderr.read()
    records = read_records(store, dedupe=False)
    keys = [record_key(r) for r in records]
    assert len(keys) == len(set(keys)) == 1
    img = rt.read_exr(store / records[0]["image"])
    assert img.shape == (8, 8, 3)


# ---------------------------------------------------------------------------------- 6. no silent wrong image

SINGULAR_IN_PLANE = ((1, 0, 0, 0), (0, 0, 0, 0), (0, 0, 1, 0), (0, 0, 0, 1))
PROJECTIVE = ((1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (0, 0, 0.5, 1))


@pytest.mark.parametrize("make", [
    lambda m, t: rt.Quad((0, 0, 0), (1, 0, 0), (0, 1, 0), m, transform=t),
    lambda m, t: rt.Box((0, 0, 0), (1, 1, 1), m, transform=t),
    lambda m, t: rt.Triangle((0, 0, 0), (1, 0, 0), (0, 1, 0), m, transform=t),
    lambda m, t: rt.Mesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], m, transform=t),
    lambda m, t: rt.Sphere((0, 0, 0), 1.0, m, transform=t),
], ids=["quad", "box", "triangle", "mesh", "sphere"])
@pytest.mark.parametrize("transform, message", [(SINGULAR_IN_PLANE, "zero|singular"), (PROJECTIVE, "affine")],
                         ids=["singular", "projective"])
def test_collapsed_or_projective_shapes_are_refused(make, transform, message):
    with pytest.raises(ValueError, match=message):
        make(rt.DiffuseLight(5.0), transform)


def test_a_mesh_of_collinear_triangles_is_refused():
    with pytest.raises(ValueError, match="zero area"):
        rt.Mesh([[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]], [[0, 1, 2], [1, 2, 3]], rt.DiffuseLight(1.0))


def test_scaling_a_mesh_to_nothing_is_refused_after_the_transform():
    mesh = rt.Mesh(np.eye(3), [[0, 1, 2]], rt.Lambertian(0.5))
    with pytest.raises(ValueError, match="zero area after its transform"):
        mesh.rotate_y(10)._compose(np.diag([0.0, 0.0, 1.0, 1.0]))


@pytest.mark.parametrize("radiance", [1e300, 3.5e38, (1.0, 1e39, 1.0)])
def test_radiance_beyond_float32_is_refused(radiance):
    with pytest.raises(ValueError, match="float32"):
        rt.DiffuseLight(radiance)
    with pytest.raises(ValueError, match="float32"):
        rt.Scene(camera=rt.Camera(lookfrom=(0, 0, -3), lookat=(0, 0, 0), vfov=40, width=4, height=4),
                 shapes=[rt.Sphere((0, 0, 0), 1, rt.Lambertian(0.5))], background=radiance)


# ---------------------------------------------------------------------------------- 7. memory bounded

HUGE_PLY = (b"ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\n"
            b"property float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\n"
            b"end_header\n" + b"\0" * 64)


def _xml_with_mesh(tmp_path, mesh: str, kind: str = "ply", face_normals: bool = True) -> Path:
    xml = tmp_path / "scene.xml"
    xml.write_text(scene_xml(f'<shape type="{kind}"><string name="filename" value="{mesh}"/>'
                             f'<boolean name="face_normals" value="{str(face_normals).lower()}"/></shape>',
                             width=8, height=8))
    return xml


@pytest.mark.parametrize("source", ["huge_header", "dev_zero"])
def test_a_mesh_is_checked_before_anything_is_allocated(tmp_path, source):
    if source == "huge_header":
        mesh = tmp_path / "huge.ply"
        mesh.write_bytes(HUGE_PLY)
    else:
        mesh = Path("/dev/zero")
    with pytest.raises(ValueError, match="declares|regular file"):
        rt.Mesh.load(mesh, rt.Lambertian(0.5))
    # the importer checks before Mitsuba's loader allocates: exit 2 in seconds, the file named
    proc = _rtbench("render", "--scene", _xml_with_mesh(tmp_path, str(mesh)), "--out", tmp_path / "r", timeout=60)
    assert proc.returncode == 2 and str(mesh) in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1


def test_a_mesh_too_large_for_memory_exits_3(tmp_path, monkeypatch):
    from reference_tracer.meshfile import checks

    mesh = tmp_path / "ok.ply"
    from mitsuba_scenes.translate import write_ply

    write_ply(mesh, np.eye(3), [[0, 1, 2]])
    monkeypatch.setattr(checks, "_available_memory", lambda: 10)
    with pytest.raises(MemoryError, match="GiB"):
        rt.Mesh.load(mesh, rt.Lambertian(0.5))
    from benchmarks.errors import exit_code

    assert exit_code(MemoryError()) == 3


def _mesh_with_face(tmp_path, kind: str, face) -> Path:
    """A mesh file of 3 vertices and the one triangle ``face``, in the format ``kind``."""
    import struct
    import zlib

    from mitsuba_scenes.translate import write_ply

    if kind == "ply_ascii":
        mesh = tmp_path / "tri.ply"
        mesh.write_text("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                        "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                        "0 0 0\n1 0 0\n0 1 0\n3 " + " ".join(map(str, face)) + "\n")
    elif kind == "ply_binary":
        mesh = tmp_path / "tri.ply"
        write_ply(mesh, [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [face])
    else:
        mesh = tmp_path / "tri.serialized"
        body = (struct.pack("<I", 0x1000) + b"tri\x00" + struct.pack("<QQ", 3, 1)
                + np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], "<f4").tobytes() + np.array(face, "<u4").tobytes())
        mesh.write_bytes(struct.pack("<HH", 0x041C, 4) + zlib.compress(body) + struct.pack("<QI", 0, 1))
    return mesh


@pytest.mark.parametrize("kind, face", [("ply_ascii", [0, 1, 7]), ("ply_ascii", [0, 1, -1]),
                                        ("ply_binary", [0, 1, 7]), ("serialized", [0, 1, 3])])
def test_a_face_index_past_the_vertices_is_refused_before_mitsuba_loads_the_mesh(tmp_path, kind, face):
    """Mitsuba 3.9.1's ply and serialized loaders take a triangle's vertex indices unchecked and
    compute vertex normals through them, outside their buffers (a heap corruption, then an
    abort); its obj loader checks them. The importer reads the triangles first and refuses the
    file: ValueError naming the mesh file, the face and the shape's line (was an IndexError from
    the normals, after Mitsuba had loaded it)."""
    from mitsuba_scenes import from_mitsuba

    mesh = _mesh_with_face(tmp_path, kind, face)
    xml = _xml_with_mesh(tmp_path, str(mesh), kind=kind.split("_")[0], face_normals=False)
    with pytest.raises(ValueError, match=rf"{re.escape(str(mesh))}: (mesh 0: )?face 0 is "
                                         rf"{re.escape(str(face))}, a vertex index out of range \[0, 3\) .*"
                                         rf"\({re.escape(str(xml))} \(line \d+, col \d+\)\)"):
        from_mitsuba(xml)
    if kind == "ply_ascii" and face[-1] == 7:   # the command a user runs: exit 2, one line naming the file
        proc = _rtbench("render", "--scene", xml, "--spp", "1", "--width", "8", "--out", tmp_path / "r")
        assert proc.returncode == 2, proc.stderr
        assert "internal error" not in proc.stderr and "tri.ply: face 0 is [0, 1, 7]" in proc.stderr, proc.stderr
        assert len(proc.stderr.strip().splitlines()) == 1


@pytest.mark.parametrize("kind, face", [("ply_ascii", [0, 1, 7]), ("ply_binary", [0, 1, 7])])
def test_mesh_load_refuses_a_face_index_past_the_vertices(tmp_path, kind, face):
    """rt.Mesh.load checks the faces before computing normals through them (was an IndexError)."""
    mesh = _mesh_with_face(tmp_path, kind, face)
    with pytest.raises(ValueError, match=rf"Mesh.load: {re.escape(str(mesh))}: face 0 is \[0, 1, 7\], "
                                         r"a vertex index out of range \[0, 3\)"):
        rt.Mesh.load(mesh, rt.Lambertian(0.5))


def test_a_mesh_object_whose_face_index_is_past_its_vertices_is_refused_at_its_node():
    """A mi.Mesh in a scene dict (Mitsuba checks none of its indices): refused with the dict's
    key, as every other problem of a mesh object is (was a ValueError of Mesh without it)."""
    from mitsuba_scenes import from_mitsuba
    from mitsuba_scenes.variants import import_mitsuba

    mi = import_mitsuba()
    mesh = mi.Mesh("tri", vertex_count=3, face_count=1, has_vertex_normals=False)
    params = mi.traverse(mesh)
    params["vertex_positions"] = np.array([0, 0, 0, 1, 0, 0, 0, 1, 0], dtype=np.float32)
    params["faces"] = np.array([0, 1, 7], dtype=np.uint32)
    params.update()
    scene = {"type": "scene", "tri": mesh,
             "sensor": {"type": "perspective", "film": {"type": "hdrfilm", "width": 4, "height": 4,
                                                        "rfilter": {"type": "box"}}}}
    with pytest.raises(ValueError, match=r"mesh object whose face 0 is \[0, 1, 7\], a vertex index out of range "
                                         r'\[0, 3\) \(dictionary node "tri"\)'):
        from_mitsuba(scene)


# ---------------------------------------------------------------------------------- 8. user errors, said as such

def test_deeply_nested_json_in_a_store_is_a_listed_problem(tmp_path):
    store = _small_store(tmp_path / "s")
    (store / "meta.json").write_text("[" * 100000 + "]" * 100000)
    with (store / RESULTS).open("a") as f:
        f.write('{"a": ' * 50000 + "1" + "}" * 50000 + "\n")
    assert main(["report", str(store), "--out", str(tmp_path / "o"), "--quiet"]) == 0
    md = (tmp_path / "o" / "summary.md").read_text()
    assert "nested too deeply" in md


def test_a_long_scene_file_name_renders(tmp_path):
    src = ROOT / "tests" / "fixtures"
    xml = src / "xml" / "box_rect_light.xml"
    long = tmp_path / ("s" * 240 + ".xml")
    long.write_text(xml.read_text())
    for extra in xml.parent.iterdir():  # meshes the file names beside it
        if extra.suffix in (".ply", ".obj"):
            (tmp_path / extra.name).write_bytes(extra.read_bytes())
    proc = _rtbench("render", "--scene", long, "--spp", "1", "--width", "8", "--out", tmp_path / "r", timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert all(len(p.name) < 255 for p in (tmp_path / "r").iterdir())


def test_a_full_disk_leaves_no_temporary_file_behind(tmp_path, monkeypatch):
    from reference_tracer import imageio

    store = _small_store(tmp_path / "s")
    out = tmp_path / "out"
    calls = {"n": 0}
    real = os.fsync

    def full(fd):
        calls["n"] += 1
        if calls["n"] >= 2:
            raise OSError(28, "No space left on device")
        return real(fd)

    monkeypatch.setattr(imageio.os, "fsync", full)
    assert main(["report", str(store), "--out", str(out), "--quiet"]) == 3
    assert not [p for p in out.rglob("*") if p.name.endswith(".tmp")]


def test_a_report_before_the_first_record_says_so(tmp_path, capsys):
    store = tmp_path / "s"
    store.mkdir()
    (store / "meta.json").write_text("{}")
    assert main(["report", str(store)]) == 2
    assert "no finished job yet" in capsys.readouterr().err


def test_a_text_file_as_a_mesh_names_the_file(tmp_path):
    mesh = tmp_path / "passwd.obj"
    mesh.write_text("root:x:0:0:root:/root:/bin/bash\n")
    with pytest.raises(ValueError, match="passwd.obj"):
        rt.Mesh.load(mesh, rt.Lambertian(0.5))
    proc = _rtbench("render", "--scene", _xml_with_mesh(tmp_path, str(mesh), kind="obj"), timeout=60)
    assert proc.returncode == 2 and "passwd.obj" in proc.stderr and "holds no triangles" in proc.stderr


OBJ_HEAD = "v 0 0 0\nv 1 0 0\nv 0 1 0\n"


@pytest.mark.parametrize("body, line", [
    ("vn nan 0 1\nf 1//1 2//1 3//1\n", 4),          # not a number
    ("vn 0 0 0\nf 1//1 2//1 3//1\n", 4),            # zero: no direction
    ("vn 1e999 0 0\nf 1//1 2//1 3//1\n", 4),        # overflows to infinity
    ("vn 0 0 1\nf 1 2//1 3//1\n", 5),               # a corner Mitsuba leaves undefined
    ("vn 0 0 1\nf 1//2 2//1 3//1\n", 5),            # an index past the normals
])
def test_bad_obj_normals_are_refused_with_their_line(tmp_path, body, line):
    mesh = tmp_path / "n.obj"
    mesh.write_text(OBJ_HEAD + body)
    with pytest.raises(ValueError, match=rf"n.obj line {line}"):
        rt.Mesh.load(mesh, rt.Lambertian(0.5))
    # face_normals=True ignores the normals, as Mitsuba's loader does (an index still counts)
    if "1//2" not in body:
        assert rt.Mesh.load(mesh, rt.Lambertian(0.5), face_normals=True).normals is None


@pytest.mark.parametrize("normal", [(np.nan, 0.0, 1.0), (0.0, 0.0, 0.0), (np.inf, 0.0, 0.0)])
def test_bad_ply_normals_are_refused(tmp_path, normal):
    """Mitsuba's PLY loader stores such a normal as it comes (NaN once normalised) and its
    shading turns NaN: Mesh.load and the importer refuse the file, naming it; rtbench exits 2."""
    from mitsuba_scenes.translate import write_ply

    mesh = tmp_path / "n.ply"
    write_ply(mesh, np.eye(3), [[0, 1, 2]], [(0.0, 0.0, 1.0), normal, (0.0, 0.0, 1.0)])
    with pytest.raises(ValueError, match="n.ply: vertex normal 1"):
        rt.Mesh.load(mesh, rt.Lambertian(0.5))
    # a vertex no face uses is never shaded: its normal does not matter
    write_ply(tmp_path / "unused.ply", np.vstack([np.eye(3), [[5.0, 5.0, 5.0]]]), [[0, 1, 2]],
              [(0.0, 0.0, 1.0)] * 3 + [normal])
    assert rt.Mesh.load(tmp_path / "unused.ply", rt.Lambertian(0.5)).normals[3].tolist() == [1.0, 0.0, 0.0]
    proc = _rtbench("render", "--scene", _xml_with_mesh(tmp_path, str(mesh), face_normals=False),
                    "--out", tmp_path / "r", timeout=120)
    assert proc.returncode == 2 and "n.ply" in proc.stderr and "not a unit vector" in proc.stderr, proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1


def test_obj_with_an_undefined_normal_exits_2_naming_its_line(tmp_path):
    mesh = tmp_path / "n.obj"
    mesh.write_text(OBJ_HEAD + "vn 0 0 1\nf 1//1 2//1 3//1\nf 1 2//1 3//1\n")
    proc = _rtbench("render", "--scene", _xml_with_mesh(tmp_path, str(mesh), kind="obj", face_normals=False),
                    "--out", tmp_path / "r", timeout=120)
    assert proc.returncode == 2 and "n.obj line 6" in proc.stderr, proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1


def test_concurrent_appends_never_interleave(tmp_path):
    """The store's own writer primitives hold under threads (the lock is per process)."""
    store = tmp_path / "s"

    def writer(k):
        for i in range(50):
            append_record(store, {"scene": "s", "renderer": "ours", "strategy": "mis", "spp": 1, "seed": k * 100 + i,
                                  "width": 1, "height": 1})

    threads = [threading.Thread(target=writer, args=(k,)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(read_records(store, dedupe=False)) == 200
    write_image(store, "images/x.exr", np.zeros((2, 2, 3)))
    with pytest.raises(ValueError):
        write_image(store, "../x.exr", np.zeros((2, 2, 3)))


def _serialized(tmp_path, body: bytes, *, version=4, meshes=1, name="m.serialized") -> str:
    import struct
    import zlib

    data = struct.pack("<HH", 0x041C, version) + zlib.compress(body)
    data += struct.pack("<Q" if version == 4 else "<I", 0) * meshes + struct.pack("<I", meshes)
    path = tmp_path / name
    path.write_bytes(data)
    return str(path)


def test_serialized_mesh_headers_are_checked_before_anything_is_allocated(tmp_path):
    """A Mitsuba .serialized mesh is compressed: a few bytes may declare billions of vertices.
    Its header is read (and only its header decompressed) before Mitsuba loads it."""
    import struct

    from reference_tracer.meshfile import check_serialized_file

    ok = _serialized(tmp_path, struct.pack("<I", 0x1000) + b"tri\x00" + struct.pack("<QQ", 3, 1) + bytes(48))
    assert check_serialized_file(ok)["vertices"] == 3
    huge = _serialized(tmp_path, struct.pack("<I", 0x2001) + b"x\x00" + struct.pack("<QQ", 2**40, 2**40),
                       name="huge.serialized")
    with pytest.raises(MemoryError, match="declares 1099511627776 vertices"):
        check_serialized_file(huge)
    with pytest.raises(ValueError, match="holds 1 mesh"):
        check_serialized_file(ok, 3)
    with pytest.raises(ValueError, match="not a Mitsuba serialized mesh"):
        check_serialized_file(__file__)
    (tmp_path / "bad.serialized").write_bytes(b"\x1c\x04\x04\x00" + b"not zlib at all")
    with pytest.raises(ValueError, match="does not decompress|truncated"):
        check_serialized_file(tmp_path / "bad.serialized")
    with pytest.raises(ValueError, match="not a regular file"):
        check_serialized_file("/dev/zero")
