"""Sweeps on a tiny scene: convergence slopes, the bias verdicts, the store's contents, MSE correction.

The statistical configuration (``STAT``) and why it is enough
------------------------------------------------------------
cornell_box at 16x16, spp 1, 2, 4, ..., 512 (10 levels), 6 seeds per level, reference
16384 spp (Mitsuba, 16 batches), our five strategies plus Mitsuba's ``path``.

* Slope. ``summary.json``'s slope is the least-squares slope of
  ``0.5 * log(mean over seeds of mse_corrected)`` over ``log spp``, one point per spp.
  Its spread was derived from a pilot, not guessed: 16 independent seeds per spp level
  (1..1024) per unbiased strategy, then 20,000 bootstrap draws of 6 seeds per level
  through the same estimator. Per-image MSE is heavy-tailed here (relative sd 0.25-1.0:
  the few pixels on the light's edge carry most of it), which the bootstrap keeps.
  Slope mean / sd: uniform -0.478 / 0.016, cosine -0.494 / 0.015, mixture -0.492 /
  0.021, mis -0.496 / 0.022 (none of the 20,000 draws left -0.5 +/- 0.1). Normal tails
  with these figures give P(|slope + 0.5| > 0.1) <= 7e-6 per strategy (mis, the
  widest); Mitsuba's ``path`` has mis's variance. False-positive rate of the slope
  assertions for a fresh choice of seeds: < 5e-5 over the five unbiased curves. (The
  slow test ``test_slope_spread_matches_the_derivation`` re-measures the spread.)
* Points of the fit. Budgets below ``slope_fit_from`` leave the fit (heavy tails: the
  seed-averaged MSE misses rare paths there). ``slope_fit_from`` comes from one tail
  reference's fourth cumulants, an estimate that is itself heavy-tailed: for ``mixture``
  over 16 tail-reference seeds (``variance_tail_reference``, as the sweep) it was
  1, 2, 9, 3, 1, 3, 2, 2, 5, 59, 3, 9, 3, 2, 2, 4 with the render's current generator and
  2, 1, 23, 8, 1, 7, 2, 4, 2, 3, 3, 5, 118, 4, 2, 2 with the earlier PCG32. The default
  seed gives 4, so ``mixture`` fits 8 points (4..512 spp), the others 10. The test asserts
  the rule (an earlier "10 points" held for one seed in five or so). The slope bound's
  false-positive rate above was derived for 10 points; for a fit of fewer (a tail
  reference with a large ``slope_fit_from``) it is not derived, and higher.
* Bias. ``metrics.bias_variance`` at the top spp (512) over the 6 seeds, one-sided at
  ``DEFAULT_ALPHA`` = 0.001: the false-positive rate for ``mixture`` is at most 0.001
  (the test is conservative for right-skewed per-pixel terms, ``benchmarks.metrics``).
  Power for ``light``: in 24 independent repetitions of this configuration its z was
  4.3 .. 12.3 (threshold 3.09), so a miss is rare (< 1/24 observed; the z spread
  suggests well under 1e-2).

The seeds are fixed (``render_seed`` hashes the seed index and spp), so the test is
deterministic; the rates above say how unlikely it was to pick seeds that fail it.
"""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from benchmarks import metrics as M
from benchmarks.store import read_json, read_records
from benchmarks.sweep import (DEFAULT_ALPHA, Group, job_metrics, make_jobs, render_seed, run_sweep,
                              summarize)
from harness_util import cache_root

STAT = Group(scenes=("cornell_box",), strategies=("uniform", "cosine", "light", "mixture", "mis"),
             spps=tuple(2 ** i for i in range(10)), seeds=6, width=16, height=16, reference_spp=16384,
             name="stat")
