"""``rtbench speed`` and ``benchmarks.speed``: fields and sane values (never timed
assertions: speed is reported, not asserted), and one real correctness check: ours and
Mitsuba agree on closest hits of the same rays on a small mesh."""
from __future__ import annotations

import json
import math
import statistics

import numpy as np
import pytest

from benchmarks import speed
from benchmarks.cli import main


def test_cli_render_table_and_json(tmp_path, capsys):
    """The CLI on a tiny configuration: 12x8, 2 spp, 2 rounds, two strategies, scalar_rgb,
    the default Russian-roulette configurations (rr_depth 5, then none)."""
    render_json = tmp_path / "speed.json"
    rc = main(["speed", "cornell_box", "--width", "12", "--height", "8", "--spp", "2", "--repeats", "2",
               "--threads", "2", "--strategies", "mis,light", "--variants", "scalar_rgb",
               "--reference", "ours", "--reference-spp", "32", "--json", str(render_json)])
    out = capsys.readouterr().out
    assert rc == 0
    for header in ("Mpaths/s", "Mpaths/cpu-s", "Mrays/s", "ms/spp", "ratio scalar (cpu)", "RMSE",
                   "eff. ratio scalar", "ours mis", "ours light", "Mitsuba scalar_rgb", "configuration",
                   "rr_depth 5", "no RR", "geometric mean (1)", "rtbench speed, suite: ours mis vs Mitsuba"):
        assert header in out, header
    assert out.index("rr_depth 5") < out.index("no RR")   # Mitsuba's default first
    assert "noisy" in out and "CPU time" in out          # the shared-machine caveat is printed
    assert "against ours (mis) 32 spp" in out            # which reference was used

    res = json.loads(render_json.read_text())["render"]
    assert res["config"]["spp"] == 2 and res["available_variants"] == ["scalar_rgb"]
    assert res["config"]["rr_depths"] == [5, None]
    assert res["environment"]["note"] == speed.WALL_CLOCK_NOTE
    labels = [(r["configuration"], r["label"]) for r in res["summary"]]
    assert sorted(labels) == sorted((c, x) for c in ("rr_depth 5", "no RR")
                                    for x in ("Mitsuba scalar_rgb", "ours light", "ours mis"))
    assert [r["configuration"] for r in res["summary"]][:3] == ["rr_depth 5"] * 3
    runs = res["runs"]
    assert len(runs) == 2 * 2 * 3                          # configurations x rounds x renderers
    for r in runs:
        assert r["width"] == 12 and r["height"] == 8 and r["spp"] == 2 and r["threads"] == 2
        assert r["max_depth"] == 50 and r["rr_depth"] in (5, None)
        assert r["paths"] == 12 * 8 * 2
        assert r["seconds"] > 0 and r["process_seconds"] >= 0
        assert math.isclose(r["paths_per_second"], r["paths"] / r["seconds"], rel_tol=1e-9)
        assert math.isclose(r["ms_per_spp"], 1e3 * r["seconds"] / 2, rel_tol=1e-9)
        assert 0 < r["rmse"] < 10 and math.isclose(r["rmse"] ** 2, r["mse"], rel_tol=1e-9)
        assert r["nonfinite_samples"] == 0
        if r["mse_corrected"] is not None and r["mse_corrected"] > 0:
            assert math.isclose(r["efficiency"], 1 / (r["mse_corrected"] * r["seconds"]), rel_tol=1e-9)
        if r["renderer"] == "ours":
            assert r["rays"] >= r["paths"]                 # at least the camera ray of every path
            assert math.isclose(r["rays_per_second"], r["rays"] / r["seconds"], rel_tol=1e-9)
        else:
            assert r["rays"] is None and r["variant"] == "scalar_rgb"
    for rr in (5, None):
        cfg = [r for r in runs if r["rr_depth"] == rr]
        # interleaving: within every round each configuration ran once, and the order alternates
        rounds = [[(r["renderer"], r["strategy"]) for r in cfg if r["round"] == k] for k in (0, 1)]
        assert sorted(rounds[0]) == sorted(rounds[1]) and rounds[0] == rounds[1][::-1]
        assert rounds[0][1][0] == "mitsuba"                # ours, Mitsuba, ours: not grouped

        # the paired ratios are medians of per-round ratios
        mits = [r for r in cfg if r["renderer"] == "mitsuba"]
        for row in res["summary"]:
            if row["rr_depth"] != rr:
                continue
            assert row["runs"] == 2 and row["paths_per_second"] > 0
            if row["renderer"] != "ours":
                assert "ratio_scalar_rgb" not in row
                continue
            ours = [r for r in cfg if r["renderer"] == "ours" and r["strategy"] == row["strategy"]]
            per_round = [a["paths_per_second"] / b["paths_per_second"] for a, b in zip(ours, mits)]
            want = statistics.median(per_round)
            assert math.isclose(row["ratio_scalar_rgb"], want, rel_tol=1e-9)
            assert row["round_ratios_scalar_rgb"] == pytest.approx(per_round, rel=1e-12)
            assert row["cpu_ratio_scalar_rgb"] > 0
            assert row["efficiency_ratio_scalar_rgb"] is None or row["efficiency_ratio_scalar_rgb"] > 0
    assert res["references"]["cornell_box"]["kind"] == "ours"
    assert res["ours"]["cornell_box"]["build_seconds"] >= 0
    for label in ("rr_depth 5", "no RR"):   # no JIT in scalar
        assert res["mitsuba"]["cornell_box"][label]["scalar_rgb"]["compile_seconds"] == 0.0
    # the headline: mis (the first strategy) per configuration, then the geometric mean
    suite = res["suite"]
    assert suite["strategy"] == "mis" and suite["variants"] == ["scalar_rgb"]
    assert [(r["configuration"], r["scene"]) for r in suite["rows"]] == [
        ("rr_depth 5", "cornell_box"), ("rr_depth 5", "geometric mean"),
        ("no RR", "cornell_box"), ("no RR", "geometric mean")]
    for head, gm in (suite["rows"][0:2], suite["rows"][2:4]):
        assert gm["scenes"] == 1 and math.isclose(gm["ratio_scalar_rgb"], head["ratio_scalar_rgb"], rel_tol=1e-12)
        assert gm["round_ratios_scalar_rgb"] == pytest.approx(head["round_ratios_scalar_rgb"], rel=1e-12)
    # the headline table shows the rounds' range beside the median
    lo, hi = min(suite["rows"][0]["round_ratios_scalar_rgb"]), max(suite["rows"][0]["round_ratios_scalar_rgb"])
    assert "rounds scalar" in out and f"{lo:.2f}-{hi:.2f}" in out


