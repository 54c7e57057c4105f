"""``rtbench run`` and ``rtbench curves`` report a sweep's failed jobs alike: on stderr (errors go there), the
first ten, with exit status 3. Fast: the sweep is replaced by one that fails."""
from __future__ import annotations

import pytest

import benchmarks.sweep
from benchmarks.cli import main
from benchmarks.errors import EXIT_ERROR
from benchmarks.sweep.run import SweepResult

FAILED = [(f"cornell_box ours mis {i} spp seed 0", f"RuntimeError: boom {i}") for i in range(12)]


@pytest.mark.parametrize("argv", [
    ["run", "--scenes", "cornell_box", "--no-report"],
    ["curves", "cornell_box", "--spps", "1", "--seeds", "1"],
])
def test_failed_jobs_go_to_stderr(argv, tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(benchmarks.sweep, "run_sweep",
                        lambda groups, out, **kw: SweepResult(store=tmp_path, jobs=12, failed=list(FAILED)))
    assert main([*argv, "--out", str(tmp_path), "--quiet"]) == EXIT_ERROR
    out, err = capsys.readouterr()
    assert "failed: " not in out and "12 failed" in out
    lines = [ln for ln in err.splitlines() if ln.startswith("  failed: ")]
    assert lines == [f"  failed: {label}: {why}" for label, why in FAILED[:10]]
