"""``rtbench speed --isa``: another build of our core timed in the same paired rounds as the
installed one, with its own rows, headline and verdicts; clear errors where the CPU cannot run
the build or the build fails. And ``--scaling``: every axis of cost against work, ours beside
Mitsuba, with build times and the SVG of the curves.

The fast tests stand the installed core in for the build (no compile); the slow one builds
the core for AVX2 (a minute or more). Nothing here asserts a speed.
"""
from __future__ import annotations

import json
import xml.etree.ElementTree as ET

import pytest

from benchmarks.cli import main
from benchmarks.speed import builds
from build_util import cpu_flags

TINY = ["--width", "8", "--height", "6", "--spp", "2", "--repeats", "2", "--threads", "2", "--strategies", "mis",
        "--rr-depth", "5", "--reference-kind", "ours", "--reference-spp", "16"]


def _installed_as_build(monkeypatch):
    """The installed core stands in for the build; returns the folders the builds were asked to use."""
    from reference_tracer.build import core_path

    folders = []
    monkeypatch.setattr(builds, "build_isa", lambda isa, folder, **kw: folders.append(folder) or core_path())
    monkeypatch.setattr(builds, "build_target", lambda folder: "the installed core, standing in")
    return folders


def test_isa_build_has_its_own_rows_headline_and_verdicts(tmp_path, capsys, monkeypatch, jit_variant):
    folders = _installed_as_build(monkeypatch)
    variant = jit_variant or "scalar_rgb"
    path = tmp_path / "speed.json"
    rc = main(["speed", "cornell_box", *TINY, "--variant", variant, "--isa", "avx2", "--cache", str(tmp_path),
               "--render", "--rays", "--triangles", "500", "--ray-count", "2000", "--json", str(path)])
    out = capsys.readouterr().out
    assert rc == 0, out
    assert "rtbench speed, suite: ours mis, avx2 build vs Mitsuba" in out and "ours mis, avx2 build" in out
    got = json.loads(path.read_text())
    res = got["render"]
    assert res["config"]["builds"] == {"avx2": str(builds.build_isa("avx2", None))}
    # built in a fresh private folder, never in (nor reused from) the cache: a build folder runs code
    assert folders[0].name.startswith("rtbench-core-avx2-") and tmp_path not in folders[0].parents
    runs = [(r["round"], r.get("build") or "") for r in res["runs"] if r["renderer"] == "ours"]
    assert sorted(runs) == [(0, ""), (0, "avx2"), (1, ""), (1, "avx2")]   # both builds in every round
    for run in (r for r in res["runs"] if r["renderer"] == "ours"):
        twin = [x for x in res["runs"] if x["renderer"] == "ours" and x["round"] == run["round"]]
        assert twin[0]["mse"] == twin[1]["mse"]                             # same core, same seed: same image
    row = next(r for r in res["summary"] if r["label"] == "ours mis, avx2 build")
    assert row["build"] == "avx2" and len(row[f"round_ratios_{variant}"]) == 2
    head = res["build_suites"]["avx2"]["rows"][0]
    assert head["scene"] == "cornell_box" and head[f"round_ratios_{variant}"] == row[f"round_ratios_{variant}"]
    # Like for like: where this CPU's Mitsuba kernels are wider than an AVX2 CPU's, Mitsuba also
    # renders in the build's worker with kernels for AVX2 (8 lanes), and the build pairs with it.
    native = got["render"]["mitsuba"]["versions"]["llvm_target"] if jit_variant else None
    same_isa = f"Mitsuba {variant}, avx2 kernels"
    if native and native["vector_width"] != 8:
        assert res["mitsuba_targets"] == {"avx2": "haswell, 8 lanes"}
        theirs = sorted((r["round"], r["paths_per_second"]) for r in res["runs"]
                        if r["renderer"] == "mitsuba" and r.get("build") == "avx2")
        ours = sorted((r["round"], r["paths_per_second"]) for r in res["runs"]
                      if r["renderer"] == "ours" and r.get("build") == "avx2")
        assert len(theirs) == 2 and row[f"round_ratios_{variant}"] == [a / b for (_, a), (_, b) in zip(ours, theirs)]
        assert row[f"against_{variant}"] == head[f"against_{variant}"] == same_isa
        assert res["build_suites"]["avx2"]["against"] == {variant: same_isa}
        assert f"{same_isa}: Mitsuba in the avx2 build's worker, Dr.Jit's kernels compiled for haswell" in out
    else:
        assert not any(r.get("build") for r in res["runs"] if r["renderer"] == "mitsuba")
    installed = next(r for r in res["summary"] if r["label"] == "ours mis")
    assert installed.get(f"against_{variant}") == f"Mitsuba {variant}"   # the installed core: this CPU's kernels
    rays = [(r["kind"], r["build"]) for r in got["rays"]["rows"]]
    # every build's own tree figures (the installed core stands in: the same tree, built in the worker)
    for mine, build_row in zip(got["rays"]["rows"][::2], got["rays"]["rows"][1::2]):
        assert build_row["bvh_bytes_per_triangle"] == mine["bvh_bytes_per_triangle"] > 0
        assert build_row["bvh_nodes"] == mine["bvh_nodes"] and build_row["build_seconds"] > 0
        assert "ours_rss_growth_mib" not in build_row   # a worker's memory is its own process's
    assert rays == [("primary", None), ("primary", "avx2"), ("random", None), ("random", "avx2")]
    if jit_variant:
        assert all(len(r["round_ratios"]) == 2 and r["agree_hit_agreement"] > 0.999 for r in got["rays"]["rows"])
        kernels = [r["mitsuba_kernels"] for r in got["rays"]["rows"]]
        if native["vector_width"] != 8:   # the build's queries pair with Mitsuba's AVX2 kernels, timed apart
            assert kernels == [None, "avx2", None, "avx2"] and got["rays"]["mitsuba"]["targets"] == {
                "avx2": "haswell, 8 lanes"}
            for mine, build_row in zip(got["rays"]["rows"][::2], got["rays"]["rows"][1::2]):
                assert mine["mitsuba_seconds"] != build_row["mitsuba_seconds"]
                assert build_row["round_ratios"] == [m / x for x, m in zip(build_row["ours_seconds"],
                                                                             build_row["mitsuba_seconds"])]
            assert "the avx2 build's rows pair with Mitsuba's kernels compiled for haswell, 8 lanes" in " ".join(
                out.split())   # the note, as the console wrapped it
        else:
            assert kernels == [None] * 4
    verdicts = got["verdicts"]
    subjects = [v["subject"] for v in verdicts]
    assert "cornell_box (avx2 build)" in subjects or not jit_variant
    if native and native["vector_width"] != 8:
        assert {v["against"] for v in verdicts if v["benchmark"] == "render" and v["build"] == "avx2"} == {same_isa}
        assert {v["against"] for v in verdicts if v["benchmark"] == "rays" and v["build"] == "avx2"
                and v["status"] != "not judged"} <= {"Embree (Mitsuba's avx2 kernels)"}
    assert "suite geometric mean (avx2 build)" in subjects and "1M triangles, random (avx2 build)" in subjects
    assert list(dict.fromkeys((v["benchmark"], v["build"]) for v in verdicts)) == [
        ("render", None), ("render", "avx2"), ("rays", None), ("rays", "avx2")]   # each build's after the installed


