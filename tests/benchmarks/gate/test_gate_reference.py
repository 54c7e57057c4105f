"""``rtbench gate --reference STORE``: features Mitsuba cannot render (Metal fuzz) gated against a trusted build."""
from __future__ import annotations

import dataclasses

import pytest

import reference_tracer as rt
from benchmarks.cli import main
from mitsuba_scenes.scene_files import clear_registry

FUZZ_SCENE = '''
import reference_tracer as rt

def build(width=8, height=8):
    return rt.Scene(camera=rt.Camera(lookfrom=(0, 1, 4), lookat=(0, 0.5, 0), vfov=40, width=width, height=height),
                    shapes=[rt.Quad((-3, 0, -3), (0, 0, 6), (6, 0, 0), rt.Lambertian(0.6)),
                            rt.Sphere((0, 0.5, 0), 0.5, rt.Metal((0.9, 0.8, 0.6), fuzz=0.3))],
                    max_depth=4, background=(0.8, 0.9, 1.0))
'''


pytestmark = pytest.mark.usefixtures("fresh_registries")


@pytest.fixture
def fuzz_store(tmp_path):
    path = tmp_path / "fuzz.py"
    path.write_text(FUZZ_SCENE)
    store = tmp_path / "ref"
    assert main(["gate", "--scene", str(path), "--width", "8", "--ref-spp", "4096", "--write-reference",
                 str(store), "--threads", "1"]) == 0
    return path, store


def _gate(path, store, tmp_path, *extra):
    return main(["gate", "--scene", str(path), "--width", "8", "--spp", "512", "--tail-spp", "0", "--threads", "1",
                 "--reference", str(store), "--out", str(tmp_path / "g"), *extra])


def test_metal_fuzz_is_gated_against_a_trusted_build(fuzz_store, tmp_path, capsys):
    path, store = fuzz_store
    assert _gate(path, store, tmp_path) == 0, capsys.readouterr().err
    assert "gate passed" in capsys.readouterr().out


def test_a_changed_build_fails_against_the_reference_store(fuzz_store, tmp_path, monkeypatch, capsys):
    path, store = fuzz_store
    real = rt.render

    def darker(*args, **kwargs):   # "a changed constant": 3% less light
        res = real(*args, **kwargs)
        return dataclasses.replace(res, mean=res.mean * 0.97, variance=res.variance * 0.97 ** 2)

    monkeypatch.setattr(rt, "render", darker)
    assert _gate(path, store, tmp_path) == 1
    assert "FAIL fuzz (mis" in capsys.readouterr().err


def test_changed_scene_or_unknown_build_is_refused(fuzz_store, tmp_path, capsys):
    path, store = fuzz_store
    assert _gate(path, store, tmp_path, "--reference-build", "nope") == 2
    assert "no records of build nope" in capsys.readouterr().err
    clear_registry()
    path.write_text(FUZZ_SCENE.replace("fuzz=0.3", "fuzz=0.2"))
    assert _gate(path, store, tmp_path) == 2
    assert "rendered from another scene description" in capsys.readouterr().err


def test_a_store_build_name_is_printed_as_text_not_markup(fuzz_store, tmp_path, capsys):
    """A results store is untrusted: a build name holding rich markup (``[bold]``, ``[link=...]``)
    shows in the verdict table as written, never as styling or a terminal link."""
    import json

    path, store = fuzz_store
    lines = (store / "results.jsonl").read_text().splitlines()
    records = [json.loads(line) for line in lines]
    for rec in records:
        rec["build"] = "evil[bold]x[link=file:///etc/passwd]y"
    (store / "results.jsonl").write_text("".join(json.dumps(rec) + "\n" for rec in records))
    capsys.readouterr()
    assert _gate(path, store, tmp_path) == 0, capsys.readouterr().err
    out = capsys.readouterr().out
    assert "evil[bold]x[link=file://" in out, out  # the table folds the rest of the cell onto its next line
