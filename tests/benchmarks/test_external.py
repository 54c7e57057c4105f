"""External renderers (``--renderer 'CMD'``): Mitsuba's own command-line program as a third curve."""
from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path

import pytest

from benchmarks.cli import main
from benchmarks.external import register_external
from repo_paths import FIXTURES

XML = FIXTURES / "xml"
MITSUBA_CLI = shutil.which("mitsuba", path=str(Path(sys.executable).parent)) or shutil.which("mitsuba")


pytestmark = pytest.mark.usefixtures("fresh_registries")


def _curves(tmp_path, *renderers):
    out = tmp_path / "store"
    args = ["curves", "--scene", str(XML / "sphere_constant.xml"), "--width", "8", "--height", "6",
            "--strategies", "mis", "--spp", "2,4,16,64", "--seeds", "2", "--reference-spp", "2048", "--no-mitsuba",
            "--out", str(out), "--quiet", "--threads", "1"]
    for r in renderers:
        args += ["--renderer", r]
    return main(args), out


@pytest.mark.skipif(MITSUBA_CLI is None, reason="the mitsuba command-line program is not installed")
def test_mitsuba_cli_as_an_external_renderer(tmp_path, capsys):
    code, out = _curves(tmp_path, f"{MITSUBA_CLI} -m scalar_rgb -D spp={{spp}} -D seed={{seed}} -o {{out}} {{scene_xml}}")
    assert code == 0, capsys.readouterr().err
    records = [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()]
    ext = [r for r in records if r["renderer"] == "ext-mitsuba"]
    assert len(ext) == 8 and {r["strategy"] for r in ext} == {"external"}
    assert all(r["build"].startswith("ext-") and r["reference_variant"] != "scalar_rgb" for r in ext)
    rows = {r["renderer"]: r for r in json.loads((out / "summary.json").read_text())["rows"]}
    assert rows["ext-mitsuba"]["bias_significant"] is False      # agrees with the llvm reference
    assert -0.8 < rows["ext-mitsuba"]["slope"] < -0.2


def test_a_failing_command_fails_its_jobs_with_the_reason(tmp_path, capsys):
    code, out = _curves(tmp_path, "false {scene_xml} {out}")
    assert code == 3  # a job that could not be rendered: an error, not a verdict (docs/rtbench.md, exit status)
    err = capsys.readouterr().err
    assert "ext-false exited with status 1" in err


def test_template_must_name_scene_and_output():
    with pytest.raises(ValueError, match=r"must contain \{scene_xml\}"):
        register_external("render -o {out}")
    assert register_external("a {scene_xml} {out}").name == "ext-a"
    assert register_external("a --x {scene_xml} {out}").name == "ext-a-2"   # another command, another name


@pytest.mark.slow
@pytest.mark.skipif(MITSUBA_CLI is None, reason="the mitsuba command-line program is not installed")
def test_gate_an_external_renderer(tmp_path, capsys):
    """The gate's verdict on the mitsuba CLI (16 batches of scalar_rgb) against the llvm reference (~30 s)."""
    code = main(["gate", "--scene", str(XML / "sphere_constant.xml"), "--width", "8", "--spp", "64",
                 "--ref-spp", "2048", "--out", str(tmp_path),
                 "--renderer", f"{MITSUBA_CLI} -m scalar_rgb -D spp={{spp}} -D seed={{seed}} -o {{out}} {{scene_xml}}"])
    assert code == 0, capsys.readouterr().err
    assert "gate passed" in capsys.readouterr().out


