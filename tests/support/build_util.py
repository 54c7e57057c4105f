"""Test-side wrappers of :mod:`benchmarks.speed.builds` (build the core in another
configuration, run code against that build): a missing cmake skips the calling test, a
failed build or run fails it with the log's end. Also the CPU's feature flags, which decide
the builds a machine can run."""
from __future__ import annotations

from pathlib import Path

import pytest

from benchmarks.speed import builds


# The CPU features (as /proc/cpuinfo names them) that GCC's and Clang's x86-64 levels assume.
X86_64_V3, X86_64_V4 = builds.ISAS["avx2"][1], builds.ISAS["avx512"][1]
cpu_flags = builds.cpu_flags


def build_core(build_dir: Path, *cmake_args: str, cxx: str | None = None) -> Path:
    """:func:`benchmarks.speed.builds.build_core`, skipping where cmake is missing."""
    try:
        return builds.build_core(build_dir, *cmake_args, cxx=cxx)
    except FileNotFoundError as e:
        pytest.skip(str(e))
    except RuntimeError as e:
        pytest.fail(str(e))


def run_with_core(module: Path, script: str) -> str:
    """:func:`benchmarks.speed.builds.run_with_core`, failing the test where the script fails."""
    try:
        return builds.run_with_core(module, script)
    except RuntimeError as e:
        pytest.fail(str(e))


def agreement_arrays(module: Path, path: Path, *, threads: int = 2):
    """:func:`benchmarks.speed.builds.agreement_arrays`, failing the test where the run fails."""
    try:
        return builds.agreement_arrays(module, path, threads=threads)
    except RuntimeError as e:
        pytest.fail(str(e))
