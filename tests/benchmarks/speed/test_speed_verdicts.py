"""Speed targets and their verdicts (``benchmarks.speed.targets``): the order-statistics
interval for the median, target evaluation on synthetic result dicts, and one tiny
``rtbench speed`` run whose closing lines and JSON carry the verdicts.

No timed assertion: which way a real run's verdict goes is measured, not tested; only
that it is stated, consistently with its numbers and the exit status.
"""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy import stats

from benchmarks import speed
from benchmarks.cli import main
from benchmarks.speed.common import median, median_coverage, median_order_interval, rounds_for_coverage
from benchmarks.speed.targets import (RAYS, SCENE_EFFICIENCY, SCENE_PATHS, SUITE_PATHS, Target, judge, not_judged,
                                      ray_verdicts, render_verdicts)

V = "llvm_ad_rgb"


# ------------------------------------------------------------------------------------------- the interval

@pytest.mark.parametrize("n", range(1, 41))
def test_coverage_is_the_binomial_probability_and_the_interval_the_narrowest(n):
    for k in range(1, (n + 1) // 2 + 1):
        want = 1 - 2 * stats.binom.cdf(k - 1, n, 0.5)
        assert median_coverage(n, k) == pytest.approx(want, abs=1e-12)
    iv = median_order_interval(np.arange(n, dtype=float), coverage=0.90)
    k = iv["rank"]
    if n < 5:
        assert k is None and iv["low"] is None and iv["high"] is None and iv["coverage"] is None
        return
    assert iv["coverage"] == median_coverage(n, k) >= 0.90
    assert (iv["low"], iv["high"]) == (k - 1, n - k)        # the k-th lowest and k-th highest
    assert k == (n + 1) // 2 or median_coverage(n, k + 1) < 0.90   # no narrower one covers 90%


def test_interval_examples_and_edge_cases():
    iv = median_order_interval([1.70, 1.52, 1.61, 1.66, 1.58])
    assert (iv["median"], iv["low"], iv["high"], iv["rounds"]) == (1.61, 1.52, 1.70, 5)
    assert iv["coverage"] == 0.9375 and iv["rounds_needed"] == 5
    assert median_order_interval([1.0, 2.0, 3.0, 4.0])["low"] is None       # 87.5% < 90%
    assert median_order_interval([1.0] * 4, coverage=0.875)["coverage"] == 0.875   # exact, not rounded
    iv = median_order_interval([None, float("nan"), float("inf"), 1.0, 2.0, 3.0, 4.0, 5.0])
    assert iv["rounds"] == 5 and (iv["low"], iv["high"]) == (1.0, 5.0)   # non-finite rounds left out
    iv = median_order_interval([float("nan")])
    assert iv["rounds"] == 0 and math.isnan(iv["median"]) and iv["low"] is None
    iv = median_order_interval([2.0] * 6)                                       # ties
    assert iv["low"] == iv["high"] == iv["median"] == 2.0
    assert [rounds_for_coverage(c) for c in (0.5, 0.75, 0.9, 0.95, 0.99)] == [2, 3, 5, 6, 8]
    for bad in (0, 1, 1.5, -0.1, True, "0.9", float("nan")):
        with pytest.raises(ValueError, match="coverage"):
            median_order_interval([1.0] * 5, coverage=bad)
    for n, k in ((0, 1), (5, 0), (5, 4)):
        with pytest.raises(ValueError):
            median_coverage(n, k)


def test_interval_covers_the_median_as_often_as_it_says():
    """Skewed draws with a known median: the interval's miss rate stays within its bound."""
    rng = np.random.default_rng(44)
    for n in (5, 9, 13):
        draws = rng.lognormal(0.3, 0.4, size=(4000, n))     # median exp(0.3)
        ivs = [median_order_interval(row) for row in draws]
        hit = np.mean([iv["low"] <= math.exp(0.3) <= iv["high"] for iv in ivs])
        cov = ivs[0]["coverage"]
        assert hit >= cov - 4 * math.sqrt(cov * (1 - cov) / 4000), (n, hit, cov)


# ------------------------------------------------------------------------------------------- one verdict

def test_judge_wording_and_status():
    v = judge(SCENE_PATHS, "cornell_box", [1.61, 1.52, 1.70, 1.66, 1.58])
    assert v["line"] == ("cornell_box paths/s vs Mitsuba llvm_ad_rgb >= 1.5x: met, clearly "
                         "(1.61x, 90% interval 1.52-1.70, 5 rounds)")
    assert (v["status"], v["clearly"], v["rounds"], v["coverage"]) == ("met", True, 5, 0.9375)
    v = judge(SCENE_PATHS, "a", [1.61, 1.40, 1.70, 1.66, 1.58])
    assert (v["status"], v["clearly"]) == ("met", False) and "met, within noise" in v["line"]
    v = judge(SCENE_PATHS, "a", [1.2, 1.3, 1.4, 1.45, 1.49])
    assert (v["status"], v["clearly"]) == ("not met", True) and "not met, clearly (1.40x" in v["line"]
    v = judge(SCENE_PATHS, "a", [1.2, 1.3, 1.4, 1.45, 1.6])
    assert (v["status"], v["clearly"]) == ("not met", False) and "not met, within noise" in v["line"]
    v = judge(SCENE_PATHS, "a", [1.5] * 5)                     # the threshold itself meets it
    assert (v["status"], v["clearly"]) == ("met", True)
    v = judge(SCENE_PATHS, "a", [1.0, 2.4])                    # too few rounds: the median's verdict alone
    assert (v["status"], v["clearly"], v["low"]) == ("met", None, None)
    assert v["line"].endswith("met (1.70x, 2 rounds; too few rounds for a 90% interval: use --repeats 5)")
    v = judge(SCENE_PATHS, "a", [2.0], coverage=0.95)
    assert "1 round;" in v["line"] and "95% interval: use --repeats 6" in v["line"]
    for rounds in ([], [None, float("nan")], None):
        v = judge(SCENE_PATHS, "a", rounds, no_rounds="why not")
        assert v["status"] == "not judged" and v["line"].endswith(": not judged: why not")
    with pytest.raises(ValueError, match="reason"):
        not_judged(SCENE_PATHS, "a", "")
    with pytest.raises(ValueError, match="threshold"):
        Target("x", "render", "paths/s", 0.0, "Mitsuba", "a")
    with pytest.raises(ValueError, match="benchmark"):
        Target("x", "scaling", "paths/s", 1.5, "Mitsuba", "a")
    assert json.loads(json.dumps(v)) == v                      # JSON-able as it is


# ------------------------------------------------------------------------------------------- render targets

SUITE = ("a", "b", "c")


def _render_result(scenes=SUITE, *, rounds=None, efficiency=None, variants=(V,), rr_depths=(5, None),
                   strategies=("mis",), integrators=("wavefront",), max_depth=None, skipped=None):
    """A render-benchmark result with the fields the headline and the verdicts read; every
    scene's per-round ratios from ``rounds`` / ``efficiency`` (scene -> list; default 2.0 x5)."""
    rounds, efficiency = rounds or {}, efficiency or {}
    summary = []
    for rr in rr_depths:
        for s in scenes:
            r = rounds.get(s, [2.0] * 5)
            e = efficiency.get(s, [2.0] * 5)
            row = {"scene": s, "rr_depth": rr, "configuration": speed.rr_label(rr), "renderer": "ours",
                   "strategy": strategies[0], "integrator": integrators[0], "variant": None,
                   "paths_per_second": 1e6}
            for v in variants:
                row.update({f"ratio_{v}": median(r), f"cpu_ratio_{v}": 1.0,
                            f"efficiency_ratio_{v}": median(e), f"round_ratios_{v}": r,
                            f"round_efficiency_ratios_{v}": e})
            summary.append(row)
            summary += [{"scene": s, "rr_depth": rr, "configuration": speed.rr_label(rr), "renderer": "mitsuba",
                         "strategy": "path", "variant": v, "paths_per_second": 5e5} for v in variants]
    result = {"config": {"strategies": list(strategies), "integrators": list(integrators),
                         "rr_depths": list(rr_depths), "variants": list(variants) + list(skipped or {}),
                         "max_depth": max_depth},
              "available_variants": list(variants), "skipped_variants": dict(skipped or {}), "summary": summary}
    result["suite"] = speed.suite_summary(result)
    return result


def _by_line(verdicts):
    return {(v["target"], v["subject"]): v for v in verdicts}


def test_whole_suite_is_judged_per_scene_and_as_geometric_mean():
    rounds = {"a": [1.0, 1.1, 1.2, 1.3, 1.4], "b": [4.0, 4.0, 4.0, 4.0, 4.0], "c": [2.0, 2.1, 1.9, 2.2, 1.8]}
    out = render_verdicts(_render_result(rounds=rounds), suite_scenes=SUITE)
    assert [(v["target"], v["subject"]) for v in out] == [
        ("scene paths/s", "a"), ("scene efficiency", "a"), ("scene paths/s", "b"), ("scene efficiency", "b"),
        ("scene paths/s", "c"), ("scene efficiency", "c"), ("suite paths/s", "suite geometric mean"),
        ("suite efficiency", "suite geometric mean")]
    got = _by_line(out)
    assert got["scene paths/s", "a"]["status"] == "not met" and got["scene paths/s", "a"]["clearly"] is True
    assert got["scene paths/s", "b"]["line"].endswith("met, clearly (4.00x, 90% interval 4.00-4.00, 5 rounds)")
    gm = got["suite paths/s", "suite geometric mean"]
    per_round = [(x * 4.0 * y) ** (1 / 3) for x, y in zip(rounds["a"], rounds["c"])]   # each round's mean
    assert gm["median"] == pytest.approx(float(np.median(per_round)))
    assert (gm["low"], gm["high"]) == pytest.approx((min(per_round), max(per_round)))
    assert gm["threshold"] == 1.75 and gm["status"] == "met"
    assert "no RR" not in " ".join(v["line"] for v in out)    # only Mitsuba's default configuration


def test_partial_suite_and_scenes_outside_it():
    out = render_verdicts(_render_result(scenes=("a",)), suite_scenes=SUITE)
    assert [v["status"] for v in out] == ["met", "met", "not judged", "not judged"]
    assert out[2]["line"] == ("suite geometric mean paths/s vs Mitsuba llvm_ad_rgb >= 1.75x: not judged: "
                              "1 of 3 suite scenes in this run")
    # a scene file beside the whole suite: not judged itself, and left out of the geometric mean
    res = _render_result(scenes=SUITE + ("my_file",), rounds={"my_file": [0.01] * 5})
    got = _by_line(render_verdicts(res, suite_scenes=SUITE))
    assert got["scene paths/s", "my_file"]["reason"].startswith("not a suite scene")
    assert ("scene efficiency", "my_file") not in got
    assert got["suite paths/s", "suite geometric mean"]["median"] == pytest.approx(2.0)


@pytest.mark.parametrize("kwargs, reason", [
    ({"variants": ("scalar_rgb",)}, "Mitsuba llvm_ad_rgb not in this run (--variant scalar_rgb)"),
    ({"variants": ("scalar_rgb",), "skipped": {V: "no libLLVM"}}, "Mitsuba llvm_ad_rgb did not run here (no libLLVM)"),
    ({"rr_depths": (None, 3)}, "no rr_depth 5 configuration (Mitsuba's default) in this run (--rr-depth none,3)"),
    ({"strategies": ("light", "mis")}, "the headline strategy is light"),
    ({"integrators": ("scalar", "wavefront")}, "the headline integrator is scalar"),
    ({"max_depth": 8}, "--max-depth 8 overrides"),
])
def test_what_the_run_did_not_measure_is_not_judged(kwargs, reason):
    out = render_verdicts(_render_result(**kwargs), suite_scenes=SUITE)
    assert [(v["target"], v["status"]) for v in out] == [
        (t, "not judged") for t in ("scene paths/s", "scene efficiency", "suite paths/s", "suite efficiency")]
    assert all(v["reason"].startswith(reason) and v["median"] is None for v in out)
    assert out[0]["line"].startswith("each suite scene paths/s vs Mitsuba llvm_ad_rgb >= 1.5x: not judged: ")


def test_efficiency_rounds_without_a_finite_ratio():
    nan = float("nan")
    res = _render_result(efficiency={"a": [nan] * 5, "b": [2.0, nan, 2.0, 2.0, 2.0]})
    got = _by_line(render_verdicts(res, suite_scenes=SUITE))
    assert got["scene efficiency", "a"]["status"] == "not judged"
    assert "--reference-spp" in got["scene efficiency", "a"]["reason"]
    assert got["scene efficiency", "b"]["rounds"] == 4 and got["scene efficiency", "b"]["low"] is None
    assert got["suite efficiency", "suite geometric mean"]["status"] == "not judged"   # no round complete
    assert got["suite paths/s", "suite geometric mean"]["status"] == "met"
    # the headline's own geometric-mean rounds: NaN where a scene lacks the round, not a mean of fewer
    gm = [r for r in res["suite"]["rows"] if r["scene"] == speed.GEOMEAN][0]
    assert all(math.isnan(x) for x in gm[f"round_efficiency_ratios_{V}"])
    assert gm[f"round_ratios_{V}"] == pytest.approx([2.0] * 5)
    assert SCENE_EFFICIENCY.metric == "efficiency"


# ------------------------------------------------------------------------------------------- ray targets

def _ray_result(configs, *, variant=V, skipped=None, config_variant=V):
    rows = [{"requested_triangles": n, "triangles": n - 144, "kind": k, "round_ratios": r} for n, k, r in configs]
    return {"config": {"triangles": sorted({n for n, _, _ in configs}) or [500], "kinds": ["primary", "random"],
                       "variant": config_variant},
            "mitsuba": {"variant": variant, "skipped": skipped or {}}, "rows": rows}


def test_ray_target_per_configuration():
    full = [(n, k, [1.3, 1.25, 1.35, 1.28, 1.31]) for n in (100_000, 1_000_000) for k in ("primary", "random")]
    full[3] = (1_000_000, "random", [0.9, 0.95, 1.0, 0.97, 0.93])
    out = ray_verdicts(_ray_result(full))
    assert [(v["subject"], v["status"]) for v in out] == [
        ("100k triangles, primary", "met"), ("100k triangles, random", "met"),
        ("1M triangles, primary", "met"), ("1M triangles, random", "not met")]
    assert out[3]["line"] == ("1M triangles, random rays/s vs Embree >= 1.2x: not met, clearly "
                              "(0.95x, 90% interval 0.90-1.00, 5 rounds)")
    out = ray_verdicts(_ray_result([(1_000_000, "random", [1.3] * 5), (4000, "random", [9.0] * 5)]))
    assert [v["status"] for v in out] == ["not judged", "not judged", "not judged", "met"]
    assert out[0]["reason"] == "not in this run (--triangles 4000,1000000)"


def test_ray_target_without_embree():
    (v,) = ray_verdicts(_ray_result([], variant=None, config_variant=None))
    assert v["status"] == "not judged" and v["subject"] == RAYS.scope and "no Mitsuba JIT variant" in v["reason"]
    (v,) = ray_verdicts(_ray_result([], variant=None, skipped={V: "no libLLVM"}))
    assert v["reason"] == "Mitsuba llvm_ad_rgb did not run here (no libLLVM)"
    (v,) = ray_verdicts(_ray_result([], variant="cuda_ad_rgb", config_variant="cuda_ad_rgb"))
    assert "Embree" in v["reason"]


def test_closing_lines_count_each_status():
    from benchmarks.speed import verdict_lines

    met, missed = judge(SUITE_PATHS, "s", [2.0] * 5), judge(SUITE_PATHS, "s", [1.0] * 5)
    lines = verdict_lines([met, missed, not_judged(RAYS, "r", "why")])
    assert lines[0].endswith("1 met, 1 not met, 1 not judged") and lines[1:] == [
        f"  {v['line']}" for v in (met, missed)] + ["  r rays/s vs Embree >= 1.2x: not judged: why"]


# ------------------------------------------------------------------------------------------- the CLI

def test_cli_ends_with_the_verdicts_and_writes_them_to_json(tmp_path, capsys, jit_variant):
    """A tiny run (12x8, 2 spp, 2 rounds, rr_depth 5): one scene judged on too few rounds,
    the geometric mean not judged; the lines close the output and the JSON carries them;
    with --require-targets the exit status follows the verdicts. With --quiet the
    verdicts are still printed."""
    variants = f"{jit_variant},scalar_rgb" if jit_variant else "scalar_rgb"
    path = tmp_path / "speed.json"
    rc = main(["speed", "cornell_box", "--width", "12", "--height", "8", "--spp", "2", "--repeats", "2",
               "--threads", "2", "--strategies", "mis", "--variant", variants, "--rr-depth", "5",
               "--reference-kind", "ours", "--reference-spp", "32", "--require-targets", "--json", str(path)])
    out = capsys.readouterr().out
    verdicts = json.loads(path.read_text())["verdicts"]
    lines = [f"  {v['line']}" for v in verdicts]
    tail = out.rstrip("\n").split("\n")
    assert tail[-len(lines) - 2].startswith("speed targets (")       # after the tables and notes
    assert tail[-len(lines) - 1:-1] == lines and tail[-1] == f"  JSON: {path}"
    assert rc == (1 if any(v["status"] == "not met" for v in verdicts) else 0)
    gm = [v for v in verdicts if v["subject"] == "suite geometric mean"]
    assert [v["status"] for v in gm] == ["not judged"] * 2 and gm[0]["reason"].startswith("1 of ")
    if jit_variant:
        scene = [v for v in verdicts if v["subject"] == "cornell_box"]
        assert [v["metric"] for v in scene] == ["paths/s", "efficiency"]
        assert scene[0]["status"] in ("met", "not met") and scene[0]["rounds"] == 2
        assert scene[0]["line"].endswith("2 rounds; too few rounds for a 90% interval: use --repeats 5)")
    else:
        assert all(v["status"] == "not judged" for v in verdicts)
    # --quiet: no tables, the verdicts still close the output
    rc = main(["speed", "cornell_box", "--width", "8", "--spp", "2", "--repeats", "1", "--threads", "1",
               "--strategies", "mis", "--variant", "scalar_rgb", "--rr-depth", "5", "--reference-kind", "ours",
               "--reference-spp", "16", "--quiet", "--require-targets"])
    out = capsys.readouterr().out.splitlines()
    assert rc == 0 and out[0].startswith("speed targets (") and out[0].endswith("0 met, 0 not met, 4 not judged")
    assert out[1] == ("  each suite scene paths/s vs Mitsuba llvm_ad_rgb >= 1.5x: not judged: Mitsuba llvm_ad_rgb "
                      "not in this run (--variant scalar_rgb)")
