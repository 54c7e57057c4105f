"""Test-side wrappers of :mod:`benchmarks.speed.builds` (build the core in another
configuration, run code against that build): a missing cmake skips the calling test, a
failed build or run fails it with the log's end. Also the CPU's feature flags, which decide
the builds a machine can run."""
from __future__ import annotations

from pathlib import Path

import pytest

from benchmarks.speed import builds


# The CPU features (as /proc/cpuinfo names them) that GCC's and Clang's x86-64 levels assume:
# a build for a level runs only where the CPU has all of them.
X86_64_V3 = frozenset({"avx", "avx2", "bmi1", "bmi2", "f16c", "fma", "movbe", "abm", "xsave"})
X86_64_V4 = X86_64_V3 | {"avx512f", "avx512bw", "avx512cd", "avx512dq", "avx512vl"}


def cpu_flags() -> frozenset:
    """The CPU's feature flags as Linux lists them (empty where /proc/cpuinfo is absent)."""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("flags"):
                    return frozenset(line.split(":", 1)[1].split())
    except OSError:
        pass
    return frozenset()


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