UNBIASED = [("ours", "uniform"), ("ours", "cosine"), ("ours", "mixture"), ("ours", "mis"), ("mitsuba", "path")]
REQUIRED = ("scene", "renderer", "strategy", "spp", "seed", "width", "height", "mse", "rmse", "relmse", "ssim",
            "flip", "mse_corrected", "seconds", "rays", "paths_per_second", "threads", "image", "versions")
SUMMARY_FIELDS = ("scene", "renderer", "strategy", "width", "height", "slope", "slope_ci", "bias2",
                  "bias2_stderr", "bias_z", "bias_p", "bias_significant", "variance", "efficiency",
                  "efficiency_vs_mitsuba", "time_to_target", "target_rmse", "samples_per_second",
                  "samples_per_second_vs_mitsuba")


@pytest.fixture(scope="module")
def stat_store(tmp_path_factory):
    out = tmp_path_factory.mktemp("stat-store")
    result = run_sweep([STAT], out=out, progress=False, cache=cache_root(tmp_path_factory), threads=2)
    assert not result.failed, result.failed
    assert result.done == result.jobs == 6 * 10 * 6
    return out, result


def _row(rows, renderer, strategy):
    (row,) = [r for r in rows if r["renderer"] == renderer and r["strategy"] == strategy]
    return row


@pytest.mark.parametrize("curve", UNBIASED, ids=lambda c: f"{c[0]}-{c[1]}")
def test_unbiased_strategies_converge_at_minus_one_half(stat_store, curve):
    _, result = stat_store
    row = _row(result.rows, *curve)
    # Budgets below slope_fit_from (from the tail reference's fourth cumulants) leave the fit;
    # every other one is a point of it, and enough remain for the derivation above to hold.
    excluded = row["slope_excluded_spps"]
    assert excluded == [s for s in STAT.spps if s < (row["slope_fit_from"] or 1)]
    if 10 - len(excluded) >= 2:
        assert row["slope_points"] == 10 - len(excluded)
    else:  # too few budgets left: the full fit is kept and marked (sweep.slopes.slope_status)
        assert row["slope_points"] == 10 and row["slope_status"].startswith("undetermined")
    assert abs(row["slope"] + 0.5) <= 0.1, row["slope"]
    lo, hi = row["slope_ci"]
    assert lo < row["slope"] < hi


def test_light_is_flagged_biased_and_mixture_is_not(stat_store):
    _, result = stat_store
    light, mixture = _row(result.rows, "ours", "light"), _row(result.rows, "ours", "mixture")
    assert light["bias_significant"] is True and light["bias_p"] < DEFAULT_ALPHA
    assert light["bias2"] > 0 and light["relative_bias"] < -0.1  # it misses the indirect light: too dark
    assert light["bias_spp"] == 512 and light["bias_seeds"] == 6
    assert mixture["bias_significant"] is False
    for renderer, strategy in UNBIASED:
        assert _row(result.rows, renderer, strategy)["bias_significant"] is False, (renderer, strategy)


def test_store_holds_every_job_with_the_contract_fields(stat_store):
    out, result = stat_store
    recs = read_records(out)
    assert len(recs) == result.jobs
    for r in recs:
        missing = [k for k in REQUIRED if k not in r]
        assert not missing, missing
        assert r["rmse"] == pytest.approx(math.sqrt(r["mse"]))
        assert r["threads"] == 2
        assert r["render_seed"] == render_seed(r["seed"], r["spp"])
        assert (r["image"] is not None) == (r["seed"] == 0)
        if r["image"]:
            assert (out / r["image"]).exists()
        if r["renderer"] == "ours":
            assert r["rays"] > 0 and r["nonfinite_samples"] == 0
            assert r["variance"] > 0 if r["spp"] > 1 else "variance" not in r  # 1 sample: no spread
        else:
            assert r["rays"] is None and r["strategy"] == "path" and "variance" not in r
        assert r["versions"]["mitsuba"] and r["versions"]["variant"]
    meta = read_json(out / "meta.json")
    ref = meta["references"]["cornell_box"]
    assert ref["spp"] == 16384 and (out / ref["path"]).exists() and (out / ref["variance_path"]).exists()
    assert meta["threads"] == 2 and meta["machine"]["cores"] >= 1 and meta["total_seconds"] > 0
    assert meta["target_rmse"]["cornell_box"] > 0
    summary = json.loads((out / "summary.json").read_text())
    assert len(summary["rows"]) == 6
    for row in summary["rows"]:
        assert all(k in row for k in SUMMARY_FIELDS)
    mits = _row(summary["rows"], "mitsuba", "path")
    assert mits["efficiency_vs_mitsuba"] == pytest.approx(1.0)