def test_cli_times_each_integrator_as_its_own_rows(tmp_path, capsys):
    """--integrators: every strategy timed with each integrator in every round; rows other
    than the wavefront's say which; the headline is the first integrator's."""
    out_json = tmp_path / "speed.json"
    rc = main(["speed", "cornell_box", "--width", "8", "--spp", "2", "--repeats", "2", "--threads", "1",
               "--strategies", "mis", "--integrators", "scalar,wavefront", "--variants", "scalar_rgb",
               "--rr-depth", "5", "--reference", "ours", "--reference-spp", "16", "--json", str(out_json)])
    out = capsys.readouterr().out
    assert rc == 0
    assert "ours mis (scalar)" in out and "rtbench speed, suite: ours mis (scalar) vs Mitsuba" in out
    res = json.loads(out_json.read_text())["render"]
    assert res["config"]["integrators"] == ["scalar", "wavefront"]
    assert sorted(r["label"] for r in res["summary"]) == ["Mitsuba scalar_rgb", "ours mis", "ours mis (scalar)"]
    ours = [r for r in res["runs"] if r["renderer"] == "ours"]
    assert sorted((r["round"], r["integrator"]) for r in ours) == [(0, "scalar"), (0, "wavefront"),
                                                                  (1, "scalar"), (1, "wavefront")]
    # Same seed per round, same image: the two integrators agree bit for bit.
    for k in (0, 1):
        a, b = (r for r in ours if r["round"] == k)
        assert a["mse"] == b["mse"] and a["rays"] == b["rays"]
    assert res["suite"]["integrator"] == "scalar"
    rc = main(["speed", "cornell_box", "--integrators", "simd", "--variants", "scalar_rgb"])
    assert rc == 2 and "integrators" in capsys.readouterr().err


