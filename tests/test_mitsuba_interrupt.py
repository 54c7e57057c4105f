"""Ctrl-C during a Mitsuba render stops the run like Ctrl-C anywhere else (exit 130, store
marked interrupted, finished records kept), although Mitsuba catches SIGINT itself ("Received
interrupt signal, winding down..") and cancels the render, which then returns a partial image
or raises a RuntimeError: before the fix a sweep counted it as a failed job and went on, and a
reference render ended in "internal error" (exit 3)."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import pytest

from benchmarks.store import META, RESULTS, read_records
from harness_util import ROOT, default_sigint

pytest.importorskip("mitsuba")

#: Mitsuba's own log line when its SIGINT handler cancels a render: proof the signal landed in one.
WINDING_DOWN = "winding down"


def _variant(name: str) -> str:
    from mitsuba_scenes.variants import probe_variant

    ok, why = probe_variant(name)
    if not ok:
        pytest.skip(f"{name} does not run here: {why}")
    return name


def _popen(args, cache) -> subprocess.Popen:
    env = dict(os.environ, RTBENCH_CACHE=str(cache), PYTHONUNBUFFERED="1")
    return subprocess.Popen([sys.executable, "-m", "benchmarks.cli", *map(str, args)], cwd=ROOT, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, preexec_fn=default_sigint)


def _lines(path) -> int:
    return path.read_bytes().count(b"\n") if path.exists() else 0


# llvm_ad_rgb (the variant picked by default on a CPU): the cancelled render raised Dr.Jit's
# RuntimeError ("drjit.custom(<mitsuba.python.util._RenderOp>): error while performing a custom
# differentiable operation"); scalar_rgb: the cancelled render returns a partial image.
@pytest.mark.parametrize("variant", ["llvm_ad_rgb", "scalar_rgb"])
def test_ctrl_c_in_a_mitsuba_sweep_job_stops_the_run(tmp_path, variant):
    variant = _variant(variant)
    store = tmp_path / "s"
    # Jobs run per budget, ours then Mitsuba's: 1 and 2 spp (4 records), then ours at 32768
    # spp (about 4 s at 8x8 on one thread), then Mitsuba's at 32768 spp, where the interrupt lands.
    args = ("curves", "cornell_box", "--strategies", "mis", "--spps", "1,2,32768", "--seeds", "1", "--width", "8",
            "--height", "8", "--reference-spp", "64", "--threads", "1", "--variant", variant, "--quiet",
            "--out", store)
    proc = _popen(args, tmp_path / "cache")
    deadline = time.monotonic() + 60
    while proc.poll() is None and _lines(store / RESULTS) < 5 and time.monotonic() < deadline:
        time.sleep(0.01)
    time.sleep(0.3)  # into the Mitsuba job's render
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode != 0, "the run finished before the interrupt: nothing was tested"
    assert WINDING_DOWN in out + err, f"the interrupt did not land in a Mitsuba render:\n{out}\n{err}"
    assert proc.returncode == 130, f"{proc.returncode}\n{out}\n{err}"
    assert "FAILED" not in out + err and "failed:" not in out + err, f"{out}\n{err}"
    records = read_records(store)
    assert len(records) == 5 and all(r["spp"] in (1, 2, 32768) for r in records)
    assert not any(r["renderer"] == "mitsuba" and r["spp"] == 32768 for r in records)
    run = json.loads((store / META).read_text())["runs"][-1]
    assert run["interrupted"] is True and run["jobs_done"] == 5


def test_ctrl_c_in_a_mitsuba_reference_render_exits_130(tmp_path):
    variant = _variant("llvm_ad_rgb")
    store = tmp_path / "s"
    args = ("curves", "cornell_box", "--strategies", "mis", "--spps", "1", "--seeds", "1", "--width", "8",
            "--height", "8", "--reference-spp", "4000000", "--threads", "1", "--variant", variant, "--quiet",
            "--out", store)
    proc = _popen(args, tmp_path / "cache")
    time.sleep(4.0)  # imports, then the reference render (several minutes were it to run to the end)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    assert WINDING_DOWN in out + err, f"the interrupt did not land in a Mitsuba render:\n{out}\n{err}"
    assert proc.returncode == 130, f"{proc.returncode}\n{out}\n{err}"
    assert "internal error" not in err and "Traceback" not in err, err


def test_a_mitsuba_error_without_ctrl_c_is_raised_as_it_is():
    from mitsuba_scenes import render_mitsuba

    before = signal.getsignal(signal.SIGINT)
    with pytest.raises(RuntimeError, match="no_such_plugin"):
        render_mitsuba({"type": "scene", "thing": {"type": "no_such_plugin"}}, spp=1, variant="scalar_rgb")
    assert signal.getsignal(signal.SIGINT) is before  # the render's own SIGINT handler is gone again
