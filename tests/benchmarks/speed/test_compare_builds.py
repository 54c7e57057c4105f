"""scripts/compare_builds.py: the tool that checks and times builds of the core on a
machine (an AVX-512 CPU, say); scripts/ab_cores.py, which times two builds render by render
(PERFORMANCE.md, How to measure)."""
from __future__ import annotations

import re
import subprocess
import sys

import pytest

from repo_paths import ROOT

SCRIPT = ROOT / "scripts" / "compare_builds.py"
AB_SCRIPT = ROOT / "scripts" / "ab_cores.py"


def _run(*args, script=SCRIPT, timeout=900):
    return subprocess.run([sys.executable, str(script), *args], capture_output=True, text=True, timeout=timeout)


@pytest.mark.parametrize("script, args, message", [
    (SCRIPT, ["--build", "no equals sign"], "expected NAME=ARGS"),
    (SCRIPT, ["--build", "a=", "--build", "a=-DRT_PACK_WIDTH=8"], "names must differ"),
    (SCRIPT, ["--build", "a=", "--threads", "0"], "--threads must be at least 1"),
    (SCRIPT, ["--build", "a=", "--rounds", "0"], "--rounds must be at least 1"),
    (AB_SCRIPT, ["installed", "/nonexistent/_core.so"], "no core module at /nonexistent/_core.so"),
    (AB_SCRIPT, ["installed", "installed", "--scenes", "nope"], "unknown scene(s) nope"),
    (AB_SCRIPT, ["installed", "installed", "--rounds", "0"], "--rounds must be at least 1"),
    (AB_SCRIPT, ["installed", "installed", "--spp", "0"], "--spp must be at least 1"),
    (AB_SCRIPT, ["installed", "installed", "--rays", "--triangles", "10"], "--triangles must be at least 32"),
    (AB_SCRIPT, ["installed", "installed", "--meshes", "1000", "10"], "--meshes must be at least 32"),
    (AB_SCRIPT, ["installed", "installed", "--rays", "--ray-count", "0"], "--ray-count must be at least 1"),
    (AB_SCRIPT, ["installed", "installed", "--rays", "--kinds", "diffuse"], "invalid choice: 'diffuse'"),
])
def test_bad_arguments_are_usage_errors(script, args, message):
    out = _run(*args, script=script, timeout=60)
    assert out.returncode == 2 and message in out.stderr


@pytest.mark.slow
def test_a_build_with_different_arithmetic_is_reported(tmp_path):
    # -ffast-math reassociates sums and drops IEEE guarantees, so some image must differ
    # from the default build's: the agreement check has to see it and exit 1, while the
    # timing table still comes out. (Two core builds: about two minutes on two cores.)
    out = _run("--build", "default=", "--build", "fast_math=-DCMAKE_CXX_FLAGS=-ffast-math", "--threads", "2",
               "--rounds", "1", "--triangles", "2000", "--spp", "1", "--work", str(tmp_path))
    assert out.returncode == 1, out.stdout[-2000:] + out.stderr[-2000:]
    assert re.search(r"agreement default vs default: (\d+)/\1 arrays identical; 1 vs 2 threads identical", out.stdout)
    assert "agreement fast_math vs default:" in out.stdout and "differ:" in out.stdout
    assert "random rays, 1 thr (Mrays/s)" in out.stdout.split("median of 1 rounds")[1]


def test_ab_cores_times_a_build_against_itself():
    # The installed core against itself: both workers render, and the speed-up row is a
    # positive ratio with its interval around the median (its value is the machine's noise
    # and is not asserted: speed belongs in the benchmark).
    out = _run("installed", "installed", "--scenes", "cornell_box", "--rounds", "5", "--spp", "1", "--size", "16",
               script=AB_SCRIPT, timeout=300)
    assert out.returncode == 0, out.stdout[-2000:] + out.stderr[-2000:]
    row = re.search(r"^cornell_box +([\d.]+) +([\d.]+) +([\d.]+) +\[([\d.]+), ([\d.]+)\]$", out.stdout, re.M)
    assert row, out.stdout
    a, b, med, low, high = map(float, row.groups())
    assert a > 0 and b > 0 and med > 0 and low <= med <= high


def test_ab_cores_times_ray_queries_of_a_build_against_itself():
    # --rays: both workers cast the same rays on a small torus; one row per mesh and kind.
    out = _run("installed", "installed", "--rays", "--triangles", "2000", "--kinds", "random", "primary",
               "--ray-count", "4096", "--rounds", "5", script=AB_SCRIPT, timeout=300)
    assert out.returncode == 0, out.stdout[-2000:] + out.stderr[-2000:]
    for kind in ("random", "primary"):
        row = re.search(rf"^2000 {kind} +([\d.]+) +([\d.]+) +([\d.]+) +\[([\d.]+), ([\d.]+)\]$", out.stdout, re.M)
        assert row, out.stdout
        a, b, med, low, high = map(float, row.groups())
        assert a > 0 and b > 0 and low <= med <= high


def test_paired_times_reports_a_worker_that_cannot_start_or_a_call_that_fails(tmp_path):
    # A file that is no core module: its worker fails on import, and the error names the
    # module and carries the worker's own message instead of hanging or a bare EOF. A call
    # that raises in a working worker comes back with its traceback, the worker still usable.
    from benchmarks.speed.builds import CoreWorker, paired_times
    from reference_tracer.build import core_path

    bogus = tmp_path / "_core.so"
    bogus.write_bytes(b"not a shared object")
    request = ("benchmarks.speed.rays.query_torus", {"triangles": 1000, "kind": "random", "rays": 8})
    with pytest.raises(RuntimeError, match=r"the worker of .*_core\.so stopped:(.|\n)*ImportError"):
        paired_times([bogus], {"x": request}, rounds=1)
    with CoreWorker(core_path()) as worker:
        with pytest.raises(RuntimeError, match=r"query_torus failed with the core(.|\n)*KeyError: 'diffuse'"):
            worker("benchmarks.speed.rays.query_torus", 1000, kind="diffuse", rays=8)
        assert worker("os.system", "echo noise on the stdout of the worker") == 0   # kept out of the answers
        assert worker("reference_tracer.build.core_path") == core_path()
