"""Every supported build of the core gives the very results of the installed one.

The README promises "g++ or clang", and issue 17's SIMD code has a portable fallback
(simd.h: plain vector extensions and lane loops where the build has no AVX). Each build
compiles the same IEEE arithmetic with fused multiply-adds off (CMakeLists.txt:
-ffp-contract=off, which Clang needs spelled out since its default contracts), and the
explicit ones (`mul_add`) are correctly rounded whether the CPU or libm does them, so on
one machine (whose libm picks its own code paths by CPU, whatever the build) the builds
must agree bit for bit with the installed module (GCC, -march=native): the images of every
suite scene and strategy with both integrators, a render with one thread and with two, and
closest hits on a mesh (benchmarks.speed.builds.AGREEMENT_SCRIPT). A difference
is a portability bug, not noise. The first Clang build of the project failed
outright: the vector-mask types of simd.h were `long` vectors, Clang's comparisons of double
vectors give `long long` ones, and calls taking a mask were ambiguous.
"""
from __future__ import annotations

import glob
import shutil
from pathlib import Path

import numpy as np
import pytest

from benchmarks.speed.builds import build_target
from build_util import X86_64_V3, X86_64_V4, agreement_arrays, build_core, cpu_flags


def _clang() -> str | None:
    """A Clang C++ compiler on PATH (clang++, or the newest clang++-N in /usr/bin), or None."""
    found = shutil.which("clang++")
    if found:
        return found
    versioned = sorted(glob.glob("/usr/bin/clang++-[0-9]*"), key=lambda p: int(p.rsplit("-", 1)[1]))
    return versioned[-1] if versioned else None


@pytest.mark.slow
@pytest.mark.parametrize("build", ["clang", "portable", "avx2"])
def test_build_gives_the_same_results_as_the_installed_module(build, tmp_path):
    # clang: Clang with the installed module's flags (-march=native where available);
    # portable: GCC without -march=native (RT_NATIVE=OFF: SSE2 only, no AVX or FMA
    # instructions, simd.h's fallbacks); avx2: GCC for x86-64-v3 (AVX2 and FMA, packs of
    # four: simd.h's __AVX__ code, which an installed build on an AVX-512 CPU never
    # compiles). About a minute each: the build.
    if build == "clang":
        clang = _clang()
        if clang is None:
            pytest.skip("no Clang compiler installed (clang++ or clang++-N; Debian: apt-get install clang)")
        module = build_core(tmp_path / build, cxx=clang)
    elif build == "avx2":
        if not X86_64_V3 <= cpu_flags():
            pytest.skip("this CPU lacks part of x86-64-v3 (AVX2, FMA, ...) or is not x86 Linux: the build would not run")
        module = build_core(tmp_path / build, "-DRT_NATIVE=OFF", "-DCMAKE_CXX_FLAGS=-march=x86-64-v3")
    else:
        module = build_core(tmp_path / build, "-DRT_NATIVE=OFF")
    _assert_same_results(module, build, tmp_path)


def _assert_same_results(module: Path, build: str, tmp_path: Path) -> None:
    """The agreement arrays of `module` equal the installed module's bit for bit."""
    from reference_tracer.build import core_path

    expected = agreement_arrays(core_path(), tmp_path / "installed.npz")
    got = agreement_arrays(module, tmp_path / f"{build}.npz")
    assert sorted(got.files) == sorted(expected.files)
    differ = [k for k in expected.files if not np.array_equal(expected[k], got[k], equal_nan=True)]
    assert differ == [], f"the {build} build differs from the installed module in {differ}"
    assert (expected["rays/prim"] >= 0).mean() > 0.2  # the ray check casts rays that hit


@pytest.mark.slow
def test_avx512_configuration_builds_on_any_machine(tmp_path):
    # simd.h's AVX-512 code (_mm512_*, packs of eight) compiles only where the build
    # targets AVX-512, which an installed build on an AVX2 CPU never does: build it for
    # x86-64-v4 anyway, so that a broken AVX-512 path shows on every machine that runs the
    # slow tests. Where the CPU has AVX-512 the build also runs, and must give the
    # installed module's results bit for bit. About a minute: the build.
    module = build_core(tmp_path / "avx512", "-DRT_NATIVE=OFF", "-DCMAKE_CXX_FLAGS=-march=x86-64-v4")
    assert module.is_file()
    target = build_target(tmp_path / "avx512")
    assert "__AVX512F__" in target and "packs of 8" in target, target
    if X86_64_V4 <= cpu_flags():  # else compiled only: this CPU cannot run it
        _assert_same_results(module, "avx512", tmp_path)