@pytest.mark.skipif(MITSUBA_CLI is None, reason="the mitsuba command-line program is not installed")
def test_speed_times_an_external_renderer_in_the_same_rounds(tmp_path, capsys):
    """``rtbench speed --renderer``: the mitsuba CLI runs in the paired rounds beside ours and
    Mitsuba, with its own rows (paths/s, RMSE, ratios against each variant)."""
    cmd = f"{MITSUBA_CLI} -m scalar_rgb -D spp={{spp}} -D seed={{seed}} -o {{out}} {{scene_xml}}"
    path = tmp_path / "speed.json"
    code = main(["speed", "--scene", str(XML / "sphere_constant.xml"), "--width", "8", "--height", "6",
                 "--spp", "4", "--repeats", "2", "--threads", "1", "--strategies", "mis", "--variant", "scalar_rgb",
                 "--rr-depth", "5", "--reference-kind", "ours", "--reference-spp", "256", "--renderer", cmd,
                 "--json", str(path)])
    out = capsys.readouterr().out
    assert code == 0
    assert "ext-mitsuba" in out and "wall clock" in out
    res = json.loads(path.read_text())["render"]
    assert res["config"]["externals"] == {"ext-mitsuba": cmd}
    ext = [r for r in res["runs"] if r["renderer"] == "ext-mitsuba"]
    assert len(ext) == 2 and all(r["strategy"] == "external" and r["seconds"] > 0 for r in ext)
    assert all(r["rr_depth"] == 5 and r["paths"] == 8 * 6 * 4 for r in ext)
    # the same scene at the same spp: its error is of the same order as Mitsuba's in-process render
    mits = [r for r in res["runs"] if r["renderer"] == "mitsuba"]
    assert max(r["rmse"] for r in ext) < 5 * max(r["rmse"] for r in mits) + 1e-3
    row = [r for r in res["summary"] if r["renderer"] == "ext-mitsuba"][0]
    assert row["label"] == "ext-mitsuba" and row["ratio_scalar_rgb"] > 0
    # a command that fails stops the benchmark before timing, with its message
    assert main(["speed", "--scene", str(XML / "sphere_constant.xml"), "--width", "8", "--spp", "4", "--repeats",
                 "1", "--variant", "scalar_rgb", "--reference-kind", "ours", "--reference-spp", "64", "--quiet",
                 "--renderer", "false {scene_xml} {out}"]) != 0
    assert "ext-false exited with status 1" in capsys.readouterr().err
    # --renderer needs the render benchmark
    assert main(["speed", "--rays", "--renderer", cmd, "--quiet"]) == 2


@pytest.mark.skipif(MITSUBA_CLI is None, reason="the mitsuba command-line program is not installed")
def test_compare_runs_the_given_command_for_the_external_curves_variance(tmp_path, capsys):
    """``rtbench compare A B --renderer CMD``: B's external curve gets its per-pixel variance
    from 16 batches of that very command (same build ``ext-<hash>``); without the command
    the curve says it rests on its stored images."""
    cmd = f"{MITSUBA_CLI} -m scalar_rgb -D spp={{spp}} -D seed={{seed}} -o {{out}} {{scene_xml}}"
    code_a, a = _curves(tmp_path / "a", cmd)
    code_b, b = _curves(tmp_path / "b", cmd)
    assert code_a == code_b == 0
    for extra, note in (([], "none: ext-mitsuba's command was not given as --renderer"),
                        (["--renderer", cmd], "ext-mitsuba in 16 batches at 256 spp")):
        path = tmp_path / "cmp.json"
        assert main(["compare", str(a), str(b), "--tail-spp", "256", "--quiet", "--out", str(tmp_path / "page"),
                     "--json", str(path), *extra]) == 0
        rows = {r["renderer"]: r for r in json.loads(path.read_text())}
        assert rows["ext-mitsuba"]["tails"] == note
        assert rows["ext-mitsuba"]["verdict"] == "pass"


def test_compare_says_when_the_given_command_fails(tmp_path):
    """An external command that fails while compare runs it for B's variance does not stop
    the comparison: the curve says why it rests on its stored images."""
    from benchmarks.compare import estimator_knowledge
    from mitsuba_scenes.scene_files import register_scene_file

    entry = register_scene_file(XML / "sphere_constant.xml")
    ext = register_external("false {scene_xml} {out}")
    knowledge = estimator_knowledge(tail_spp=32, externals=[ext])
    from mitsuba_scenes import get_scene

    scene = get_scene(entry.name).with_camera_size(8, 6)
    record = {"build": ext.build, "scene_source": entry.path, "scene_hash": scene.content_hash()[:16]}
    note = knowledge((entry.name, ext.name, "external", 8, 6), [record]).note
    assert note.startswith("none: ext-false exited with status 1")
    # a scene the user did not name with --scene is never loaded from the file the store names
    gone = dict(record, scene_source=str(tmp_path / "gone.xml"))
    note = knowledge(("gone", ext.name, "external", 8, 6), [gone]).note
    assert note.startswith("none: scene 'gone' is not a suite scene") and "--scene PATH" in note
