"""Generator of small synthetic results stores for the report tests (and for trying the report by hand).

The store follows the harness's layout (issue 5): ``meta.json``, ``results.jsonl``,
``summary.json`` and EXR images (reference, and the mean image of seed 0 of each job).
Images are a procedural Cornell-box-like picture plus Gaussian noise whose standard
deviation falls as 1/sqrt(spp); the ``light`` strategy is darkened off the emitter to
stand in for the indirect light it misses (a bias).

Run as a script to write one: ``python tests/support/report_store.py OUT [--size 64]``.
"""
from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks import metrics as M  # noqa: E402
from benchmarks.display import reference_exposure, to_display  # noqa: E402
from benchmarks.sweep.by_metric import add_metric_ratios, curve_metrics  # noqa: E402
from benchmarks.sweep.headline import add_noise_ratios, headline_rows  # noqa: E402
from benchmarks.store import write_image  # noqa: E402

#: per-sample relative noise of each (renderer, strategy)
NOISE = {("ours", "uniform"): 0.9, ("ours", "cosine"): 0.6, ("ours", "light"): 0.25, ("ours", "mixture"): 0.3,
         ("ours", "mis"): 0.2, ("mitsuba", "path"): 0.2}
#: seconds per sample per pixel (arbitrary units)
COST = {("ours", "uniform"): 1.0e-6, ("ours", "cosine"): 1.1e-6, ("ours", "light"): 1.3e-6,
        ("ours", "mixture"): 1.5e-6, ("ours", "mis"): 1.8e-6, ("mitsuba", "path"): 1.2e-6}


def scene_image(size: int, *, variant: int = 0) -> np.ndarray:
    """A procedural, Cornell-box-like linear image (H, W, 3) with a bright emitter at the top."""
    y, x = np.mgrid[0:size, 0:size].astype(np.float64) / max(size - 1, 1)
    img = np.empty((size, size, 3))
    img[...] = 0.55 * (0.6 + 0.4 * (1 - y))[..., None]
    left, right = x < 0.18, x > 0.82
    img[left] = img[left] * np.array([1.0, 0.15, 0.12])
    img[right] = img[right] * np.array([0.15, 0.9, 0.2])
    img[y > 0.85] *= 0.7  # floor
    cx, cy, r = (0.4, 0.62, 0.2) if variant == 0 else (0.6, 0.55, 0.25)
    d2 = (x - cx) ** 2 + (y - cy) ** 2
    ball = d2 < r * r
    shade = np.clip(1.0 - np.sqrt(d2) / r, 0, 1) ** 0.5
    img[ball] = (0.2 + 0.7 * shade[ball])[:, None] * np.array([0.8, 0.8, 0.75])
    light = (y < 0.06) & (np.abs(x - 0.5) < 0.15)
    img[light] = 12.0
    return img.astype(np.float32)


def _metrics(img, ref, exposure):
    from skimage.metrics import structural_similarity

    d = img.astype(np.float64) - ref
    mse = float(np.mean(d ** 2))
    relmse = float(np.mean(d ** 2 / (ref.astype(np.float64) ** 2 + 0.01)))
    disp = lambda a: to_display(a, exposure)  # noqa: E731 - as the report shows them
    ssim = float(structural_similarity(disp(img), disp(ref), data_range=1.0,
                                       channel_axis=-1, gaussian_weights=True, sigma=1.5,
                                       use_sample_covariance=False, win_size=7))
    return mse, relmse, ssim, M.flip(img, ref) if M.flip_available() else None


