"""The per-curve summary of a results store (``summary.json``): slope, bias, variance, cost of each
(scene, renderer, strategy, width, height), from the store and the cached tail references alone, so
:func:`summarize` can be rerun at any time. Fields: ``benchmarks/STORE.md``; statistics: ``STATISTICS.md``."""
from __future__ import annotations

import collections
import math
from pathlib import Path

import numpy as np

from reference_tracer.estimate import ImageEstimate

from .. import metrics as M
from .. import tails as T
from ..constants import BIAS_TEST_ALPHA, CLOSED_FORM, MITSUBA_STRATEGY, STRATEGIES
from ..numbers import as_float, finite_mean, ratio
from ..scenes import scene_at
from ..store import SUMMARY, read_image, read_meta, read_records, update_meta, write_json
from ..tails import DEFAULT_MAX_TAIL_SAMPLES, DEFAULT_TAIL_SPP
from .bias import bias_stats
from .by_metric import add_metric_ratios, curve_metrics, tail_variance_image
from .headline import add_noise_ratios, exact, headline_rows, mitsuba_cost, tail_noise
from .jobs import mitsuba_pairs
from .progress import render_cost
from .slopes import mse_reliable_from, reliable_points_only, slope_stats, slope_status

#: time-to-target uses target RMSE = this x the reference's RMS radiance.
TARGET_RELATIVE_RMSE = 0.1

#: what the summary's fields mean, written into ``summary.json`` (``{alpha}``, ``{target}`` filled in).
_NOTES = {
    "slope": "fit of log sqrt(mean over seeds of mse_corrected) on log spp, "
             "one point per spp; slope_ci is its 95% t interval; slope_status marks a slope measured "
             "where the estimator is still heavy-tailed (bias_verdict undetermined at the top spp); "
             "slope_excluded_spps: budgets below slope_fit_from (from the tail reference: the budget from "
             "which the seed-averaged MSE is near its expectation), left out of the fit",
    "bias": "bias2: metrics.bias_variance at bias_spp over bias_seeds "
            "seeds; bias_significant, bias_p: tile and image levels of "
            "benchmarks.gate.compare on the mean over seeds (Bonferroni), "
            "level {alpha}, 2+ seeds needed; bias_z: normal quantile of bias_p. "
            "Estimators whose value rests on rare paths (uniform sampling "
            "of small lights on glossy plates) are flagged until they "
            "converge: their error at that spp is real",
    "efficiency": "1 / (expected MSE x mean seconds) at the highest spp: for our estimators found unbiased "
                  "the expected MSE is the tail reference's per-sample variance / spp, else the mean "
                  "mse_corrected (efficiency_source)",
    "tails": "variance, skewness and kurtosis of our estimators from cached tail references "
             "(benchmarks.tails); bias_verdict is the gate's three-valued test (benchmarks/STATISTICS.md)",
    "target_rmse": "{target} x RMS of the reference radiance",
    "by_metric": "slope, efficiency and time to target under relMSE, 1 - SSIM and FLIP (benchmarks.sweep.by_metric; "
                 "the top-level figures are RMSE's); efficiency and time to target mean something only where no bias "
                 "was detected",
}


def target_rmse(ref_mean) -> float:
    """Target RMSE of a scene: :data:`TARGET_RELATIVE_RMSE` x the RMS of the reference's radiance.

    >>> target_rmse(np.full((4, 4, 3), 2.0))
    0.2
    """
    r = np.asarray(ref_mean, dtype=np.float64)
    return float(TARGET_RELATIVE_RMSE * math.sqrt(float(np.mean(r * r))))


def _scene_filter(scene: str, w: int, h: int, cache: dict):
    """The pixel filter of a store's scene (None where the scene is no longer known here)."""
    if scene not in cache:
        try:
            cache[scene] = scene_at(scene, w, h).camera.filter
        except (ValueError, KeyError):
            cache[scene] = None
    return cache[scene]


