"""The core built by Clang gives the very results of the GCC build the tests install.

The README promises "g++ or clang". Both compile the same IEEE arithmetic with fused
multiply-adds off (CMakeLists.txt: -ffp-contract=off, which Clang needs spelled out since
its default contracts), so the two builds must agree bit for bit: images of every suite
scene and strategy with both integrators, and closest hits on a mesh. A difference is a
portability bug (a construct the two compilers read differently), not noise. The first
Clang build of the project failed outright: the vector-mask types of simd.h were `long`
vectors, Clang's comparisons of double vectors give `long long` ones, and calls taking a
mask were ambiguous.
"""
from __future__ import annotations

import glob
import shutil

import numpy as np
import pytest

from build_util import build_core, run_with_core

SCRIPT = """
import numpy as np
import reference_tracer as rt
from mitsuba_scenes import SUITE, get_scene
from benchmarks.speed.rays import mesh_scene, random_rays
from reference_tracer.render import core_scene

out = {}
for name in SUITE:
    for strategy in rt.STRATEGIES:
        scene = get_scene(name, width=16, height=12)
        for integrator in ("scalar", "wavefront"):
            r = rt.render(scene, spp=4, strategy=strategy, seed=5, threads=2, integrator=integrator)
            out[f"{name}/{strategy}/{integrator}"] = r.mean
mesh = core_scene(mesh_scene(20_000))
o, d = random_rays(4096, seed=3)
hits = mesh.intersect(np.asarray(o, dtype=np.float64), np.asarray(d, dtype=np.float64), threads=2)
out["rays/t"], out["rays/prim"] = np.asarray(hits["t"]), np.asarray(hits["prim"])
np.savez(PATH, **out)
"""


def _clang() -> str | None:
    """A Clang C++ compiler on PATH (clang++, or a versioned clang++-N), or None."""
    found = shutil.which("clang++")
    if found:
        return found
    versioned = sorted(glob.glob("/usr/bin/clang++-[0-9]*"), key=lambda p: int(p.rsplit("-", 1)[1]))
    return versioned[-1] if versioned else None


@pytest.mark.slow
def test_clang_build_gives_the_same_results_as_gcc(tmp_path):
    clang = _clang()
    if clang is None:
        pytest.skip("no Clang compiler installed (clang++ or clang++-N; Debian: apt-get install clang)")
    gcc_module = build_core(tmp_path / "gcc", cxx=shutil.which("g++") or "g++")
    clang_module = build_core(tmp_path / "clang", cxx=clang)
    results = {}
    for label, module in (("gcc", gcc_module), ("clang", clang_module)):
        path = tmp_path / f"{label}.npz"
        run_with_core(module, SCRIPT.replace("PATH", repr(str(path))))
        results[label] = np.load(path)
    gcc, clang_results = results["gcc"], results["clang"]
    assert sorted(gcc.files) == sorted(clang_results.files)
    differ = [k for k in gcc.files if not np.array_equal(gcc[k], clang_results[k], equal_nan=True)]
    assert differ == [], f"Clang's build differs from GCC's in {differ}"
    assert (gcc["rays/prim"] >= 0).mean() > 0.2  # the ray check casts rays that hit