def make_store(path, *, scenes=("cornell_box", "spheres"), strategies=("uniform", "light", "mixture"),
               spps=(1, 4, 16), seeds=(0, 1), size=16, mitsuba=True, seed_comparison=False,
               duplicate=True, truncated=False, rng_seed=7) -> Path:
    """Write a synthetic results store and return its folder.

    Parameters
    ----------
    path : str or Path
        Folder to create (may exist).
    scenes, strategies, spps, seeds : sequences
        The sweep: every scene x (our strategies + Mitsuba ``path``) x spp x seed.
    size : int
        Width and height of the images.
    mitsuba : bool
        Include Mitsuba ``path`` jobs.
    seed_comparison : bool
        Add ``cornell_box`` jobs at 400x400 (uniform and light, spp 1, 4, 16, 50, 64, no
        images) whose RMSE follows exact power laws: uniform 0.5/sqrt(spp), light
        0.1/sqrt(spp), so light reaches uniform's 50-spp error at exactly 2 spp.
    duplicate : bool
        Append a stale first copy of one job before its final copy (a resumed run).
    truncated : bool
        End ``results.jsonl`` with a half-written line (an interrupted run).
    """
    rng = np.random.default_rng(rng_seed)
    root = Path(path)
    (root / "images").mkdir(parents=True, exist_ok=True)
    (root / "references").mkdir(parents=True, exist_ok=True)
    curves = [("ours", s) for s in strategies] + ([("mitsuba", "path")] if mitsuba else [])
    meta = {"date": "2025-11-22T05:40:00", "preset": "test", "total_seconds": 12.5, "threads": 2,
            "machine": {"cores": 2, "cpu": "Synthetic CPU @ 3.0GHz", "platform": "Linux-test"},
            "versions": {"rtbench": "0.1.0", "mitsuba": "3.9.1", "variant": "llvm_ad_rgb", "python": "3.11.2",
                         "numpy": np.__version__},
            "references": {}, "target_rmse": {}}
    records, rows = [], []
    for si, scene in enumerate(scenes):
        ref = scene_image(size, variant=si)
        ref_rel = f"references/{scene}.exr"
        write_image(root, ref_rel, ref)
        var_rel = f"references/{scene}_variance.exr"
        write_image(root, var_rel, (0.2 * ref) ** 2)
        meta["references"][scene] = {"spp": 4096, "seed": 1234, "path": ref_rel, "variance_path": var_rel}
        exposure = reference_exposure(ref)
        target = 0.08
        meta["target_rmse"][scene] = target
        for renderer, strategy in curves:
            sigma = NOISE.get((renderer, strategy), 0.4)
            mean_img = ref.astype(np.float64).copy()
            if strategy == "light":  # misses indirect light: darker away from the emitter
                mean_img[ref < 5] *= 0.7
            for spp in spps:
                for seed in seeds:
                    noise = rng.standard_normal(ref.shape) * (sigma * (ref + 0.05)) / math.sqrt(spp)
                    img = (mean_img + noise).astype(np.float32)
                    mse, relmse, ssim, flip = _metrics(img, ref, exposure)
                    secs = COST.get((renderer, strategy), 1e-6) * spp * size * size * (1 + 0.05 * rng.random())
                    image_rel = None
                    if seed == seeds[0]:
                        image_rel = f"images/{scene}/{renderer}_{strategy}_{spp}spp_seed{seed}.exr"
                        write_image(root, image_rel, img)
                    records.append({
                        "scene": scene, "renderer": renderer, "strategy": strategy, "spp": spp, "seed": seed,
                        "width": size, "height": size, "mse": mse, "rmse": math.sqrt(mse), "relmse": relmse,
                        "ssim": ssim, "flip": flip, "mse_corrected": mse - 1e-5,
                        "variance": float(np.mean((sigma * (ref + 0.05)) ** 2)), "seconds": secs,
                        "rays": None if renderer == "mitsuba" else int(spp * size * size * 3),
                        "paths_per_second": spp * size * size / secs, "threads": 2, "image": image_rel,
                        "versions": {"rtbench": "0.1.0", "mitsuba": "3.9.1"}})
            rows.append(_summary_row(records, scene, renderer, strategy, mean_img, ref, spps, size, target, rng))
        mits = next((r for r in rows if r["scene"] == scene and r["renderer"] == "mitsuba"), None)
        for r in rows:
            if r["scene"] == scene and mits is not None:
                r["efficiency_vs_mitsuba"] = r["efficiency"] / mits["efficiency"]
                r["samples_per_second_vs_mitsuba"] = r["samples_per_second"] / mits["samples_per_second"]
    add_metric_ratios(rows)
    add_noise_ratios(rows)
    if seed_comparison:
        records += _seed_comparison_records(seeds, root, meta)
    lines = [json.dumps(r) for r in records]
    if duplicate and records:
        stale = dict(records[0], rmse=999.0, mse=998001.0)
        lines.insert(0, json.dumps(stale))
    text = "\n".join(lines) + "\n"
    if truncated:
        text += json.dumps(records[-1])[:40]
    (root / "results.jsonl").write_text(text)
    (root / "summary.json").write_text(json.dumps({"rows": rows, "headline": headline_rows(rows)}, indent=1))
    (root / "meta.json").write_text(json.dumps(meta, indent=1))
    return root


