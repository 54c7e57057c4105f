"""--metric (issue 16): slopes, efficiency and time to target under relMSE, SSIM and FLIP; no cost for a biased curve."""
from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks.metrics import cost_status, require_metric, view
from benchmarks.sweep.by_metric import add_metric_ratios, curve_metrics


def _by_spp(c_rel, c_flip, spps=(1, 2, 4, 8, 16)):
    """Two seeds per spp on exact power laws: relMSE = c/spp, FLIP = c_flip/sqrt(spp), 1 - SSIM = 0.5/sqrt(spp)."""
    return {s: [{"relmse": c_rel / s, "flip": c_flip / math.sqrt(s), "ssim": 1 - 0.5 / math.sqrt(s),
                 "mse_corrected": 0.01 / s, "seconds": 0.1 * s} for _ in range(2)] for s in spps}


def test_curve_metrics_fit_each_metric_on_its_own_errors():
    by = _by_spp(0.2, 0.3)
    secs = [0.1 * s for s in sorted(by)]
    figs = curve_metrics(by, secs, target_rmse=0.05)
    assert figs["relmse"]["slope"] == pytest.approx(-1.0) and figs["relmse"]["unbiased_slope"] == -1.0
    assert figs["flip"]["slope"] == pytest.approx(-0.5) and figs["ssim"]["slope"] == pytest.approx(-0.5)
    # efficiency at the top spp: 1 / (error x seconds)
    assert figs["relmse"]["efficiency"] == pytest.approx(1 / ((0.2 / 16) * 1.6))
    # time to target relMSE 0.01: 0.2/s = 0.01 at s = 20 > 16: not reached; FLIP 0.05 reached between 32..
    assert figs["relmse"]["time_to_target"] is None
    assert figs["ssim"]["time_to_target"] is None  # 0.5/sqrt(16) = 0.125 > 0.05
    by2 = _by_spp(0.02, 0.3)
    figs2 = curve_metrics(by2, secs)
    # 0.02/s = 0.01 at s = 2 spp: 0.2 s
    assert figs2["relmse"]["time_to_target"] == pytest.approx(0.2)


def test_reference_noise_is_removed_from_relmse():
    class Ref:
        mean = np.ones((4, 4, 3))
        variance = np.full((4, 4, 3), 1.01 * 64 * 0.001)  # relative noise = var/spp/(1 + 0.01) = 0.001
        spp = 64

    by = {s: [{"relmse": 0.1 / s + 0.001}] for s in (1, 2, 4, 8)}
    figs = curve_metrics(by, [1, 2, 4, 8], ref=Ref())
    assert figs["relmse"]["slope"] == pytest.approx(-1.0)


@pytest.mark.parametrize("theirs, expected", [(2.0, 2.0), (0.0, None), (-2.0, None), (None, None),
                                              (float("nan"), None)])
def test_ratios_to_mitsuba_need_a_positive_denominator(theirs, expected):
    from benchmarks.sweep.summary import _add_mitsuba_ratios

    rows = [{"scene": "s", "width": 8, "height": 8, "renderer": renderer, "strategy": strategy, "efficiency": eff,
             "samples_per_second": eff, "by_metric": {"relmse": {"efficiency": eff}}}
            for renderer, strategy, eff in (("ours", "mis", 4.0), ("mitsuba", "path", theirs))]
    _add_mitsuba_ratios(rows)
    add_metric_ratios(rows)
    for got in (rows[0]["efficiency_vs_mitsuba"], rows[0]["samples_per_second_vs_mitsuba"],
                rows[0]["by_metric"]["relmse"]["efficiency_vs_mitsuba"]):
        assert got == expected