def _summary_row(scene, rr_depth, renderer, strategy, pps, **ratios):
    """A render-benchmark summary row with only the fields the headline reads."""
    return {"scene": scene, "rr_depth": rr_depth, "configuration": speed.rr_label(rr_depth), "renderer": renderer,
            "strategy": strategy, "variant": "llvm_ad_rgb" if renderer == "mitsuba" else None,
            "paths_per_second": pps, **{f"{k}_llvm_ad_rgb": v for k, v in ratios.items()}}


def test_suite_summary_orders_configurations_and_takes_geometric_means():
    """Rows per configuration in run order (roulette first), scenes in run order, the
    headline strategy only, then the geometric mean of each ratio over the scenes."""
    summary = []
    for rr, scale in ((5, 1.0), (None, 2.0)):
        for scene, ratio in (("a", 0.5), ("b", 2.0), ("c", 4.0)):
            summary += [_summary_row(scene, rr, "ours", "mis", 1e6, ratio=scale * ratio, cpu_ratio=ratio,
                                     efficiency_ratio=ratio),
                        _summary_row(scene, rr, "ours", "cosine", 9e6, ratio=99.0, cpu_ratio=99.0,
                                     efficiency_ratio=99.0),
                        _summary_row(scene, rr, "mitsuba", "path", 3e6)]
    result = {"config": {"strategies": ["mis", "cosine"], "rr_depths": [5, None]},
              "available_variants": ["llvm_ad_rgb"], "summary": summary}
    rows = speed.suite_summary(result)["rows"]
    assert [(r["configuration"], r["scene"]) for r in rows] == [
        ("rr_depth 5", s) for s in ("a", "b", "c", "geometric mean")] + [
        ("no RR", s) for s in ("a", "b", "c", "geometric mean")]
    assert [r["ratio_llvm_ad_rgb"] for r in rows[:3]] == [0.5, 2.0, 4.0]
    assert rows[0]["mitsuba_paths_per_second_llvm_ad_rgb"] == 3e6 and rows[0]["ours_paths_per_second"] == 1e6
    assert math.isclose(rows[3]["ratio_llvm_ad_rgb"], 4.0 ** (1 / 3), rel_tol=1e-12)
    assert math.isclose(rows[7]["ratio_llvm_ad_rgb"], 2 * 4.0 ** (1 / 3), rel_tol=1e-12)
    assert math.isclose(rows[7]["efficiency_ratio_llvm_ad_rgb"], 4.0 ** (1 / 3), rel_tol=1e-12)
    assert rows[3]["scenes"] == 3 and rows[3]["rr_depth"] == 5 and rows[7]["rr_depth"] is None