def test_mitsuba_kernels_for_the_isa_only_where_narrower_and_settable(monkeypatch):
    # Mitsuba runs with an ISA's kernels in the build's worker only where this CPU's kernels are
    # wider; where the target cannot be set there (an old Dr.Jit), the build pairs with this
    # CPU's kernels, and the run says why instead of stopping.
    from benchmarks.speed import common

    def worker_that_cannot(function, *args, **kwargs):
        raise RuntimeError(f"{function} failed with the core x.so:\nTraceback ...\n"
                           "RuntimeError: Dr.Jit 1.0 does not export jit_llvm_set_target")

    def worker(function, *args, **kwargs):
        assert (function, args) == ("benchmarks.speed.common.use_mitsuba_kernels", ("llvm_ad_rgb", "avx2"))
        return {"cpu": "haswell", "vector_width": 8, "avx512": False}

    monkeypatch.setattr(common, "llvm_target", lambda: {"cpu": "rocketlake", "vector_width": 16, "avx512": True})
    said = []
    assert common.mitsuba_kernel_workers({"avx2": worker_that_cannot}, "llvm_ad_rgb", said.append) == (
        {}, {}, {"avx2": "RuntimeError: Dr.Jit 1.0 does not export jit_llvm_set_target"})
    assert said == ["Mitsuba llvm_ad_rgb with avx2 kernels cannot run here (RuntimeError: Dr.Jit 1.0 does not export "
                    "jit_llvm_set_target): the avx2 build pairs with this CPU's kernels"]
    assert common.mitsuba_kernel_workers({"avx2": worker}, "llvm_ad_rgb") == (
        {"avx2": worker}, {"avx2": "haswell, 8 lanes"}, {})
    assert common.mitsuba_kernel_workers({"avx2": worker}, "scalar_rgb") == ({}, {}, {})
    assert common.mitsuba_kernel_workers({"avx512": worker}, "llvm_ad_rgb") == ({}, {}, {})   # already 16 lanes
    monkeypatch.setattr(common, "llvm_target", lambda: {"cpu": "znver3", "vector_width": 8, "avx512": False})
    assert common.mitsuba_kernel_workers({"avx2": worker}, "llvm_ad_rgb") == ({}, {}, {})   # an AVX2 CPU's own