def test_view_switches_the_summary_and_biased_rows_show_no_cost(tmp_path):
    rows = []
    for strategy, bias in (("mis", "pass"), ("light", "fail")):
        figs = curve_metrics(_by_spp(0.2, 0.3), [0.1, 0.2, 0.4, 0.8, 1.6], target_rmse=0.05)
        rows.append({"scene": "s", "width": 8, "height": 8, "renderer": "ours", "strategy": strategy,
                     "slope": -0.36, "efficiency": 5.0, "bias_verdict": bias, "bias_significant": bias == "fail",
                     "samples_per_second": 1e6, "by_metric": figs})
    figs = curve_metrics(_by_spp(0.4, 0.3), [0.1, 0.2, 0.4, 0.8, 1.6])
    rows.append({"scene": "s", "width": 8, "height": 8, "renderer": "mitsuba", "strategy": "path", "slope": -0.46,
                 "efficiency": 2.0, "bias_verdict": "pass", "bias_significant": False, "by_metric": figs})
    add_metric_ratios(rows)
    assert view(rows[0], "rmse")["slope"] == -0.36 and view(rows[0], "relmse")["slope"] == pytest.approx(-1.0)
    assert view(rows[0], "relmse")["efficiency_vs_mitsuba"] == pytest.approx(2.0)
    assert cost_status(rows[1]) == "biased" and cost_status(dict(rows[1], bias_verdict="undetermined",
                                                                 bias_significant=None)) == "undetermined"
    from benchmarks.store import write_json
    from reports import summary_table

    write_json(tmp_path / "summary.json", {"rows": rows})  # the table `rtbench curves` prints
    cells = {line.split()[2]: line.split()[3:] for line in summary_table(tmp_path, metric="relmse").splitlines()[3:]}
    assert cells["mis"][:4] == ["-1", "pass", "–", "2"] and cells["light"][:4] == ["-1", "fail", "–", "biased"]
    assert "-0.36" in summary_table(tmp_path, metric="rmse")


def test_unknown_metric_is_a_clear_error():
    with pytest.raises(ValueError, match="unknown metric"):
        require_metric("psnr")


def test_exact_estimator_gets_no_efficiency_under_any_metric(tmp_path_factory):
    # regression: mis in the furnace has no error but float rounding; its relMSE efficiency read ~1e27
    from harness_util import cache_root

    from benchmarks.sweep import Group, run_sweep

    g = Group(scenes=("furnace",), strategies=("mis",), spps=(2, 4), seeds=2, width=8, height=8, mitsuba=False)
    res = run_sweep([g], out=tmp_path_factory.mktemp("exact") / "s", threads=2, progress=False,
                    cache=cache_root(tmp_path_factory))
    (row,) = res.rows
    assert row["efficiency_source"] == "exact (zero variance)" and row["efficiency"] is None
    assert all(f["efficiency"] is None for f in row["by_metric"].values())


def test_a_slope_measured_while_heavy_tailed_is_marked_undetermined():
    """Where the gate cannot decide at the curve's top budget, the renders have mostly not
    met the paths that carry the variance and the fitted slope reads shallower than the
    estimator's: the summary row and the report's table say so, and keep the number."""
    from benchmarks.metrics import view
    from benchmarks.sweep.slopes import slope_status
    from reports.tables import stats_table

    heavy = {"renderer": "ours", "strategy": "uniform", "slope": -0.21, "slope_ci": [-0.3, -0.12],
             "bias_verdict": "undetermined", "bias_spp_needed": 120000}
    assert "undetermined: heavy-tailed" in slope_status(heavy) and "120000" in slope_status(heavy)
    assert slope_status(dict(heavy, bias_verdict="pass")) is None
    assert slope_status(dict(heavy, bias_verdict="fail")) is None
    heavy["slope_status"] = slope_status(heavy)
    cell = stats_table([view(heavy, "rmse")])[0][1]
    assert cell.startswith("-0.21") and cell.endswith("(undetermined: heavy-tailed)")
    ok = dict(heavy, bias_verdict="pass", slope_status=None)
    assert "undetermined" not in stats_table([view(ok, "rmse")])[0][1]