def test_suite_table_has_one_row_per_scene_and_a_geometric_mean_per_configuration():
    """The printed headline: configuration blocks in order, each closed by its geometric
    mean; a missing efficiency ratio prints as '-' and stays out of the mean."""
    from rich.console import Console

    from benchmarks.commands.speed import suite_table

    summary = [_summary_row(s, rr, "ours", "mis", 2e6, ratio=r, cpu_ratio=r, efficiency_ratio=e, round_ratios=k)
               for rr in (5, None) for s, r, e, k in (("a", 1.0, None, [0.5, 2.0]), ("b", 4.0, 3.0, [2.0, 8.0]))]
    summary += [_summary_row(s, rr, "mitsuba", "path", 1e6) for rr in (5, None) for s in ("a", "b")]
    result = {"config": {"strategies": ["mis"], "rr_depths": [5, None], "width": 8, "height": 8, "spp": 2,
                         "threads": 2, "repeats": 2}, "available_variants": ["llvm_ad_rgb"], "summary": summary}
    result["suite"] = speed.suite_summary(result)
    console = Console(width=250, record=True)
    console.print(suite_table(result))
    rows = [[c.strip() for c in ln.split("\u2502")[1:-1]] for ln in console.export_text().splitlines()]
    rows = [r for r in rows if r and r[0] in ("rr_depth 5", "no RR")]
    assert [(r[0], r[1]) for r in rows] == [(c, s) for c in ("rr_depth 5", "no RR")
                                            for s in ("a", "b", "geometric mean (2)")]
    for r in rows:
        if r[1].startswith("geometric mean"):   # rounds: each round's geometric mean, 1 and 4
            assert r[2:] == ["-", "-", "2.00 (2.00)", "1.00-4.00", "3.00"]
    assert rows[0][2:] == ["2.000", "1.000", "1.00 (1.00)", "0.50-2.00", "-"]   # scene a: no efficiency ratio


def test_rr_depth_option_and_its_validation(capsys):
    from benchmarks.cli import build_parser

    speed_parser = next(a for a in build_parser()._actions if a.dest == "command").choices["speed"]
    assert speed_parser.parse_args(["--rr-depth", "none,3"]).rr_depth == (None, 3)
    for bad in ("x", ""):
        with pytest.raises(SystemExit) as exc:   # argparse rejects it
            main(["speed", "--rr-depth", bad, "--quiet"])
        assert exc.value.code == 2
        assert "rtbench speed: error: --rr-depth" in capsys.readouterr().err
    assert main(["speed", "--rr-depth", "0", "--quiet", "--variants", "scalar_rgb", "--reference", "ours"]) == 2
    assert "rtbench speed: error: --rr-depth: a depth must be >= 1, got 0" in capsys.readouterr().err
    with pytest.raises(ValueError, match="rr_depths: 5 given more than once"):
        speed.render_benchmark(["cornell_box"], rr_depths=(5, 5))
    with pytest.raises(ValueError, match="rr_depths: a depth must be an integer, None or 'scene', got 2.5"):
        speed.render_benchmark(["cornell_box"], rr_depths=(2.5,))


def test_cli_rejects_bad_input(capsys):
    assert main(["speed", "--spp", "0"]) == 2
    assert "--spp must be >= 1" in capsys.readouterr().err
    assert main(["speed", "--strategies", "mis,bogus", "--quiet"]) == 2
    assert "unknown strategies ['bogus']" in capsys.readouterr().err
    assert main(["speed", "--spp", "8", "--reference-spp", "8", "--quiet", "--variants", "scalar_rgb"]) == 2
    assert "--reference-spp (8) must exceed --spp (8)" in capsys.readouterr().err
    with pytest.raises(ValueError, match="unknown scenes"):
        speed.render_benchmark(["no_such_scene"])
    with pytest.raises(ValueError, match="reference must be one of"):
        speed.render_benchmark(reference="both")
    with pytest.raises(ValueError, match="JIT Mitsuba variant"):
        speed.ray_benchmark(variant="scalar_rgb")