def _summary_row(records, scene, renderer, strategy, mean_img, ref, spps, size, target, rng) -> dict:
    """The summary.json row of one curve, from its records (bias from the known mean image)."""
    recs = [r for r in records if r["scene"] == scene and (r["renderer"], r["strategy"]) == (renderer, strategy)]
    x = np.log([r["spp"] for r in recs])
    slope = float(np.polyfit(x, np.log([r["rmse"] for r in recs]), 1)[0])
    bias = float(np.mean((mean_img - ref) ** 2))
    last = [r for r in recs if r["spp"] == spps[-1]]
    mse_last = float(np.mean([r["mse"] for r in last]))
    sec_last = float(np.mean([r["seconds"] for r in last]))
    by_spp = {s: [r for r in recs if r["spp"] == s] for s in spps}
    secs = [float(np.mean([r["seconds"] for r in by_spp[s]])) for s in spps]
    by_metric = curve_metrics(by_spp, secs, target_rmse=target, unbiased=strategy != "light")
    # noise figures as the summary gives them from tail references: sigma^2 of the synthetic
    # noise in relMSE's weights, a 1% standard error, the cost model of COST
    sigma = NOISE.get((renderer, strategy), 0.4)
    r64 = ref.astype(np.float64)
    noise = float(np.mean((sigma * (r64 + 0.05)) ** 2 / (r64 * r64 + 0.01)))
    rel_bias = float(np.sum(mean_img - ref) / np.sum(ref))
    return {"by_metric": by_metric, "noise": noise, "noise_se": 0.01 * noise, "noise_lower_bound": False,
        "noise_source": "synthetic", "exact": False, "seconds_per_sample": COST.get((renderer, strategy), 1e-6),
        "relative_bias": rel_bias, "relative_bias_ci": [rel_bias - 0.005, rel_bias + 0.005],
        "bias_min_detectable": 0.02, "bias_spp": spps[-1], "reference_kind": "Mitsuba 4096 spp",
        "scene": scene, "renderer": renderer, "strategy": strategy, "width": size, "height": size,
        "slope": slope, "slope_ci": [slope - 0.04, slope + 0.04],
        "bias2": bias + float(rng.normal(0, 1e-6)), "bias2_stderr": 2e-6 + 1e-3 * bias,
        "bias_z": (bias / (2e-6 + 1e-3 * bias)) if bias > 0 else float(rng.normal()),
        "bias_p": 1e-12 if bias > 0 else 0.4, "bias_significant": bool(bias > 0),
        "bias_verdict": "fail" if bias > 0 else "pass",
        "variance": recs[0]["variance"], "efficiency": 1.0 / (mse_last * sec_last),
        "efficiency_vs_mitsuba": None, "time_to_target": None if strategy == "light" else sec_last * 0.7,
        "target_rmse": target, "samples_per_second": spps[-1] * size * size / sec_last,
        "samples_per_second_vs_mitsuba": None}


def _seed_comparison_records(seeds, root, meta) -> list[dict]:
    """cornell_box 400x400 uniform and light records on exact power laws (see make_store), with
    the seed figure's images (uniform at 50 spp, light at 4 spp, seed 0) and its reference,
    recorded in ``meta``'s ``references_by_size`` as a run records it."""
    ref = scene_image(400)
    write_image(root, "references/cornell_box_400x400.exr", ref)
    write_image(root, "references/cornell_box_400x400_var.exr", (0.2 * ref) ** 2)
    meta.setdefault("references_by_size", {})["cornell_box@400x400"] = {
        "spp": 64, "seed": 1234, "variant": "llvm_ad_rgb", "path": "references/cornell_box_400x400.exr",
        "variance_path": "references/cornell_box_400x400_var.exr"}
    noise = np.random.default_rng(3).standard_normal(ref.shape)
    out = []
    for strategy, a in (("uniform", 0.5), ("light", 0.1)):
        for spp in (1, 4, 16, 50, 64):
            for seed in seeds:
                image = None
                if seed == seeds[0] and (strategy, spp) in (("uniform", 50), ("light", 4)):
                    image = f"images/cornell_box_400x400/ours_{strategy}_spp{spp}_seed{seed}.exr"
                    write_image(root, image, (ref + a * (ref + 0.05) * noise / math.sqrt(spp)).astype(np.float32))
                rmse = a / math.sqrt(spp)
                out.append({"scene": "cornell_box", "renderer": "ours", "strategy": strategy, "spp": spp,
                            "seed": seed, "width": 400, "height": 400, "mse": rmse ** 2, "rmse": rmse,
                            "relmse": rmse ** 2 * 3, "relmse_corrected": rmse ** 2 * 3, "ssim": 1 - rmse,
                            "mse_corrected": rmse ** 2,
                            "variance": a * a, "seconds": 0.01 * spp, "rays": 1000 * spp,
                            "paths_per_second": 1.6e7, "threads": 2, "image": image, "versions": {}})
    return out


if __name__ == "__main__":
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out")
    ap.add_argument("--size", type=int, default=64)
    ap.add_argument("--spp", default="1,4,16,64")
    ap.add_argument("--strategies", default="uniform,light,mixture,mis")
    a = ap.parse_args()
    p = make_store(a.out, size=a.size, spps=tuple(int(s) for s in a.spp.split(",")),
                   strategies=tuple(a.strategies.split(",")), seed_comparison=True)
    print(p)