def test_budgets_below_the_normal_start_are_left_out_of_the_slope():
    """Per-point rule: where the tail reference says the image mean is near normal only
    from 64 spp, the cheaper budgets' MSE (rare paths missed: too low) is left out of the
    fit; with fewer than four budgets left there is no slope, and the row says why."""
    from benchmarks.sweep.slopes import reliable_points_only, slope_stats, slope_status

    spps = [4, 16, 64, 256, 1024, 4096]
    # an estimator of variance 1: MSE 1/n from 64 spp on, far below it at 4 and 16 spp
    mse = np.array([0.01, 0.01, 1 / 64, 1 / 256, 1 / 1024, 1 / 4096])
    row = dict(slope_stats(spps, mse, mse), spps=spps, bias_verdict="pass", slope_fit_from=64)
    assert row["slope"] > -0.3                     # the low points flatten the whole fit
    row.update(reliable_points_only(spps, mse, mse, row))
    assert row["slope_excluded_spps"] == [4, 16] and row["slope_range"] == [64, 4096]
    assert row["slope"] == pytest.approx(-0.5) and row["slope_points"] == 4
    assert slope_status(row) is None
    late = dict(slope_stats(spps, mse, mse), spps=spps, bias_verdict="pass", slope_fit_from=1000)
    late.update(reliable_points_only(spps, mse, mse, late))
    assert late["slope_excluded_spps"] == [4, 16, 64, 256] and late["slope"] is None
    assert "below 1000 spp" in slope_status(late) and "fewer than 4" in slope_status(late)
    # nothing to leave out: normal from 1 spp, or no tail reference (None)
    for start in (1, None):
        r = dict(slope_stats(spps, mse, mse), spps=spps, bias_verdict="pass", slope_fit_from=start)
        assert reliable_points_only(spps, mse, mse, r) == {"slope_excluded_spps": []}
    # three budgets fit any line: no slope from them, whatever they say
    assert slope_stats(spps[:3], mse[:3], mse[:3])["slope"] is None


def test_every_metric_slope_follows_the_per_point_rule():
    from benchmarks.sweep.by_metric import metric_figures

    spps = [4, 16, 64, 256, 1024, 4096]
    err = np.array([0.1, 0.1, 1 / 8, 1 / 16, 1 / 32, 1 / 64])     # RMSE-like: -0.5 from 64 spp on
    secs = np.array(spps, dtype=float)
    assert metric_figures("relmse", spps, err, secs)["slope"] > -0.3
    fig = metric_figures("relmse", spps, err, secs, fit_from=64)
    assert fig["slope"] == pytest.approx(-0.5) and fig["slope_range"] == [64, 4096]
    # fewer than four budgets above: no slope at all
    assert metric_figures("relmse", spps, err, secs, fit_from=1000)["slope"] is None
    # steeper than Monte Carlo allows, beyond its interval: flagged
    steep = metric_figures("relmse", spps[2:], np.array([1.0, 1 / 16, 1 / 256, 1 / 4096]), secs[2:])
    assert steep["slope"] == pytest.approx(-2.0) and steep["slope_steep"]


def test_the_report_says_where_a_slope_was_fitted_from():
    from benchmarks.metrics import view
    from reports.tables import stats_table

    row = {"renderer": "ours", "strategy": "uniform", "slope": -0.5, "slope_ci": [-0.6, -0.4], "bias_verdict": "pass",
           "slope_status": None, "slope_excluded_spps": [4, 16], "slope_fit_from": 37, "slope_range": [64, 1024]}
    cell = stats_table([view(row, "rmse")])[0][1]
    assert cell.endswith("64–1024 spp") and "37" not in cell  # the budgets rendered, not a computed start
    steep = stats_table([view(dict(row, slope=-0.8, slope_ci=[-0.9, -0.7], slope_steep=True), "rmse")])[0][1]
    assert "steeper than -0.5" in steep


def test_a_closed_form_scene_in_two_groups_of_one_size(tmp_path_factory):
    """Two groups naming the furnace at one size and one reference spp share its closed-form
    reference (whose spp is CLOSED_FORM_SPP, not the spp the groups ask for)."""
    from harness_util import cache_root

    from benchmarks.sweep import Group, run_sweep

    groups = [Group(scenes=("furnace",), strategies=(s,), spps=(2,), seeds=1, width=8, height=8, mitsuba=False,
                    name=s) for s in ("mis", "cosine")]
    res = run_sweep(groups, out=tmp_path_factory.mktemp("two") / "s", threads=2, progress=False,
                    cache=cache_root(tmp_path_factory))
    assert sorted(row["strategy"] for row in res.rows) == ["cosine", "mis"]


def test_one_scene_and_size_in_two_groups_asking_different_reference_spp(tmp_path_factory):
    from benchmarks.sweep import Group, run_sweep

    groups = [Group(scenes=("furnace",), strategies=("mis",), spps=(2,), seeds=1, width=8, height=8, mitsuba=False,
                    reference_spp=r, name=f"r{r}") for r in (64, 128)]
    with pytest.raises(ValueError, match="different reference spp"):
        run_sweep(groups, out=tmp_path_factory.mktemp("clash") / "s", threads=2, progress=False)