@pytest.mark.parametrize("bad, message", [
    (["--strategies", "mis,bogus"], "unknown strategies ['bogus']"),
    (["--integrators", "simd"], "unknown integrators ['simd']"),
    (["no_such_scene"], "unknown scenes ['no_such_scene']"),
    (["--max-depth", "0"], "--max-depth must be >= 1 or -1, got 0"),
    (["--spp", "8", "--reference-spp", "8"], "--reference-spp (8) must exceed --spp (8)"),
    (["--rr-depth", "0"], "--rr-depth: a depth must be >= 1, got 0"),
    (["--rr-depth", "5,none,5"], "--rr-depth: 5 given more than once"),
])
def test_render_options_are_refused_before_an_isa_build(monkeypatch, capsys, bad, message):
    """A bad option of the render benchmark is one error line naming the option (exit 2) before
    the --isa build of our core (minutes) starts, not after it."""
    from benchmarks.commands import speed as command

    monkeypatch.setattr(command, "_build_isa", lambda *a: pytest.fail("built the core before checking the options"))
    monkeypatch.setattr(speed, "render_benchmark", lambda *a, **k: pytest.fail("rendered before the refusal"))
    assert main(["speed", *bad, "--isa", "avx2", "--quiet"]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"rtbench speed: error: {message}"), lines