def _curve_stats(recs, ref: ImageEstimate | None, store, *, alpha, target, tails=None, pixel_filter=None) -> dict:
    """Summary figures of one curve."""
    by_spp = collections.defaultdict(list)
    for r in recs:
        by_spp[int(r["spp"])].append(r)
    spps = sorted(by_spp)
    mse_c = np.array([finite_mean(r.get("mse_corrected") for r in by_spp[s]) for s in spps])
    mse_p = np.array([finite_mean(r.get("mse") for r in by_spp[s]) for s in spps])
    secs = np.array([finite_mean(r.get("seconds") for r in by_spp[s]) for s in spps])
    row = {"spps": spps, "seeds": max(len(by_spp[s]) for s in spps), "timing_source": "each render's wall time"}
    row.update(slope_stats(spps, mse_c, mse_p))
    top = spps[-1]
    row.update(bias_stats(by_spp[top], top, ref, store, alpha=alpha, tails=tails, pixel_filter=pixel_filter))
    row["slope_fit_from"] = mse_reliable_from(tails, seeds=row["seeds"]) if tails is not None else None
    row.update(reliable_points_only(spps, mse_c, mse_p, row))
    lo_hi = row.get("slope_ci") or ([row["slope"]] * 2 if row.get("slope") is not None else None)
    row["slope_steep"] = bool(lo_hi is not None and lo_hi[1] < -0.5)  # RMSE's Monte Carlo slope
    row["slope_status"] = slope_status(row)
    if row["variance"] is None:
        row["variance"] = finite_mean(r.get("variance") for r in recs)
    row["variance_source"], row["variance_lower_bound"] = "renders at the top spp", None
    if tails is not None:
        row.update(tail_noise(tails, ref))

    # cost: efficiency at the top spp, throughput, time to the target RMSE. An unbiased
    # estimator's expected MSE at n spp is its per-sample variance / n; from the tail
    # reference's variance it counts the rare paths a few renders at the top spp missed.
    row["efficiency"] = None
    unbiased = row.get("bias_verdict") in ("pass", "undetermined")
    if tails is not None and exact(tails):
        # every sample equals the pixel value (mis in the furnace): no error to trade for time
        row.update(variance=0.0, variance_lower_bound=False, efficiency_source="exact (zero variance)")
    elif tails is not None and unbiased and row["variance"] > 0 and secs[-1] > 0:
        row["efficiency"] = M.efficiency(row["variance"] / top, secs[-1])
        row["efficiency_source"] = "tail-reference variance / spp"
    elif math.isfinite(mse_c[-1]) and mse_c[-1] > 0 and secs[-1] > 0:
        row["efficiency"] = M.efficiency(mse_c[-1], secs[-1])
        row["efficiency_source"] = "measured MSE"
    row["samples_per_second"] = finite_mean(r.get("paths_per_second") for r in by_spp[top])
    row["seconds_at_top"] = secs[-1]
    row["target_rmse"] = target
    row["time_to_target"] = None
    ok = np.isfinite(mse_c) & (mse_c > 0)
    if target is not None and ok.any():
        row["time_to_target"] = M.time_to_error(secs[ok], np.sqrt(mse_c[ok]), target)
    row["rmse_at_top"] = math.sqrt(mse_p[-1]) if mse_p[-1] >= 0 else None
    row["by_metric"] = curve_metrics(by_spp, secs, ref=ref, target_rmse=target, unbiased=unbiased,
                                     variance_image=tail_variance_image(tails) if tails is not None else None,
                                     fit_from=row["slope_fit_from"] if row["slope_excluded_spps"] else None)
    if row.get("efficiency_source") == "exact (zero variance)":
        # float rounding is all the error there is: no efficiency under any metric (it was ~1e27)
        for fig in row["by_metric"].values():
            fig.update(efficiency=None, efficiency_source="exact (zero variance)")
    return row


def _store_reference(store, info) -> ImageEstimate | None:
    """The reference a store holds for one (scene, size) (``meta.json``'s entry ``info``), or None."""
    if not info:
        return None
    try:
        return ImageEstimate(mean=read_image(store, info["path"], sha256=info.get("sha256")).astype(np.float64),
                             variance=read_image(store, info["variance_path"],
                                                 sha256=info.get("variance_sha256")).astype(np.float64),
                             spp=int(info["spp"]), seconds=as_float(info.get("render_seconds")),
                             source=str(info.get("variant", "")))
    except Exception:  # noqa: BLE001 - missing or corrupt (checksum) reference: figures that need it stay null
        return None


def _add_mitsuba_ratios(rows) -> None:
    """``*_vs_mitsuba``: each curve against Mitsuba's curve of the same scene and size."""
    for r, m in mitsuba_pairs(rows):
        for field in ("efficiency", "samples_per_second"):
            r[f"{field}_vs_mitsuba"] = ratio(r.get(field), (m or {}).get(field))


def _curve_tails(scene, strategy, w, h, *, tail_spp, cache, threads, log, escalate=True):
    """The tail reference of one of our curves (cached; with ``escalate`` a larger one where its
    variance rests on single samples: ``variance_tail_reference``), or None."""
    if not tail_spp:
        return None
    cap = DEFAULT_MAX_TAIL_SAMPLES if escalate else tail_spp * w * h
    try:
        return T.variance_tail_reference(scene_at(scene, w, h), strategy=strategy, spp=tail_spp, cache=cache,
                                         threads=threads, log=log, max_samples=cap, what=f"{scene} {w}x{h}")
    except ValueError as exc:  # a scene no longer in the suite: no tail diagnostics for it
        if log:
            log(f"no tail reference for {scene} ({strategy}): {exc}")
        return None


