"""Build the C++ core in another configuration and run code against that build.

For the tests that compare builds (tests/test_wavefront.py's eight-ray packs,
tests/test_builds.py's Clang and portable builds): the module is built with CMake into a
temporary folder and loaded in a subprocess as ``reference_tracer._core``, so that the
installed module of the test process stays untouched.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def build_core(build_dir: Path, *cmake_args: str, cxx: str | None = None) -> Path:
    """Configure and build the ``_core`` target into ``build_dir``; return the module's path.

    ``cxx`` names the C++ compiler (CMake's ``CMAKE_CXX_COMPILER``); None keeps CMake's
    choice. Skips the calling test where cmake is missing. About a minute on two cores.
    """
    if shutil.which("cmake") is None:
        pytest.skip("cmake is not installed")
    configure = ["cmake", "-S", str(ROOT), "-B", str(build_dir), "-DCMAKE_BUILD_TYPE=Release",
                 f"-DPython_EXECUTABLE={sys.executable}", *cmake_args]
    if cxx is not None:
        configure.append(f"-DCMAKE_CXX_COMPILER={cxx}")
    for command in (configure, ["cmake", "--build", str(build_dir), "--target", "_core", "-j", "2"]):
        done = subprocess.run(command, capture_output=True, text=True)
        assert done.returncode == 0, f"{' '.join(command)} failed:\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}"
    return next(build_dir.glob("_core*.so"))


def run_with_core(module: Path, script: str) -> str:
    """Run ``script`` in a fresh interpreter whose ``reference_tracer._core`` is ``module``;
    return its stdout (the test fails with the script's stderr where it fails)."""
    preamble = f"""
import importlib.util, sys
spec = importlib.util.spec_from_file_location("reference_tracer._core", {str(module)!r})
core = importlib.util.module_from_spec(spec); spec.loader.exec_module(core)
sys.modules["reference_tracer._core"] = core
"""
    out = subprocess.run([sys.executable, "-c", preamble + script], capture_output=True, text=True, cwd=ROOT,
                         env=dict(os.environ, PYTHONDONTWRITEBYTECODE="1"))
    assert out.returncode == 0, out.stderr[-3000:]
    return out.stdout
