"""scripts/compare_builds.py: the tool that checks and times builds of the core on a
machine (PERFORMANCE.md round 13 ran it on an AVX-512 CPU)."""
from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "compare_builds.py"


def _run(*args, timeout=900):
    return subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True, text=True, timeout=timeout)


@pytest.mark.parametrize("args, message", [
    (["--build", "no equals sign"], "expected NAME=ARGS"),
    (["--build", "a=", "--build", "a=-DRT_PACK_WIDTH=8"], "names must differ"),
    (["--build", "a=", "--threads", "0"], "--threads must be at least 1"),
    (["--build", "a=", "--rounds", "0"], "--rounds must be at least 1"),
])
def test_bad_arguments_are_usage_errors(args, message):
    out = _run(*args, timeout=60)
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