def _not_escalated(row: dict, tails, w: int, h: int) -> None:
    """Without the larger tail reference (the quick preset), a verdict on a variance resting on
    single samples is undetermined, with the budget that would decide."""
    if tails is None or not T.variance_is_lower_bound(tails):
        return
    need = DEFAULT_MAX_TAIL_SAMPLES // (w * h)
    row["tail_spp_needed"] = need
    if row.get("bias_verdict") in ("pass", "fail"):
        row.update(bias_verdict="undetermined", bias_significant=None,
                   bias_reason=(f"the variance rests on single samples of the {tails.spp}-spp tail reference; a tail "
                                f"reference of about {need} spp would decide (--preset full renders it)"))


def summarize(store, *, alpha: float = BIAS_TEST_ALPHA, tail_spp: int | None = None, cache=None, threads=None,
              log=None, escalate: bool = True, bar=None, tail_plan=None) -> list:
    """Write ``summary.json`` of a results store and return its rows, one per curve.

    ``alpha``: level of each bias test; ``tail_spp`` (default 16384), ``cache``,
    ``threads``, ``log``, ``escalate``: the tail references of our curves with 2+ seeds
    (:func:`benchmarks.tails.variance_tail_reference`); ``bar``, ``tail_plan``: the run's
    progress (:mod:`benchmarks.sweep.progress`).
    """
    tail_spp = DEFAULT_TAIL_SPP if tail_spp is None else int(tail_spp)
    store = Path(store)
    records = read_records(store)
    refs_meta = read_meta(store).get("references_by_size", {})
    curves = collections.defaultdict(list)
    for r in records:
        curves[(r["scene"], r["renderer"], r["strategy"], r["width"], r["height"])].append(r)
    ref_cache, targets, rows, filters = {}, {}, [], {}
    for (scene, renderer, strategy, w, h), recs in curves.items():
        if (scene, w, h) not in ref_cache:
            ref_cache[(scene, w, h)] = _store_reference(store, refs_meta.get(f"{scene}@{w}x{h}"))
        ref = ref_cache[(scene, w, h)]
        target = target_rmse(ref.mean) if ref is not None else None
        if target is not None:
            targets.setdefault(scene, target)
        row = {"scene": scene, "renderer": renderer, "strategy": strategy, "width": w, "height": h,
               "build": recs[-1].get("build"), "build_git": recs[-1].get("build_git")}
        top = max(int(r["spp"]) for r in recs)  # the bias verdict needs 2+ seeds kept at the top spp
        seeds_at_top = len({r["seed"] for r in recs if int(r["spp"]) == top and r.get("stats_image")})
        tails = None
        if renderer == "ours" and ref is not None and seeds_at_top >= 2:
            planned = (tail_plan or {}).get((scene, strategy, w, h))
            if bar is not None:
                if planned is None:  # a curve of an earlier run in this store: not planned yet
                    planned = render_cost(w * h, tail_spp)
                    bar.plan(planned)
                bar.current(f"tail reference {scene} {w}x{h} {strategy} ({tail_spp} spp)")
            tails = _curve_tails(scene, strategy, w, h, tail_spp=tail_spp, cache=cache, threads=threads, log=log,
                                 escalate=escalate)
            if bar is not None:
                bar.advance(planned)
        row.update(_curve_stats(recs, ref, store, alpha=alpha, target=target, tails=tails,
                                pixel_filter=_scene_filter(scene, w, h, filters)))
        if not escalate:
            _not_escalated(row, tails, w, h)
        row["reference_kind"] = (None if ref is None else CLOSED_FORM if ref.source == CLOSED_FORM
                                 else f"Mitsuba {ref.spp} spp")
        # the reference is Mitsuba's own estimator only for its `path` curve (or, under
        # `direct`, the curve with the scene's own counts)
        if (renderer == "mitsuba" and strategy in (MITSUBA_STRATEGY, "direct_mis") and ref is not None
                and ref.source != CLOSED_FORM and tail_spp):
            mitsuba_cost(row, ref)
        rows.append(row)
    _add_mitsuba_ratios(rows)
    add_noise_ratios(rows)
    add_metric_ratios(rows)
    order = {s: i for i, s in enumerate(STRATEGIES)}
    rows.sort(key=lambda r: (r["scene"], r["width"], r["height"], r["renderer"] != "ours",
                             order.get(r["strategy"], 9)))
    notes = {k: v.format(alpha=alpha, target=TARGET_RELATIVE_RMSE) for k, v in _NOTES.items()}
    write_json(store / SUMMARY, {"rows": rows, "headline": headline_rows(rows), "alpha": alpha,
                                 "target_relative_rmse": TARGET_RELATIVE_RMSE, "notes": notes})
    if targets:
        update_meta(store, target_rmse=targets)
    return rows
