"""``rtbench corpus DIR``: a folder of Mitsuba scenes, each loaded, imported and judged.

The corpus is a small subset of real ones kept in ``tests/fixtures/corpus`` (sources and
licences in its ``SOURCES.md``): a scene that agrees, one refused in scope, one out of scope,
one Mitsuba cannot load and a fragment. One run over a copy of it (with a hostile file name
added) checks the statuses, the files written and the escaping; a rerun reuses the verdicts.
"""
from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from benchmarks.cli import main
from benchmarks.corpus.judge import compact_feature, out_of_scope, small_film
from benchmarks.corpus.results import feature_ranking, needs_text
from benchmarks.corpus.scan import scan
from repo_paths import FIXTURES

CORPUS = FIXTURES / "corpus"
AGREES = "bitterli/cornell-box/scene_v3.xml"
REFUSED = "mitsuba-data/tests/scenes/mesh_attributes/test_mesh_attributes_1_face_direct.xml"
OUT_OF_SCOPE = "mitsuba-data/docs/scenes/integrator_stokes_cbox.xml"
MITSUBA_FAILS = "mitsuba-data/docs/scenes/sensor_orthographic.xml"
FRAGMENT = "mitsuba-data/docs/scenes/include/sensor_scene.xml"
#: a file name with Markdown, HTML and a terminal escape sequence in it
HOSTILE = "evil|<b>*x*[l](u)\x1b[31m.xml"


@pytest.fixture(scope="module")
def corpus_run(tmp_path_factory):
    """One run over a copy of the fixture corpus plus a hostile name, then a rerun."""
    base = tmp_path_factory.mktemp("corpus")
    folder, out = base / "corpus", base / "out"
    shutil.copytree(CORPUS, folder)
    shutil.copy(folder / REFUSED, folder / "mitsuba-data/tests/scenes/mesh_attributes" / HOSTILE)
    args = ["corpus", str(folder), "--out", str(out), "--spp", "256", "--variant", "scalar_rgb", "--threads", "2",
            "--source", "fixture <corpus> | test"]
    return folder, out, args


def _records(out):
    data = json.loads((out / "corpus.json").read_text())
    return data, {r["path"]: r for r in data["scenes"]}


def test_corpus_statuses_files_escaping_and_resume(corpus_run, capsys):
    folder, out, args = corpus_run
    assert main(args) == 0
    printed = capsys.readouterr()
    data, recs = _records(out)
    hostile = "mitsuba-data/tests/scenes/mesh_attributes/" + HOSTILE

    assert recs[AGREES]["status"] == "agrees"
    assert max(abs(g) for g in recs[AGREES]["global_z"]) <= 4 and recs[AGREES]["share_z4"] <= 0.01
    assert recs[AGREES]["film_original"] == [1024, 1024] and recs[AGREES]["film"] == [48, 48]
    assert recs[REFUSED]["status"] == "refused" and recs[hostile]["status"] == "refused"
    assert "bsdf 'blendbsdf'" in [compact_feature(f) for f in recs[REFUSED]["reasons"]]
    assert all("line" not in f for f in recs[REFUSED]["reasons"])          # file locations dropped
    assert recs[OUT_OF_SCOPE]["status"] == "out-of-scope"
    assert recs[OUT_OF_SCOPE]["reasons"] == ["polarisation: integrator 'stokes'"]
    # both files the scene names are missing; Mitsuba loads its plugins in parallel, so either may be reported
    assert recs[MITSUBA_FAILS]["status"] == "mitsuba-fails"
    assert any(f in recs[MITSUBA_FAILS]["reasons"][0] for f in ("museum.exr", "matpreview.serialized"))
    assert FRAGMENT not in recs
    assert data["fragments"] == [{"path": FRAGMENT, "included_by": [MITSUBA_FAILS]}]
    assert data["counts"] == {"agrees": 1, "refused": 2, "out-of-scope": 1, "mitsuba-fails": 1}
    assert data["source"] == "fixture <corpus> | test" and data["dir"] == str(folder.resolve())
    assert all(isinstance(r["seconds"], float) for r in recs.values())

    md = (out / "corpus.md").read_text()
    assert "| bitterli/cornell-box/scene_v3.xml | agrees |" in md
    assert "fixture &lt;corpus&gt; \\| test" in md                           # --source escaped too
    assert "\x1b" not in md and "<b>" not in md and "evil\\|&lt;b&gt;\\*x\\*\\[l\\](u)" in md
    assert "\x1b" not in printed.out + printed.err and "evil|<b>*x*[l](u)\\x1b[31m.xml" in printed.out
    assert "1 agrees, 2 refused, 1 out-of-scope, 1 mitsuba-fails; 1 fragment(s) skipped" in printed.out

    # a rerun reuses every verdict; a changed file is judged again
    assert main(args + ["--quiet"]) == 0
    assert "0 judged now, 5 reused" in capsys.readouterr().out
    assert _records(out)[1] == recs
    scene = folder / REFUSED
    scene.write_text(scene.read_text() + "\n<!-- changed -->\n")
    assert main(args + ["--quiet"]) == 0
    assert "1 judged now, 4 reused" in capsys.readouterr().out


