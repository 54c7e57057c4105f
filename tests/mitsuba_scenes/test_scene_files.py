"""``--scene PATH`` / ``--param``: user scenes (Mitsuba XML or Python files) beside the suite."""
from __future__ import annotations

import json

import pytest

import reference_tracer as rt
from benchmarks.cli import main
from mitsuba_scenes import get_scene, known_scenes, list_scenes
from mitsuba_scenes.scene_files import PYTHON_DEFAULT_SIZE, parse_params, register_scene_file, scene_file
from repo_paths import FIXTURES

XML = FIXTURES / "xml"

PY_SCENE = '''
import reference_tracer as rt

def build(width=24, height=16, light=10.0):
    return rt.Scene(camera=rt.Camera(lookfrom=(0, 1, 4), lookat=(0, 0.5, 0), vfov=40, width=width, height=height),
                    shapes=[rt.Quad((-3, 0, -3), (0, 0, 6), (6, 0, 0), rt.Lambertian(0.7)),
                            rt.Quad((-0.5, 2, -0.5), (1, 0, 0), (0, 0, 1), rt.DiffuseLight(float(light)))],
                    max_depth=3, background=(0.1, 0.1, 0.1))
'''


pytestmark = pytest.mark.usefixtures("fresh_registries")


@pytest.fixture
def py_scene(tmp_path):
    path = tmp_path / "my_scene.py"
    path.write_text(PY_SCENE)
    return path


def test_xml_file_registers_with_params_and_resizes():
    entry = register_scene_file(XML / "camera_axes.xml", {"fov_axis": "y"})
    assert entry.name == "camera_axes+fov_axis=y" and entry.kind == "xml"
    assert entry.name in known_scenes() and entry.name not in list_scenes()
    own = get_scene(entry.name)
    assert (own.camera.width, own.camera.height) == (20, 12)
    assert own.camera.vfov == pytest.approx(50.0)          # fov_axis=y: the fov is vertical
    small = get_scene(entry.name, width=10, height=6)
    assert (small.camera.width, small.camera.height) == (10, 6)
    other = register_scene_file(XML / "camera_axes.xml", {"fov_axis": "x"})
    assert other.content_hash != entry.content_hash      # the parameters are part of the hash


def test_xml_file_resized_keeps_its_fov_axis():
    """fov_axis=x keeps the horizontal field of view at any size, as Mitsuba's film does: a
    20x12 file with 50 degrees along x built square has 50 degrees vertically too, everywhere
    the harness builds it (and the same camera as the file imported at that film size)."""
    from mitsuba_scenes import from_mitsuba

    from benchmarks.scenes import scene_at

    from mitsuba_scenes.render import load_file
    from mitsuba_scenes.variants import import_mitsuba

    entry = register_scene_file(XML / "camera_axes.xml", {"fov_axis": "x"})
    assert get_scene(entry.name).camera.vfov == pytest.approx(31.26, abs=0.01)  # 50 degrees across 20 pixels
    imported = from_mitsuba(XML / "camera_axes.xml", {"fov_axis": "x"}, film_size=(16, 16)).camera
    mi = import_mitsuba("scalar_rgb")
    sensor = load_file(XML / "camera_axes.xml", params={"fov_axis": "x"}, film_size=(16, 16)).sensors()[0]
    assert float(mi.traverse(sensor)["x_fov"]) == pytest.approx(50.0, abs=1e-4)  # Mitsuba's own, square film
    for scene in (get_scene(entry.name, width=16, height=16), scene_at(entry.name, 16, 16)):
        assert scene.camera.vfov == pytest.approx(50.0) and scene.camera == imported


def test_python_file_build_and_params(py_scene):
    entry = register_scene_file(py_scene, {"light": "5"})
    scene = get_scene(entry.name, width=8, height=4)
    assert (scene.camera.width, scene.camera.height) == (8, 4)
    assert scene.shapes[1].material.radiance == (5.0, 5.0, 5.0)
    with pytest.raises(ValueError, match=r"build\(\) takes no parameter\(s\) \['bogus'\]"):
        register_scene_file(py_scene, {"bogus": "1"})