def test_isa_the_cpu_cannot_run_or_a_build_that_fails(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(builds, "cpu_flags", frozenset)
    assert main(["speed", "--isa", "avx2", "--cache", str(tmp_path), "--quiet"]) == 2
    assert "this CPU cannot run an avx2 build (-march=x86-64-v3): /proc/cpuinfo lists no abm, avx" in (
        capsys.readouterr().err)
    monkeypatch.setattr(builds, "cpu_flags", lambda: builds.ISAS["avx512"][1])

    def fails(*args, **kwargs):
        raise RuntimeError("cmake --build failed: no compiler")

    monkeypatch.setattr(builds, "build_core", fails)
    assert main(["speed", "--isa", "avx512", "--cache", str(tmp_path), "--quiet"]) == 3
    assert "the avx512 build of our core failed: cmake --build failed: no compiler" in capsys.readouterr().err
    assert main(["speed", "--scaling", "--isa", "avx2", "--quiet"]) == 2
    assert "--isa times the render and ray benchmarks" in capsys.readouterr().err


@pytest.mark.slow
def test_isa_avx2_builds_and_runs(tmp_path, capsys):
    # The real thing: the core built for x86-64-v3 in a temporary folder, timed beside the
    # installed one. A minute or more: the build.
    if not builds.ISAS["avx2"][1] <= cpu_flags():
        pytest.skip("this CPU cannot run an AVX2 build")
    path = tmp_path / "speed.json"
    rc = main(["speed", "cornell_box", *TINY, "--variant", "scalar_rgb", "--isa", "avx2", "--cache", str(tmp_path),
               "--json", str(path)])
    out = capsys.readouterr().out
    assert rc == 0 and "ours mis, avx2 build" in out and "packs of 4" in out
    res = json.loads(path.read_text())["render"]
    module = res["config"]["builds"]["avx2"]
    assert not (tmp_path / "cores").exists() and "rtbench-core-avx2-" in module and str(tmp_path) not in module
    assert {r["build"] for r in res["summary"] if r["renderer"] == "ours"} == {None, "avx2"}


def test_scaling_every_axis_beside_mitsuba_with_build_times_and_svg(tmp_path, capsys, jit_variant):
    svg, path = tmp_path / "scaling.svg", tmp_path / "scaling.json"
    variant = jit_variant or "scalar_rgb"
    rc = main(["speed", "--scaling", "--resolutions", "8,16", "--scaling-depths", "2,4", "--scaling-triangles",
               "200,2000", "--scaling-spp", "1", "--repeats", "1", "--threads", "2", "--variant", variant,
               "--svg", str(svg), "--json", str(path)])
    out = capsys.readouterr().out
    assert rc == 0 and "speed targets: none applies to --scaling" in out
    for title in ("paths/s vs image size", "paths/s vs max depth", "paths/s vs threads", "cost vs triangle count",
                  "ours build s"):
        assert title in out, title
    res = json.loads(path.read_text())["scaling"]
    assert [r["resolution"] for r in res["resolution"]] == [8, 16]
    assert [(r["max_depth"], r["resolution"]) for r in res["depth"]] == [(2, 16), (4, 16)]
    assert [r["threads"] for r in res["threads"]] == [1, 2]
    assert all(r["build_seconds"] > 0 for r in res["mesh"])
    sides = ("ours", "mitsuba") if jit_variant else ("ours",)
    for r in res["resolution"] + res["depth"] + res["threads"] + res["mesh"]:
        assert all(r[f"{w}_paths_per_second"] > 0 for w in sides) and ("ratio" in r) == bool(jit_variant)
    if jit_variant:
        assert all(r["mitsuba_load_seconds"] > 0 for r in res["mesh"]) and "mitsuba_ns_per_ray" in res["fits"]
    curves = {g.get("id") for g in ET.parse(svg).iter("{http://www.w3.org/2000/svg}g")}
    assert {f"{axis}-{w}" for axis in ("resolution", "depth", "threads", "mesh") for w in sides} <= curves
    assert ("mesh-mitsuba" in curves) == bool(jit_variant)
    text = svg.read_text()
    assert all(f"paths/s vs {label}" in text for label in ("image size", "max depth", "threads", "triangles"))
    assert main(["speed", "--svg", str(svg), "--quiet"]) == 2