def test_corpus_of_another_folder_is_not_overwritten(tmp_path, capsys):
    (tmp_path / "scenes").mkdir()
    shutil.copy(CORPUS / OUT_OF_SCOPE, tmp_path / "scenes" / "s.xml")
    earlier = json.dumps({"format": "rtbench-corpus/1", "dir": "/elsewhere", "scenes": []})
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "corpus.json").write_text(earlier)
    assert main(["corpus", str(tmp_path / "scenes"), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    assert "results of another folder" in capsys.readouterr().err
    assert (tmp_path / "out" / "corpus.json").read_text() == earlier


def test_usage_errors_exit_2(tmp_path, capsys):
    assert main(["corpus", str(tmp_path / "missing")]) == 2
    assert main(["corpus", str(tmp_path), "--timeout", "0"]) == 2
    (tmp_path / "frag.xml").write_text("<bsdf type='diffuse'/>")
    assert main(["corpus", str(tmp_path), "--out", str(tmp_path / "o")]) == 2   # no scene, only a fragment
    assert "no scene XML" in capsys.readouterr().err


def test_scan_finds_fragments_by_include_and_by_root(tmp_path):
    (tmp_path / "inc").mkdir()
    (tmp_path / "a.xml").write_text('<scene version="3.0.0"><default name="d" value="inc"/>'
                                    '<include filename="$d/b.xml"/></scene>')
    (tmp_path / "inc" / "b.xml").write_text('<scene version="3.0.0"/>')
    (tmp_path / "c.xml").write_text('<bsdf type="diffuse"/>')
    (tmp_path / "broken.xml").write_text("<scene")
    found = scan(tmp_path)
    assert [p.name for p in found.scenes] == ["a.xml", "broken.xml"]      # Mitsuba judges the broken one
    assert {p.name: [q.name for q in by] for p, by in found.fragments.items()} == {"b.xml": ["a.xml"], "c.xml": []}


def test_a_difference_without_spread_is_seen():
    from reference_tracer import ImageEstimate

    from benchmarks.gate.agreement import agreement

    def est(mean, var):
        return ImageEstimate(mean=mean, variance=var, spp=64)

    mean, var = np.ones((4, 4, 3)), np.zeros((4, 4, 3))
    assert agreement(est(mean, var), est(mean, var)).spreadless == 0
    assert agreement(est(mean, var), est(mean * (1 + 1e-7), var)).spreadless == 0   # float precision
    a = agreement(est(mean, var), est(mean * 1.01, var))
    assert a.spreadless == 48 and not a.agrees                                      # no spread, yet different
    assert agreement(est(mean, var + 0.1), est(mean * 1.01, var)).spreadless == 0   # spread: the z-scores judge it


def test_small_film_and_features():
    assert small_film(768, 512, 48) == (48, 32) and small_film(1280, 720, 48) == (48, 27)
    assert small_film(2000, 10, 48) == (48, 1) and small_film(16, 16, 48) == (16, 16)
    assert out_of_scope(["integrator 'moment' (only 'path' and 'direct')"], plugins=[("integrator", "volpath")]) \
        == ["participating media: integrator 'volpath'"]
    assert out_of_scope(["medium 'homogeneous' inside a shape"]) == ["participating media: medium 'homogeneous'"]
    assert out_of_scope(["bsdf 'plastic'"], "At a.xml: ... only supported in spectral variants") \
        == ["spectral-only data: At a.xml: ... only supported in spectral variants"]
    assert out_of_scope(["bsdf 'plastic'", "emitter 'envmap' (only 'area')"]) == []
    recs = [{"status": "refused", "reasons": ["bsdf 'plastic'", "emitter 'envmap' (only 'area')"]},
            {"status": "refused", "reasons": ["emitter 'envmap' (only 'area')"]},
            {"status": "agrees"}]
    assert feature_ranking(recs) == [("emitter 'envmap'", 2, 1), ("bsdf 'plastic'", 1, 0)]
    order = {f: i for i, (f, _, _) in enumerate(feature_ranking(recs))}
    assert needs_text(recs[0], order) == "emitter 'envmap'; bsdf 'plastic'"


def test_a_scene_past_its_time_limit_is_recorded_and_retried_under_a_longer_one(tmp_path, capsys):
    (tmp_path / "scenes").mkdir()
    shutil.copy(CORPUS / AGREES, tmp_path / "scenes" / "cbox.xml")
    args = ["corpus", str(tmp_path / "scenes"), "--out", str(tmp_path / "out"), "--spp", "1000000", "--variant",
            "scalar_rgb", "--threads", "1", "--quiet"]
    assert main(args + ["--timeout", "0.5"]) == 0
    rec = _records(tmp_path / "out")[1]["cbox.xml"]
    assert rec["status"] == "timeout" and rec["timeout_s"] == 0.5 and "0.5 s" in rec["reasons"][0]
    assert main(args + ["--timeout", "0.5"]) == 0
    assert "0 judged now, 1 reused" in capsys.readouterr().out
    assert main(args + ["--timeout", "0.6"]) == 0                        # a longer limit: judged again
    assert "1 judged now, 0 reused" in capsys.readouterr().out


def test_film_size_is_the_scene_at_another_size_on_both_sides():
    """``film_size`` gives what the file's own size parameters give, in Mitsuba and in our import."""
    from mitsuba_scenes import from_mitsuba
    from mitsuba_scenes.render import film_sizes, load_file
    from mitsuba_scenes.variants import import_mitsuba

    mi = import_mitsuba("scalar_rgb")
    path = FIXTURES / "published" / "bitterli" / "veach-mis" / "scene_v3.xml"
    own = {"resx": "48", "resy": "27"}
    assert film_sizes(path) == [(1280, 720)] and film_sizes(path, params=own) == [(48, 27)]
    assert from_mitsuba(path, film_size=(48, 27)).camera == from_mitsuba(path, own).camera
    a, b = load_file(path, film_size=(48, 27)), mi.load_file(str(path), **own)
    assert list(a.sensors()[0].film().size()) == [48, 27]
    assert str(mi.traverse(a.sensors()[0])["x_fov"]) == str(mi.traverse(b.sensors()[0])["x_fov"])
    with pytest.raises(ValueError, match="film_size"):
        from_mitsuba(path, film_size=(0, 27))


def test_reading_a_file_first_leaves_its_path_folders_to_the_import():
    """film_sizes and load_file restore Mitsuba's file resolver, so from_mitsuba still sees the
    folders a file's ``<path>`` adds (it finds meshes there) after the corpus has parsed it."""
    from mitsuba_scenes import from_mitsuba
    from mitsuba_scenes.importer import UnsupportedSceneError
    from mitsuba_scenes.render import film_sizes, load_file
    from mitsuba_scenes.variants import import_mitsuba

    mi = import_mitsuba("scalar_rgb")
    path = CORPUS / OUT_OF_SCOPE            # its meshes are in ../../common, through <path>
    before = [str(p) for p in mi.file_resolver()]
    film_sizes(path)
    with pytest.raises(RuntimeError, match="polarized mode"):   # Mitsuba's RGB variants refuse stokes
        load_file(path, film_size=(8, 8))
    assert [str(p) for p in mi.file_resolver()] == before
    with pytest.raises(UnsupportedSceneError) as info:
        from_mitsuba(path, film_size=(8, 8))
    assert not any("cannot be used" in f for f in info.value.features), info.value.features