@pytest.mark.parametrize("bad, message", [
    (["--rays", "--triangles", "10"], "--triangles: a mesh has at least 32 triangles, got 10"),
    (["--render", "--rays", "--triangles", "100,10"], "--triangles: a mesh has at least 32 triangles, got 10"),
    (["--rays", "--isa", "avx2", "--triangles", "10"], "--triangles: a mesh has at least 32 triangles, got 10"),
    (["--scaling", "--scaling-triangles", "10,1000"], "--scaling-triangles: a mesh has at least 32 triangles, got 10"),
    (["--render", "--scaling", "--scaling-triangles", "1000,1000"],
     "--scaling-triangles: the mesh sweep needs two different sizes at least, got 1000,1000"),
])
def test_mesh_sizes_are_refused_before_any_benchmark_naming_the_option(monkeypatch, capsys, bad, message):
    """--triangles and --scaling-triangles are checked before anything is built or timed (they
    were checked inside the ray and scaling benchmarks, after the render benchmark and an --isa
    build, as 'triangles must be >= 32' whichever option it was)."""
    from benchmarks.commands import speed as command

    monkeypatch.setattr(command, "_build_isa", lambda *a: pytest.fail("built the core before checking the options"))
    for name in ("render_benchmark", "ray_benchmark", "scaling_benchmark"):
        monkeypatch.setattr(speed, name, lambda *a, **k: pytest.fail("a benchmark ran before the refusal"))
    assert main(["speed", *bad, "--quiet"]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert lines == [f"rtbench speed: error: {message}"], lines


def test_no_working_variant_names_the_options_that_help(capsys):
    """Where no --variant works the refusal says which and why, and names --variant and
    --reference-kind ours (it named the Python keyword alone, reference='ours')."""
    assert main(["speed", "cornell_box", "--variant", "bogus_rgb", "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("rtbench speed: error: no Mitsuba variant of bogus_rgb works here "
                                               "(bogus_rgb: "), err
    assert "(--variant)" in err[0] and "--reference-kind ours" in err[0] and "{" not in err[0], err


def test_torus_mesh_is_closed_and_consistently_wound():
    v, f = speed.torus_mesh(2000, seed=3)
    assert abs(len(f) - 2000) < 100 and v.dtype == np.float64
    assert np.array_equal(v, v.astype(np.float32).astype(np.float64))   # float32-exact for Mitsuba
    # closed: each directed edge appears once and its reverse once (consistent winding)
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    directed = {tuple(x) for x in e.tolist()}
    assert len(directed) == len(e)
    assert all((b, a) in directed for a, b in directed)
    # outward: signed volume positive (CCW seen from outside)
    vol = np.einsum("ij,ij->i", v[f[:, 0]], np.cross(v[f[:, 1]], v[f[:, 2]])).sum() / 6
    assert vol > 0 and math.isclose(vol, 2 * math.pi ** 2 * 1.0 * 0.35 ** 2, rel_tol=0.05)


def test_ray_generators():
    o, d = speed.primary_rays(1000, seed=1)
    assert o.shape == d.shape == (1000, 3) and o.dtype == d.dtype == np.float32
    assert np.allclose(np.linalg.norm(d, axis=1), 1, atol=1e-6)
    assert np.allclose(o, o[0])                                   # one pinhole
    o2, d2 = speed.random_rays(1000, seed=1)
    assert np.allclose(np.linalg.norm(d2, axis=1), 1, atol=1e-6)
    assert o2.std(axis=0).min() > 0.1 and abs(d2.mean(axis=0)).max() < 0.15   # spread, isotropic-ish
    assert not np.array_equal(speed.random_rays(10, seed=2)[0], speed.random_rays(10, seed=3)[0])


def test_hit_agreement_and_log_fit():
    a = np.array([1.0, 2.0, np.inf, 4.0])
    b = np.array([1.0, 2.0 * (1 + 1e-3), np.inf, np.inf])
    r = speed.hit_agreement(a, b)
    assert r["hit_agreement"] == 0.75 and r["both_hit"] == 2 and r["t_agreement"] == 0.5
    with pytest.raises(ValueError):
        speed.hit_agreement(a, b[:3])
    n = np.array([1e3, 1e4, 1e5, 1e6])
    fit = speed.fit_log_growth(n, 50 + 7 * np.log(n))
    assert math.isclose(fit["b"], 7) and math.isclose(fit["a"], 50) and math.isclose(fit["r2"], 1)
    assert 0 < fit["loglog_exponent"] < 0.3
    assert math.isclose(speed.fit_log_growth(n, 3 * n)["loglog_exponent"], 1)   # linear growth
    with pytest.raises(ValueError):
        speed.fit_log_growth([10], [1.0])


def test_hits_agree_with_mitsuba_on_same_rays(jit_variant):
    """Real correctness check: > 99.9% of rays agree on hit/miss, distances agree."""
    from mitsuba_scenes import to_mitsuba
    from mitsuba_scenes.variants import select_variant
    from reference_tracer.probe import core_scene

    if jit_variant is None:
        pytest.skip("llvm_ad_rgb does not work here: Mitsuba's ray queries need a JIT variant")
    scene = speed.mesh_scene(3000, seed=5)
    core = core_scene(scene)
    select_variant(jit_variant)
    import mitsuba as mi

    mscene = mi.load_dict(to_mitsuba(scene))
    count = 20000
    for kind, gen in (("primary", speed.primary_rays), ("random", speed.random_rays)):
        o, d = gen(count, seed=11)
        ours = speed.intersect_ours(core, o, d, threads=2)
        theirs = speed.intersect_mitsuba(mscene, o, d)
        agree = speed.hit_agreement(ours["t"], theirs["t"])
        assert 0.1 < agree["hit_fraction_a"] < 0.9, (kind, agree)     # the test is not trivial
        assert agree["hit_agreement"] > 0.999, (kind, agree)
        assert agree["t_agreement"] > 0.999, (kind, agree)
        both = np.isfinite(ours["t"]) & np.isfinite(theirs["t"])
        assert np.mean(ours["prim"][both] == theirs["prim"][both]) > 0.99, kind


def test_ray_benchmark_fields(jit_variant, capsys, tmp_path):
    if jit_variant is None:
        pytest.skip("llvm_ad_rgb does not work here: the timed Mitsuba side needs a JIT variant")
    path = tmp_path / "rays.json"
    rc = main(["speed", "--rays", "--triangles", "500,4000", "--ray-count", "4000", "--repeats", "2",
               "--variants", jit_variant, "--json", str(path)])
    assert rc == 0
    out = capsys.readouterr().out
    assert "ours Mrays/s" in out and "Mitsuba Mrays/s" in out and "hit agree" in out and "ours full Mrays/s" in out
    # the ray targets' meshes (100k, 1M triangles) were not in this run: said, not passed
    verdicts = json.loads(path.read_text())["verdicts"]
    assert [(v["subject"], v["status"]) for v in verdicts] == [
        (f"{n} triangles, {k}", "not judged") for n in ("100k", "1M") for k in ("primary", "random")]
    assert out.rstrip().splitlines()[-2].endswith(
        "1M triangles, random rays/s vs Embree >= 1.2x: not judged: not in this run (--triangles 500,4000)")
    res = json.loads(path.read_text())["rays"]
    assert [(r["kind"], r["triangles"] < 1000) for r in res["rows"]] == [
        ("primary", True), ("random", True), ("primary", False), ("random", False)]
    for r in res["rows"]:
        assert r["rays"] == 4000 and len(r["ours_seconds"]) == len(r["mitsuba_seconds"]) == 2
        assert len(r["ours_full_seconds"]) == 2
        assert r["ours_mrays_per_second"] > 0 and r["mitsuba_mrays_per_second"] > 0
        assert math.isclose(r["ours_mrays_per_second"], 4000 / statistics.median(r["ours_seconds"]) / 1e6)
        assert math.isclose(r["ratio_full"], statistics.median(
            [m / o for o, m in zip(r["ours_full_seconds"], r["mitsuba_seconds"])]))
        assert r["ratio_min"] <= r["ratio"] <= r["ratio_max"]
        assert r["round_ratios"] == pytest.approx([m / o for o, m in zip(r["ours_seconds"], r["mitsuba_seconds"])])
        assert r["requested_triangles"] in (500, 4000)
        assert r["ratio_full_min"] <= r["ratio_full"] <= r["ratio_full_max"]
        assert r["agree_hit_agreement"] > 0.999
        assert r["build_seconds_per_mtri"] > 0 and r["mitsuba_load_seconds"] > 0 and r["bvh_depth"] >= 1
        # a tree of 8-wide nodes over blocks of four triangles: tens to hundreds of bytes a triangle
        assert 10 < r["bvh_bytes_per_triangle"] < 2000
        assert isinstance(r["ours_rss_growth_mib"], float) and isinstance(r["mitsuba_rss_growth_mib"], float)
        assert r["peak_rss_mib"] >= max(r["ours_rss_growth_mib"], r["mitsuba_rss_growth_mib"])


def test_resident_memory_sees_an_allocation():
    # In a fresh interpreter: in this one, memory freed by earlier tests stays resident and a new
    # block may reuse it without the resident size growing (why the benchmark's growths are lower bounds).
    import subprocess
    import sys

    code = ("import numpy as np; from benchmarks.speed.rays import resident_mib; now, peak = resident_mib(); "
            "block = np.ones(64 << 17); grown, peak_after = resident_mib(); "
            "print(now, peak, grown, peak_after, block.sum() == 64 << 17)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    now, peak, grown, peak_after = map(float, out[:4])
    assert out[4] == "True"
    assert 0 < now <= peak and grown - now > 60 and peak_after >= grown    # 64 MiB of doubles, every page touched


def test_scaling_fields():
    res = speed.scaling_benchmark(resolutions=(8, 16), depths=(3, 2), spp=1, thread_counts=(1, 2),
                                  triangles=(200, 2000), rays=2000, mesh_spp=1, variant=None, repeats=1)
    assert [r["resolution"] for r in res["resolution"]] == [8, 16]
    assert [r["max_depth"] for r in res["depth"]] == [2, 3] and res["config"]["depths"] == [2, 3]
    assert [r["threads"] for r in res["threads"]] == [1, 2]
    assert res["threads"][0]["ours_speedup"] == 1.0 and res["threads"][1]["ours_speedup"] > 0
    assert [r["triangles"] < 1000 for r in res["mesh"]] == [True, False]
    for r in res["resolution"] + res["depth"] + res["threads"] + res["mesh"]:
        assert r["ours_paths_per_second"] > 0 and "mitsuba_paths_per_second" not in r
    fit = res["fits"]["ours_ns_per_ray"]
    assert set(fit) == {"a", "b", "per_doubling", "r2", "loglog_exponent"} and "mitsuba_ns_per_ray" not in res["fits"]
    with pytest.raises(ValueError, match="at least two"):
        speed.scaling_benchmark(triangles=(1000,))
