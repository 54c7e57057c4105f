"""The main job's budget: what the quick preset may render, and that a second run renders nothing.

Wall time is never asserted (speed belongs in benchmarks): these tests pin the logic that keeps
``make report`` within its budget: the quick preset's groups, tail references that never grow
past their 16384 spp (the curve says "undetermined" and which budget would decide instead), the
progress plan of cached and uncached steps, and a rerun that finds everything in the caches.
"""
from __future__ import annotations

import math
import re
import subprocess
import sys

import numpy as np
import pytest

from benchmarks.constants import MIN_SLOPE_BUDGETS
from benchmarks.sweep import headline as H
from benchmarks.sweep import summary as S
from benchmarks.sweep.presets import escalates_tails, preset_groups
from benchmarks.tails import DEFAULT_MAX_TAIL_SAMPLES, DEFAULT_TAIL_SPP

from harness_util import ROOT


def test_quick_preset_renders_what_its_verdicts_need_and_no_more():
    suite, seed = preset_groups("quick")
    assert not escalates_tails("quick") and escalates_tails("full")
    assert len(suite.spps) >= MIN_SLOPE_BUDGETS and max(suite.spps) == 256 and suite.seeds >= 2
    assert suite.reference_spp == 8192 and (suite.width, suite.height) == (32, 32)
    # the seed figure has no verdict: its reference only carries error maps and a corrected relMSE
    assert seed.reference_spp == 64 and seed.seeds == 1 and 50 in seed.spps and 4 in seed.spps


class _FakeTails:
    def __init__(self, spp, lower_bound):
        self.spp, self.lower_bound = spp, lower_bound


def test_quick_never_escalates_a_tail_reference(monkeypatch):
    """Where a tail reference's variance rests on single samples, the full preset renders one of
    2^30 samples; the quick preset stops at 16384 spp."""
    import benchmarks.tails as T

    calls = []

    def fake_tail_reference(scene, *, strategy, spp, **kw):
        calls.append(spp)
        return _FakeTails(spp, lower_bound=True)

    monkeypatch.setattr(T, "tail_reference", fake_tail_reference)
    monkeypatch.setattr(T, "variance_is_lower_bound", lambda t: t.lower_bound)
    S._curve_tails("glossy_plates", "uniform", 32, 32, tail_spp=DEFAULT_TAIL_SPP, cache=None, threads=1, log=None,
                   escalate=False)
    assert calls == [DEFAULT_TAIL_SPP]
    calls.clear()
    S._curve_tails("glossy_plates", "uniform", 32, 32, tail_spp=DEFAULT_TAIL_SPP, cache=None, threads=1, log=None,
                   escalate=True)
    assert calls == [DEFAULT_TAIL_SPP, DEFAULT_MAX_TAIL_SAMPLES // (32 * 32)]


@pytest.mark.parametrize("verdict", ["pass", "fail"])
def test_a_verdict_on_a_lower_bound_variance_is_undetermined_in_quick(monkeypatch, verdict):
    import benchmarks.tails as T

    monkeypatch.setattr(T, "variance_is_lower_bound", lambda t: True)
    row = {"bias_verdict": verdict, "bias_significant": verdict == "fail"}
    S._not_escalated(row, _FakeTails(DEFAULT_TAIL_SPP, True), 32, 32)
    assert row["bias_verdict"] == "undetermined" and row["bias_significant"] is None
    assert row["tail_spp_needed"] == DEFAULT_MAX_TAIL_SAMPLES // 1024 and "--preset full" in row["bias_reason"]
    monkeypatch.setattr(T, "variance_is_lower_bound", lambda t: False)
    row = {"bias_verdict": verdict}
    S._not_escalated(row, _FakeTails(DEFAULT_TAIL_SPP, False), 32, 32)
    assert row == {"bias_verdict": verdict}  # a trusted variance: the verdict stands


def test_progress_plans_uncached_steps_at_their_cost_and_cached_ones_at_a_read(monkeypatch):
    import benchmarks.references as R
    import benchmarks.tails as T
    from benchmarks.sweep.progress import Progress
    from benchmarks.sweep.run import _plan_progress

    groups = preset_groups("quick", scenes=["cornell_box"])
    for cached in (False, True):
        monkeypatch.setattr(R, "is_cached", lambda *a, **k: cached)
        monkeypatch.setattr(T, "is_cached", lambda *a, **k: cached)
        bar = Progress(enabled=False)
        tails = _plan_progress(bar, groups, [], variant=None, cache=None)
        assert len(tails) == 5 and bar.steps_total == 2 + 5  # two references, five tail references
        per_step = bar.cost_total / bar.steps_total
        if cached:
            assert per_step == pytest.approx(0.05)
        else:
            assert per_step > 1.0  # seconds of rendering planned per step


def test_noise_figures_and_ratios():
    rng = np.random.default_rng(0)
    x = rng.exponential(size=(200_000, 2, 2, 3))  # Var 1, m4 9 per sample
    var, m4 = x.var(axis=0), ((x - x.mean(axis=0)) ** 4).mean(axis=0)
    ref = np.ones((2, 2, 3))
    out = H.relative_noise_of(var, ref, n=x.shape[0], m4=m4)
    assert out["noise"] == pytest.approx(1 / 1.01, rel=0.02)
    # se of the mean of 12 independent sample variances: sqrt((m4 - s^4) / n / 12) / 1.01
    assert out["noise_se"] == pytest.approx(math.sqrt(8 / x.shape[0] / 12) / 1.01, rel=0.1)
    rows = [dict(scene="s", width=2, height=2, renderer="ours", strategy="light", noise=1.0, noise_se=0.01,
                 seconds_per_sample=1e-7),
            dict(scene="s", width=2, height=2, renderer="ours", strategy="uniform", noise=30.0, noise_se=0.3,
                 seconds_per_sample=0.5e-7)]
    H.add_noise_ratios(rows)
    u = rows[1]
    assert u["noise_vs_light"] == pytest.approx(30.0) and u["time_noise_vs_light"] == pytest.approx(15.0)
    lo, hi = u["noise_vs_light_ci"]
    assert lo < 30.0 < hi and hi / 30.0 == pytest.approx(math.exp(1.96 * math.sqrt(2) * 0.01), rel=1e-3)
    (entry,) = H.headline_rows(rows)
    assert entry["verdict"] is None and [c["strategy"] for c in entry["curves"]] == ["light", "uniform"]


def test_a_second_run_renders_nothing(tmp_path):
    """Everything a quick run renders is cached or in its store: run again, nothing is rendered."""
    env_cache = tmp_path / "cache"
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "benchmarks.cli", "run", "--preset", "quick", "--scenes", "large_light",
           "--no-report", "--cache", str(env_cache), "--out", str(out)]
    first = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=900)
    assert first.returncode == 0, first.stderr[-2000:]
    assert "rendering the tail reference of large_light 32x32" in first.stderr
    second = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=900)
    assert second.returncode == 0, second.stderr[-2000:]
    assert "(0 jobs rendered" in second.stdout and "rendering" not in second.stderr
    assert "rendered in" not in second.stderr  # every reference came from the cache
    assert re.search(r"^time: start-up \d+ s, references \d+ s, jobs \d+ s, tail references and summary \d+ s",
                     second.stdout, re.M)