def test_python_file_as_documented_needs_no_defaults(tmp_path, capsys):
    """``build(width, height, **params)`` as docs/mitsuba.md writes it: registered at the suite's
    size (PYTHON_DEFAULT_SIZE), rendered at the size asked for."""
    path = tmp_path / "plain.py"
    path.write_text(PY_SCENE.replace("def build(width=24, height=16, light=10.0):", "def build(width, height, light=5):"))
    entry = register_scene_file(path)
    scene = get_scene(entry.name)
    assert (scene.camera.width, scene.camera.height) == PYTHON_DEFAULT_SIZE
    assert main(["render", "--scene", str(path), "--spp", "1", "--width", "6", "--out", str(tmp_path)]) == 0, \
        capsys.readouterr().err
    assert rt.read_exr(tmp_path / "plain_6x6_mis_spp1_seed0.exr").shape[:2] == (6, 6)


@pytest.mark.parametrize("body, message", [
    ("def build(size):\n    return None", r"build\(\) must accept \(width, height\); it accepts \['size'\]"),
    ("def build(width, height):\n    return [][1]", r"build\(\): IndexError: list index out of range"),
    ("def build(width, height):\n    raise RuntimeError('boom')", r"build\(\): RuntimeError: boom"),
    ("def build(width, height):\n    return len(3)", r"build\(\): TypeError: object of type 'int' has no len"),
])
def test_python_file_errors_are_bad_input(tmp_path, capsys, body, message):
    """An error inside the user's build() is theirs: named as raised, exit 2, never 'internal error'."""
    path = tmp_path / "broken.py"
    path.write_text(body + "\n")
    with pytest.raises(ValueError, match=message):
        register_scene_file(path)
    assert main(["render", "--scene", str(path), "--spp", "1", "--width", "4", "--out", str(tmp_path)]) == 2
    assert "internal error" not in capsys.readouterr().err


def test_unsupported_xml_is_refused_with_file_and_line(tmp_path):
    bad = tmp_path / "bad.xml"
    bad.write_text('<scene version="3.0.0">\n  <sensor type="thinlens"/>\n  <shape type="disk"/>\n</scene>\n')
    with pytest.raises(ValueError) as err:
        register_scene_file(bad)
    assert "disk" in str(err.value) and "bad.xml (line 3" in str(err.value)
    assert scene_file("bad") is None


def test_parse_params_and_name_clash(tmp_path):
    assert parse_params(["a=1", "b = x"]) == {"a": "1", "b": "x"}
    clash = tmp_path / "cornell_box.py"
    clash.write_text(PY_SCENE)
    with pytest.raises(ValueError, match="like a suite scene"):
        register_scene_file(clash)


def test_cli_param_without_scene_is_a_usage_error(capsys):
    assert main(["render", "cornell_box", "--param", "x=1", "--spp", "1", "--width", "4"]) == 2
    assert "--param applies to scene files" in capsys.readouterr().err


def test_curves_records_carry_scene_file_hash_and_source(tmp_path, capsys):
    out = tmp_path / "store"
    code = main(["curves", "--scene", str(XML / "box_rect_light.xml"), "--width", "8", "--height", "8",
                 "--strategies", "mis", "--spp", "1,2", "--seeds", "1", "--reference-spp", "16", "--no-mitsuba",
                 "--out", str(out), "--quiet", "--threads", "1"])
    assert code == 0, capsys.readouterr().err
    records = [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()]
    assert {r["scene"] for r in records} == {"box_rect_light"}
    assert all(r["scene_source"] == str((XML / "box_rect_light.xml").resolve()) for r in records)
    scene = get_scene("box_rect_light", width=8, height=8)
    assert all(r["scene_hash"] == scene.content_hash()[:16] for r in records)
    meta = json.loads((out / "meta.json").read_text())
    assert meta["scene_files"]["box_rect_light"]["source"].endswith("box_rect_light.xml")
    assert meta["references"]["box_rect_light"]["scene_source"].endswith("box_rect_light.xml")


def test_render_cli_takes_a_python_scene_file(py_scene, tmp_path, capsys):
    code = main(["render", "--scene", str(py_scene), "--param", "light=3", "--spp", "2", "--width", "6",
                 "--out", str(tmp_path)])
    assert code == 0, capsys.readouterr().err
    img = rt.read_exr(tmp_path / "my_scene+light=3_6x6_mis_spp2_seed0.exr")  # names never collide (issue 16)
    assert img.shape[:2] == (6, 6)


def test_run_preset_takes_scene_files_only_when_given():
    from benchmarks.sweep.presets import preset_groups

    entry = register_scene_file(XML / "two_sided.xml")
    groups = preset_groups("quick", scenes=[entry.name])
    assert [g.scenes for g in groups] == [(entry.name,)]          # no seed comparison: not cornell_box
    assert preset_groups("quick")[0].scenes == tuple(list_scenes())  # the default stays the suite