def test_summary_figures_follow_from_the_records(stat_store):
    """Recompute efficiency, throughput and time-to-target of one curve by hand.

    Efficiency is 1 / (expected MSE x seconds) at the top spp; for an estimator found
    unbiased the expected MSE is its per-sample variance (from its tail reference) / spp,
    which counts the rare paths a few renders miss (issue 18)."""
    out, result = stat_store
    recs = [r for r in read_records(out) if r["renderer"] == "ours" and r["strategy"] == "mis"]
    row = _row(result.rows, "ours", "mis")
    top = [r for r in recs if r["spp"] == 512]
    secs = np.mean([r["seconds"] for r in top])
    assert row["bias_verdict"] in ("pass", "undetermined")
    assert row["efficiency_source"] == "tail-reference variance / spp" and row["variance"] > 0
    assert row["efficiency"] == pytest.approx(1 / (row["variance"] / 512 * secs))
    assert row["samples_per_second"] == pytest.approx(np.mean([16 * 16 * 512 / r["seconds"] for r in top]))
    spps = sorted({r["spp"] for r in recs})
    t = [np.mean([r["seconds"] for r in recs if r["spp"] == s]) for s in spps]
    e = [math.sqrt(np.mean([r["mse_corrected"] for r in recs if r["spp"] == s])) for s in spps]
    expect = M.time_to_error(t, e, row["target_rmse"])
    assert (row["time_to_target"] is None and math.isnan(expect)) or row["time_to_target"] == pytest.approx(expect)
    mits = _row(result.rows, "mitsuba", "path")
    assert row["efficiency_vs_mitsuba"] == pytest.approx(row["efficiency"] / mits["efficiency"])
    # summarize() is a pure function of the store: rerunning it gives the same rows
    again = summarize(out)
    assert [r["slope"] for r in again] == [r["slope"] for r in result.rows]


def test_mse_correction_on_synthetic_images_of_known_noise():
    """mse_corrected recovers the render's own error when the reference is noisy.

    Truth T; reference R = T + N(0, tau^2 / N_ref) per pixel-channel with per-sample
    variance image tau^2; render X = T + N(0, sigma^2 / N). E[plain MSE] = sigma^2/N +
    tau^2/N_ref (0.0125 + 0.0100 here); E[corrected] = sigma^2/N = 0.0125. With
    P = 128*128*3 = 49152 Gaussian pixel-channels the sd of either estimate is
    sqrt(2/P) * 0.0225 = 1.4e-4; the bounds are 5 sd (false-positive rate < 1e-6), and
    the plain MSE's offset (0.0100 = 70 sd) is far outside them.
    """
    rng = np.random.default_rng(1234)
    shape = (128, 128, 3)
    truth = rng.uniform(0.1, 2.0, shape)
    sigma2, n = 0.2, 16          # render: per-sample variance, spp
    tau2, n_ref = 1.0, 100       # reference
    ref = truth + rng.normal(0, math.sqrt(tau2 / n_ref), shape)
    img = truth + rng.normal(0, math.sqrt(sigma2 / n), shape)
    m = job_metrics(img, np.full(shape, sigma2), ref, np.full(shape, tau2), n_ref)
    sd = math.sqrt(2 / np.prod(shape)) * (sigma2 / n + tau2 / n_ref)
    assert abs(m["mse_corrected"] - sigma2 / n) < 5 * sd
    assert abs(m["mse"] - (sigma2 / n + tau2 / n_ref)) < 5 * sd
    assert m["mse"] - m["mse_corrected"] == pytest.approx(tau2 / n_ref)
    assert m["variance"] == pytest.approx(sigma2)


