"""``rtbench parity``: first-hit AOVs at pixel centres, ours vs Mitsuba; it points at translation errors."""
from __future__ import annotations

import dataclasses
import json

import pytest

import reference_tracer as rt
from benchmarks.cli import main
from benchmarks.parity import run_parity
from mitsuba_scenes import from_mitsuba, get_scene, list_scenes, to_mitsuba
from repo_paths import FIXTURES

XML = FIXTURES / "xml"


pytestmark = pytest.mark.usefixtures("fresh_registries")


@pytest.mark.parametrize("name", list_scenes())
def test_suite_scene_has_parity(name):
    report = run_parity(get_scene(name).with_camera_size(24, 16), name=name)
    assert report.passed, (report.summary(), report.findings)


def test_flipped_quad_is_named():
    scene = get_scene("cornell_box").with_camera_size(24, 16)
    d = to_mitsuba(scene)
    d["shape_002_quad"]["flip_normals"] = True    # a deliberate translation error
    report = run_parity(scene, mitsuba=d, name="flipped")
    assert not report.passed and report.counts["normal"] > 0
    assert any(f.startswith("shape 2 (Quad, Lambertian): normal reversed") for f in report.findings), report.findings


def test_wrong_fov_axis_blames_the_camera():
    scene = get_scene("cornell_box").with_camera_size(24, 16)   # not square: the axis matters
    d = to_mitsuba(scene)
    d["sensor"]["fov_axis"] = "x"
    report = run_parity(scene, mitsuba=d, name="fov")
    assert not report.passed and report.findings[0].startswith("camera:"), report.findings


def test_reflecting_light_is_named_by_albedo():
    """The importer's old error (an emitter without <bsdf> given diffuse 0.5) shows at once."""
    path = XML / "box_rect_light.xml"
    scene = from_mitsuba(path)
    shapes = [dataclasses.replace(s, material=rt.DiffuseLight(s.material.radiance, albedo=0.5))
              if s.material.emits else s for s in scene.shapes]
    report = run_parity(dataclasses.replace(scene, shapes=shapes), mitsuba=path, name="old_import")
    assert report.counts["albedo"] > 0
    assert any("DiffuseLight): albedo ours [0.5, 0.5, 0.5] vs Mitsuba [0.0, 0.0, 0.0]" in f for f in report.findings)


def test_cli_passes_on_hand_written_files(capsys):
    assert main(["parity", "--scene", str(XML / "two_sided.xml"), "--scene", str(XML / "camera_axes.xml"),
                 "--param", "fov_axis=diagonal"]) == 0, capsys.readouterr().err
    assert "camera_axes+fov_axis=diagonal: parity ok" in capsys.readouterr().out


@pytest.mark.parametrize("size, want", [([], (20, 12)), (["--width", "24"], (24, 24)),
                                        (["--width", "24", "--height", "10"], (24, 10))])
def test_cli_resizes_an_xml_file_with_width_and_height(tmp_path, capsys, size, want):
    """--width / --height resize a --scene XML file in both renderers (the films of the file
    Mitsuba loads too), as rtbench render resizes it; without them the file's own film (20x12).
    A diagonal fov_axis on a film of another aspect: the field of view follows the axis in both."""
    out = tmp_path / "rows.json"
    assert main(["parity", "--scene", str(XML / "camera_axes.xml"), "--param", "fov_axis=diagonal", *size,
                 "--json", str(out)]) == 0, capsys.readouterr().err
    (row,) = json.loads(out.read_text())
    assert (row["width"], row["height"]) == want and row["passed"]
    assert f"{want[0]}x{want[1]} pixel centres" in capsys.readouterr().out


def test_gate_stops_on_a_parity_failure_with_maps(tmp_path, capsys, monkeypatch):
    """A translation error in the importer (fov axis ignored, seen on a film that is not square):
    the gate renders nothing."""
    import benchmarks.gate
    import mitsuba_scenes.importer.sensor as sensor

    monkeypatch.setattr(sensor, "_vfov", lambda ctx, node, fov, axis, w, h: fov)
    monkeypatch.setattr(benchmarks.gate, "run_gate", lambda *a, **k: pytest.fail("the gate rendered despite parity"))
    code = main(["gate", "--scene", str(XML / "camera_axes.xml"), "--width", "8", "--height", "6", "--spp", "4",
                 "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert code == 1, err
    assert "parity FAILED" in err and "camera:" in err
    assert (tmp_path / "camera_axes_parity.png").is_file() and (tmp_path / "camera_axes_parity.exr").is_file()


class _Stop(ValueError):
    """Raised by a runner patched in place of the render: the command ends with exit 2 there."""


def _stop_at_render(monkeypatch, command: str) -> dict:
    """Patch the runner ``command`` calls after its parity check: it records its keywords and stops."""
    import benchmarks.gate
    import benchmarks.sweep

    seen = {}

    def runner(*args, **kwargs):
        seen.update(kwargs, args=args)
        raise _Stop("stopped where the render would start")

    module, attr = (benchmarks.gate, "run_gate") if command == "gate" else (benchmarks.sweep, "run_sweep")
    monkeypatch.setattr(module, attr, runner)
    return seen


@pytest.mark.parametrize("command", ["gate", "curves"])
def test_gate_and_curves_check_an_xml_files_parity_at_their_size(tmp_path, capsys, monkeypatch, command):
    """The parity check before gate and curves render an XML file is at their --width x --height
    (the size they render it at), not at the file's own film (camera_axes.xml: 20x12)."""
    seen = _stop_at_render(monkeypatch, command)
    code = main([command, "--scene", str(XML / "camera_axes.xml"), "--width", "8", "--height", "6",
                 "--spp" if command == "gate" else "--spps", "4", "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert code == 2 and "stopped where the render would start" in err, err
    assert "camera_axes: parity ok (8x6 pixel centres" in err, err
    assert "20x12" not in err and "warning" not in err, err
    size = (seen["width"], seen["height"]) if command == "gate" else (seen["args"][0][0].width,
                                                                      seen["args"][0][0].height)
    assert size == (8, 6)


@pytest.mark.parametrize("command", ["gate", "curves"])
def test_an_xml_file_without_a_film_is_checked_at_mitsubas_default_size(tmp_path, capsys, monkeypatch, command):
    """Mitsuba cannot load a film-less XML file at another size (there is no film to resize):
    its parity is checked at Mitsuba's default 768x576, one warning line says so, and the
    command goes on to render it at the size asked for."""
    text = (XML / "two_sided.xml").read_text()
    start, end = text.index("<film"), text.index("</film>") + len("</film>")
    path = tmp_path / "no_film.xml"
    path.write_text(text[:start] + text[end:])
    seen = _stop_at_render(monkeypatch, command)
    code = main([command, "--scene", str(path), "--width", "8", "--spp" if command == "gate" else "--spps", "4",
                 "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2 and "stopped where the render would start" in err, err
    assert (f"rtbench {command}: warning: no_film: the file has no <film>, so its parity is checked at "
            f"Mitsuba's default film size (768x576), not at 8x8\n") in err, err
    assert "no_film: parity ok (768x576 pixel centres" in err, err
    assert seen


@pytest.mark.parametrize("size", [(48, 32), (33, 17)])
def test_hairline_cracks_at_corners_are_edges_not_errors(size):
    """At 48x32 one pixel centre of cornell_box escapes through the corner of two of Mitsuba's
    float32 rectangles (ours hits a wall); rays a hundredth of a pixel away in Mitsuba hit it."""
    report = run_parity(get_scene("cornell_box").with_camera_size(*size), name="cornell_box")
    assert report.passed, report.findings