def test_job_list_and_validation():
    jobs = make_jobs(["cornell_box"], strategies=["mis", "light"], spps=[4, 1], seeds=2, width=8, height=8)
    assert len(jobs) == 2 * 2 * 3
    assert [j.spp for j in jobs[:6]] == [1] * 6  # cheapest first
    assert {j.strategy for j in jobs if j.renderer == "mitsuba"} == {"path"}
    with pytest.raises(ValueError, match="unknown scene"):
        Group(scenes=("nope",), strategies=("mis",), spps=(1,), seeds=1, width=8, height=8)
    with pytest.raises(ValueError, match="unknown strategy"):
        Group(scenes=("cornell_box",), strategies=("mis", "best"), spps=(1,), seeds=1, width=8, height=8)
    with pytest.raises(ValueError, match="spps"):
        Group(scenes=("cornell_box",), strategies=("mis",), spps=(0, 4), seeds=1, width=8, height=8)
    with pytest.raises(ValueError, match="repeated"):
        Group(scenes=("cornell_box",), strategies=("mis",), spps=(4, 4), seeds=1, width=8, height=8)
    with pytest.raises(ValueError, match="seeds"):
        Group(scenes=("cornell_box",), strategies=("mis",), spps=(4,), seeds=0, width=8, height=8)
    with pytest.raises(ValueError, match="scenes"):
        Group(scenes="cornell_box", strategies=("mis",), spps=(4,), seeds=1, width=8, height=8)
    g = Group(scenes=("cornell_box",), strategies=("mis",), spps=(4,), seeds=1, width=8, height=8)
    with pytest.raises(ValueError, match="threads"):
        run_sweep([g], out="/tmp/never-created-rtbench", threads=0, progress=False)


@pytest.mark.slow
def test_slope_spread_matches_the_derivation(tmp_path_factory):
    """Re-measure the pilot behind STAT's false-positive figure: 16 seeds per level, then
    the bootstrap sd of the 6-seed slope must not exceed the derivation's (with 20% margin
    for the pilot's own sampling error) and its mean must stay within 0.03 of -0.5."""
    import reference_tracer as rt

    from benchmarks.references import reference
    from benchmarks.scenes import scene_at

    scene = scene_at("cornell_box", 16, 16)
    ref = reference(scene, spp=STAT.reference_spp, cache=cache_root(tmp_path_factory))
    spps = np.array(STAT.spps)
    x = np.log(spps)
    w = (x - x.mean()) / ((x - x.mean()) ** 2).sum()
    rng = np.random.default_rng(0)
    derived = {"uniform": 0.016, "cosine": 0.015, "mixture": 0.021, "mis": 0.022}
    for strategy, sd_derived in derived.items():
        a = np.array([[M.mse_corrected(rt.render(scene, spp=int(s), strategy=strategy,
                                                 seed=render_seed(500 + k, int(s))).mean,
                                       ref.mean, ref.variance, ref.spp) for k in range(16)] for s in spps])
        idx = rng.integers(0, 16, size=(5000, len(spps), STAT.seeds))
        m = np.take_along_axis(np.broadcast_to(a, (5000,) + a.shape), idx, axis=2).mean(axis=2)
        slopes = (0.5 * np.log(np.where(m > 0, m, np.nan)) * w).sum(axis=1)
        assert np.nanstd(slopes) < 1.2 * sd_derived, (strategy, np.nanstd(slopes))
        assert abs(np.nanmean(slopes) + 0.5) < 0.03, (strategy, np.nanmean(slopes))
