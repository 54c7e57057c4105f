"""The per-curve summary of a results store (``summary.json``): slope, bias, variance, cost.

A curve is one (scene, renderer, strategy, width, height). Its figures come from the
store's records and images alone, so :func:`summarize` can be rerun at any time and
gives the same rows.
"""
from __future__ import annotations

import collections
import math
from pathlib import Path

import numpy as np
from scipy import stats

from reference_tracer.estimate import ImageEstimate

from .. import metrics as M
from .. import tails as T
from ..constants import BIAS_TEST_ALPHA, CLOSED_FORM, MIN_SLOPE_BUDGETS, MITSUBA_STRATEGY, RELMSE_EPS, STRATEGIES
from ..gate import compare
from ..gate.filtered import filter_weights
from ..scenes import scene_at
from ..store import META, SUMMARY, read_image, read_json, read_records, update_meta, write_json
from ..tails import DEFAULT_MAX_TAIL_SAMPLES, DEFAULT_TAIL_SPP
from .by_metric import add_metric_ratios, curve_metrics, tail_variance_image
from .coerce import as_float
from .headline import add_noise_ratios, headline_rows, relative_noise_of
from .jobs import mitsuba_pairs
from .progress import render_cost

#: batches of a Mitsuba reference whose store entry does not say (``benchmarks.references``).
DEFAULT_BATCHES = 16

__all__ = ["TARGET_RELATIVE_RMSE", "target_rmse", "summarize"]

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


def target_rmse(ref_mean, *, relative: float = TARGET_RELATIVE_RMSE) -> float:
    """Target RMSE of a scene: ``relative`` x the RMS of the reference's radiance.

    Examples
    --------
    >>> target_rmse(np.full((4, 4, 3), 2.0), relative=0.1)
    0.2
    """
    r = np.asarray(ref_mean, dtype=np.float64)
    return float(relative * math.sqrt(float(np.mean(r * r))))


def _nanmean(vals):
    a = np.asarray([as_float(v) for v in vals], dtype=np.float64)
    a = a[np.isfinite(a)]
    return float(a.mean()) if a.size else math.nan


def _filtered_inputs(pixel_filter, mean, per_sample, tails) -> dict:
    """``compare``'s keywords for a scene with a tent or Gaussian filter (none for a box): the
    per-sample moments of the samples are the tail reference's (its box twin's, 16384 spp);
    without one, the filtered pixels' own variance over the filter's variance reduction (the
    noise taken as locally even)."""
    if pixel_filter is None or pixel_filter.is_box:
        return {}

    fw = filter_weights(pixel_filter)
    if tails is not None:
        samples = (np.asarray(tails.mean, dtype=np.float64), np.asarray(tails.moments.m2, dtype=np.float64))
    else:
        samples = (mean, per_sample / fw.variance_ratio)
    return {"pixel_samples": samples, "filter_weights": fw}


def _bias_verdict(imgs, vars_, spp, ref_mean, ref_var, ref_spp, *, alpha, tails=None, pixel_filter=None):
    """Is the curve's expectation different from the reference's? The regression gate's test.

    The mean over K seeds is the mean of K * spp samples; its per-sample variance is the
    seeds' own per-sample variance where recorded (ours), else the between-seed variance
    times spp (Mitsuba's sweep renders carry no variance image). ``benchmarks.gate.compare``
    then tests with a false-alarm rate <= ``alpha``: a precision-weighted test, so a few
    very noisy pixels (light edges) cannot hide a bias elsewhere, as they can in the
    unweighted ``bias2`` estimate beside it. ``bias_z`` is the normal quantile of the
    gate's p-value (capped at 40).

    With ``tails`` (the tail reference of the same estimator, :mod:`benchmarks.tails`) the
    test is the gate's three-valued one on every level: ``bias_verdict`` is 'pass', 'fail'
    or 'undetermined' (heavy-tailed at this budget; ``bias_reason`` and
    ``bias_spp_needed`` say why and what would decide) and ``bias_significant`` is True,
    False or None accordingly. Without it only the tile and image levels are used (the
    older rule, which reads rare paths not yet sampled as bias).
    """
    k = len(imgs)
    if k < 2:
        # One render's own sample variance is no basis for a verdict where the samples
        # are heavy-tailed: uniform sampling at 50 spp (the 400x400 seed comparison) has
        # tiles whose rare paths did not occur, and was flagged at z = 18 while its slope
        # was -0.50. Independent seeds are required.
        return {"bias_significant": None, "bias_p": None, "bias_z": None}
    mean = np.mean(np.stack(imgs), axis=0)
    if spp > 1 and all(v is not None for v in vars_):
        # rt.render's per-sample variance is E[x^2] - E[x]^2 over each seed's spp samples
        per_sample = np.mean(np.stack(vars_), axis=0) * (spp / (spp - 1.0))
    else:
        per_sample = np.var(np.stack(imgs), axis=0, ddof=1) * spp
    n = k * spp
    if n < 2:
        return {"bias_significant": None, "bias_p": None, "bias_z": None}
    filtered = _filtered_inputs(pixel_filter, mean, per_sample, tails)
    if tails is not None:
        res = compare(mean, per_sample, n, ref_mean, ref_var, max(int(ref_spp), 2), alpha=alpha, var_ddof=1,
                      tails=tails.moments, **filtered)
        p = res.p_value
        z = float(min(stats.norm.isf(p / 2.0), 40.0)) if p > 0 else 40.0
        return {"bias_significant": {"fail": True, "pass": False}.get(res.verdict), "bias_p": p, "bias_z": z,
                "bias_levels": res.failed_levels, "bias_verdict": res.verdict, "bias_reason": res.reason,
                "bias_spp_needed": res.spp_needed, "bias_min_detectable": res.min_detectable_bias}
    res = compare(mean, per_sample, n, ref_mean, ref_var, max(int(ref_spp), 2), alpha=alpha, var_ddof=1,
                  **filtered)
    # Tile and image levels only (Bonferroni over the two): a biased *estimator* shows in
    # pooled statistics, while single-pixel tests are unreliable where a pixel's samples
    # are dominated by rare events (uniform sampling of a small light: a few seeds carry
    # all of its variance even at thousands of samples).
    p = float(min(1.0, 2.0 * min(res.level_p["tile"], res.level_p["image"])))
    z = float(min(stats.norm.isf(p / 2.0), 40.0)) if p > 0 else 40.0
    levels = [lv for lv in ("tile", "image") if 2.0 * res.level_p[lv] < alpha]
    return {"bias_significant": p < alpha, "bias_p": p, "bias_z": z, "bias_levels": levels,
            "bias_verdict": "fail" if p < alpha else "pass", "bias_reason": "without tail diagnostics"}


def _slope_status(row: dict):
    """Why the fitted slope says nothing yet, or None.

    Where the gate cannot decide even at the curve's top budget (its image mean is too far
    from normal: ``bias_verdict`` 'undetermined'), the renders have mostly not met the rare
    paths that carry the estimator's variance, so their measured MSE sits far below its
    expectation, by a factor that shrinks as spp grows: the fitted slope is then shallower
    than the estimator's (``uniform`` on ``glossy_plates``), and its regression interval
    does not cover that. The slope is kept in the row (it is what was measured) and marked.
    """
    if row.get("bias_verdict") != "undetermined":
        kept = len(row.get("spps") or []) - len(row.get("slope_excluded_spps") or [])
        if row.get("slope_excluded_spps") and kept < MIN_SLOPE_BUDGETS:
            return (f"undetermined: heavy-tailed below {row['slope_fit_from']} spp (the measured MSE misses "
                    f"rare paths there), and {kept} rendered budget(s) at or above it, fewer than "
                    f"{MIN_SLOPE_BUDGETS}")
        if row.get("slope") is None:
            return f"no slope: fewer than {MIN_SLOPE_BUDGETS} rendered budgets"
        return None
    need = row.get("bias_spp_needed")
    return ("undetermined: heavy-tailed at these budgets (the measured MSE misses rare paths)"
            + (f"; the gate needs about {need} samples per pixel" if need else ""))


def mse_reliable_from(tails, *, seeds: int) -> int:
    """The smallest budget from which the seed-averaged MSE (and relMSE) of this estimator
    is near its expectation, from its tail reference (``benchmarks/STATISTICS.md``).

    One render's MSE at ``n`` spp over ``P`` pixels, ``(1/P) sum_p (xbar_p - mu_p)^2``, has
    expectation ``sum_p s2_p / (P n)`` and, from the samples' fourth cumulants ``k4_p``, a
    variance of at least ``sum_p k4_p / (P^2 n^3)``: relative to the squared expectation,
    ``K = sum_p k4_p / (sum_p s2_p)^2`` over ``n``, and over ``n k`` for the mean of ``k``
    seeds. Where that exceeds 1 the MSE rests on rare paths: most renders missed them and
    read low, a few met them and read high. The budget is ``ceil(K / k)``, with ``K`` the
    largest over the channels and over the weights of MSE (1) and relMSE
    (``1 / (mu^2 + eps)``).

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> m = SimpleNamespace(m2=np.ones((4, 4, 3)), kappa4=np.full((4, 4, 3), 160.0))
    >>> mse_reliable_from(SimpleNamespace(moments=m, mean=np.ones((4, 4, 3))), seeds=2)
    5
    """
    m2 = np.asarray(tails.moments.m2, dtype=np.float64)
    k4 = np.asarray(tails.moments.kappa4, dtype=np.float64)
    mu = np.asarray(tails.mean, dtype=np.float64)
    worst = 0.0
    for w in (np.ones_like(mu), 1.0 / (mu * mu + RELMSE_EPS)):
        num, den = (w * w * k4).sum(axis=(0, 1)), (w * m2).sum(axis=(0, 1)) ** 2
        with np.errstate(divide="ignore", invalid="ignore"):
            k = np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0)
        worst = max(worst, float(np.max(k)))
    return max(1, int(math.ceil(worst / max(int(seeds), 1))))


def _reliable_points_only(spps, mse_c, mse_p, row: dict) -> dict:
    """The slope refitted without the budgets below ``slope_fit_from`` (the per-point rule).

    Below it, renders have mostly not met the rare paths that carry the variance, their MSE
    sits below expectation and would flatten the fit. Where the gate is undetermined at the
    top budget :func:`_slope_status` marks the whole slope instead.
    """
    start = row.get("slope_fit_from")
    if not start or row.get("bias_verdict") == "undetermined":
        return {"slope_excluded_spps": []}
    keep = [i for i, s in enumerate(spps) if s >= start]
    excluded = [int(s) for s in spps if s < start]
    if not excluded:
        return {"slope_excluded_spps": []}
    out = _slope_stats([spps[i] for i in keep], mse_c[keep], mse_p[keep])
    if out["slope"] is None:  # too few budgets left: no slope (_slope_status says why)
        return {"slope_excluded_spps": excluded, "slope": None, "slope_ci": None, "slope_stderr": None,
                "slope_range": None}
    return dict(out, slope_excluded_spps=excluded)


def _slope_stats(spps, mse_c, mse_p) -> dict:
    """Convergence: one point per spp, RMSE from the seed-averaged reference-noise-corrected MSE;
    no slope from fewer than :data:`MIN_SLOPE_BUDGETS` budgets (``slope_range``: the first and
    last budget fitted)."""
    ok = np.isfinite(mse_c) & (mse_c > 0)
    row = dict(slope=None, slope_ci=None, slope_stderr=None, slope_points=int(ok.sum()), slope_range=None)
    if len(set(np.asarray(spps)[ok])) >= MIN_SLOPE_BUDGETS:
        fit = M.convergence_slope(np.asarray(spps)[ok], np.sqrt(mse_c[ok]))
        row.update(slope=fit.slope, slope_stderr=fit.stderr,
                   slope_ci=[fit.ci_low, fit.ci_high] if math.isfinite(fit.ci_low) else None,
                   slope_range=[int(np.asarray(spps)[ok][0]), int(np.asarray(spps)[ok][-1])])
    okp = np.isfinite(mse_p) & (mse_p > 0)
    row["slope_uncorrected"] = None
    if len(set(np.asarray(spps)[okp])) >= MIN_SLOPE_BUDGETS:
        row["slope_uncorrected"] = M.convergence_slope(np.asarray(spps)[okp], np.sqrt(mse_p[okp])).slope
    return row


def _read_stats_images(store, recs) -> tuple:
    """``(means, variances or None)`` of the records' kept images, by seed; ``([], [])`` if one is unreadable."""
    imgs, vars_ = [], []
    for r in sorted(recs, key=lambda r: r["seed"]):
        try:
            imgs.append(read_image(store, r["stats_image"]))
            vars_.append(read_image(store, r["stats_variance_image"]) if r.get("stats_variance_image") else None)
        except Exception:  # noqa: BLE001 - a missing/corrupt image: no bias figure for this curve
            return [], []
    return imgs, vars_


def _scene_filter(scene: str, w: int, h: int, cache: dict):
    """The pixel filter of a store's scene (None where the scene is no longer known here)."""
    if scene not in cache:
        try:
            cache[scene] = scene_at(scene, w, h).camera.filter
        except (ValueError, KeyError):
            cache[scene] = None
    return cache[scene]


def _bias_stats(top_recs, top, ref: ImageEstimate | None, store, *, alpha, tails=None, pixel_filter=None) -> dict:
    """Bias and variance over seeds at the highest spp ``top`` (the records that kept their images)."""
    row = dict(bias2=None, bias2_stderr=None, bias_z=None, bias_p=None, bias_significant=None, bias_levels=None,
               bias_spp=None, bias_seeds=None, relative_bias=None, variance=None, bias_method=None)
    kept = [r for r in top_recs if r.get("stats_image")]
    if ref is None or not kept:
        return row
    imgs, vars_ = _read_stats_images(store, kept)
    bv, method = None, None
    if len(imgs) >= 2:
        bv = M.bias_variance(np.stack(imgs), ref.mean, ref.variance, ref.spp, spp=top, alpha=alpha)
        method = "seeds"
    elif len(imgs) == 1 and vars_[0] is not None and top > 1:
        # one seed: the renderer's own per-sample variance, E[x^2] - E[x]^2 (de-biased by n/(n-1))
        bv = M.bias_variance(np.stack(imgs), ref.mean, ref.variance, ref.spp, var_k=np.stack(vars_), spp=top,
                             alpha=alpha, variance_source="samples", var_ddof=1)
        method = "samples"
    if bv is not None:
        row.update(bias2=bv.bias2, bias2_stderr=bv.bias2_se, bias_spp=top, bias_seeds=bv.k,
                   relative_bias=bv.relative_bias, variance=bv.sample_variance, bias_method=method,
                   relative_bias_ci=_relative_bias_ci(imgs, vars_, top, ref, tails))
        row.update(_bias_verdict(imgs, vars_, top, ref.mean, ref.variance, ref.spp, alpha=alpha, tails=tails,
                                 pixel_filter=pixel_filter))
    return row


def _relative_bias_ci(imgs, vars_, spp, ref, tails):
    """95% interval of the relative bias ``sum(mean - ref) / sum(ref)`` at the top budget: the
    variance of the summed difference is the seeds' mean's (per-sample variance, floored by
    the tail reference's where there is one, over K spp samples) plus the reference's own."""
    k = len(imgs)
    mean = np.mean(np.stack(imgs), axis=0)
    if spp > 1 and all(v is not None for v in vars_):
        per_sample = np.mean(np.stack(vars_), axis=0) * (spp / (spp - 1.0))
    elif k >= 2:
        per_sample = np.var(np.stack(imgs), axis=0, ddof=1) * spp
    else:
        return None
    if tails is not None:
        per_sample = np.maximum(per_sample, tail_variance_image(tails))
    total = float(np.sum(ref.mean))
    if not total > 0:
        return None
    var_sum = float(np.sum(per_sample) / (k * spp) + np.sum(ref.variance) / max(int(ref.spp), 1))
    centre, half = float(np.sum(mean - ref.mean)) / total, 1.959963984540054 * math.sqrt(var_sum) / total
    return [centre - half, centre + half]


def _exact(tails) -> bool:
    """Whether an estimator has no noise beyond float rounding in any pixel (relative spread < 1e-6)."""
    return not np.any(T.sample_variance(tails) > 0)


def _tail_variance(tails) -> dict:
    """The estimator's per-sample variance (mean over pixels) from its tail reference, and
    whether it is only a lower bound: where one sample carries more than half of a pixel's
    sum of squared deviations, the rarer paths that set the true variance were not seen."""
    return {"variance": float(T.sample_variance(tails).mean()), "variance_source": f"tail reference, {tails.spp} spp",
            "variance_lower_bound": T.variance_is_lower_bound(tails)}


def _tail_noise(tails, ref) -> dict:
    """The curve's noise figures for the headline (:mod:`benchmarks.sweep.headline`): its
    per-sample relative variance from the tail reference, and the tail render's seconds per sample."""
    out = {"noise": None, "noise_se": None, "noise_lower_bound": T.variance_is_lower_bound(tails),
           "noise_source": f"tail reference, {tails.spp} spp", "exact": _exact(tails),
           "seconds_per_sample": None}
    if ref is not None:
        out.update(relative_noise_of(tail_variance_image(tails), ref.mean, n=tails.spp, m4=tails.moments.m4))
    if out["exact"]:
        out.update(noise=0.0, noise_se=0.0)
    pixels = int(np.prod(np.shape(tails.mean)[:2]))
    if tails.seconds > 0:
        out["seconds_per_sample"] = float(tails.seconds) / (tails.spp * pixels)
    return out


def _curve_stats(recs, ref: ImageEstimate | None, store, *, alpha, target, tails=None,
                 seconds_per_sample: float | None = None, pixel_filter=None) -> dict:
    """Summary figures of one (scene, renderer, strategy, width, height) curve.

    With ``seconds_per_sample`` (from a seconds-long render of the same estimator: our tail
    reference, Mitsuba's reference) a budget of ``n`` spp costs ``n`` x pixels x that time:
    the renders of a small image take milliseconds, mostly per-render overhead, and would
    make equal-time figures measure the overhead (``timing_source`` says which was used).
    """
    by_spp = collections.defaultdict(list)
    for r in recs:
        by_spp[int(r["spp"])].append(r)
    spps = sorted(by_spp)
    mse_c = np.array([_nanmean(r.get("mse_corrected") for r in by_spp[s]) for s in spps])
    mse_p = np.array([_nanmean(r.get("mse") for r in by_spp[s]) for s in spps])
    secs = np.array([_nanmean(r.get("seconds") for r in by_spp[s]) for s in spps])
    row = {"spps": spps, "seeds": max(len(by_spp[s]) for s in spps), "timing_source": "each render's wall time"}
    pixels = int(recs[0]["width"]) * int(recs[0]["height"]) if recs else 0
    if seconds_per_sample and pixels:
        secs = np.asarray(spps, dtype=np.float64) * pixels * seconds_per_sample
        row["timing_source"] = "spp x pixels x seconds per sample of a high-budget render of the estimator"
    row.update(_slope_stats(spps, mse_c, mse_p))
    top = spps[-1]
    row.update(_bias_stats(by_spp[top], top, ref, store, alpha=alpha, tails=tails, pixel_filter=pixel_filter))
    row["slope_fit_from"] = mse_reliable_from(tails, seeds=row["seeds"]) if tails is not None else None
    row.update(_reliable_points_only(spps, mse_c, mse_p, row))
    lo_hi = row.get("slope_ci") or ([row["slope"]] * 2 if row.get("slope") is not None else None)
    row["slope_steep"] = bool(lo_hi is not None and lo_hi[1] < -0.5)  # RMSE's Monte Carlo slope
    row["slope_status"] = _slope_status(row)
    if row["variance"] is None:
        row["variance"] = _nanmean(r.get("variance") for r in recs)
    row["variance_source"], row["variance_lower_bound"] = "renders at the top spp", None
    if tails is not None:
        row.update(_tail_variance(tails))
        row.update(_tail_noise(tails, ref))

    # cost: efficiency at the top spp, throughput, time to the target RMSE. An unbiased
    # estimator's expected MSE at n spp is its per-sample variance / n; from the tail
    # reference's variance it counts the rare paths a few renders at the top spp missed.
    row["efficiency"] = None
    unbiased = row.get("bias_verdict") in ("pass", "undetermined")
    if tails is not None and _exact(tails):
        # every sample equals the pixel value (mis in the furnace): no error to trade for time
        row.update(variance=0.0, variance_lower_bound=False, efficiency_source="exact (zero variance)")
    elif tails is not None and unbiased and row["variance"] > 0 and secs[-1] > 0:
        row["efficiency"] = M.efficiency(row["variance"] / top, secs[-1])
        row["efficiency_source"] = "tail-reference variance / spp"
    elif math.isfinite(mse_c[-1]) and mse_c[-1] > 0 and secs[-1] > 0:
        row["efficiency"] = M.efficiency(mse_c[-1], secs[-1])
        row["efficiency_source"] = "measured MSE"
    row["samples_per_second"] = (1.0 / seconds_per_sample if seconds_per_sample else
                                 _nanmean(r.get("paths_per_second") for r in by_spp[top]))
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
        ref = ImageEstimate(mean=read_image(store, info["path"], sha256=info.get("sha256")).astype(np.float64),
                            variance=read_image(store, info["variance_path"],
                                                sha256=info.get("variance_sha256")).astype(np.float64),
                            spp=int(info["spp"]), seconds=as_float(info.get("render_seconds")),
                            source=str(info.get("variant", "")))
        ref.batches = int(info.get("batches") or DEFAULT_BATCHES)
        return ref
    except Exception:  # noqa: BLE001 - missing or corrupt (checksum) reference: figures that need it stay null
        return None


def _ratio(a, b):
    a, b = as_float(a), as_float(b)
    if not (math.isfinite(a) and math.isfinite(b)) or b == 0:
        return None
    return a / b


def _mitsuba_cost(row: dict, ref: ImageEstimate) -> None:
    """Mitsuba's variance and efficiency from its own high-spp reference (the same estimator,
    ``path``), as ours come from our tail references: expected MSE = variance / spp."""
    var = float(np.mean(ref.variance, dtype=np.float64)) * ref.spp / max(ref.spp - 1.0, 1.0)
    row.update(variance=var, variance_source=f"Mitsuba reference, {ref.spp} spp", variance_lower_bound=None)
    row.update(relative_noise_of(np.asarray(ref.variance, dtype=np.float64) * ref.spp / max(ref.spp - 1.0, 1.0),
                                 ref.mean, batches=getattr(ref, "batches", None) or DEFAULT_BATCHES),
               noise_lower_bound=None, noise_source=f"Mitsuba reference, {ref.spp} spp", exact=False,
               seconds_per_sample=None)
    ref_seconds = as_float(getattr(ref, "seconds", None))
    if math.isfinite(ref_seconds) and ref_seconds > 0:
        row["seconds_per_sample"] = ref_seconds / (ref.spp * int(np.prod(np.shape(ref.mean)[:2])))
    top, secs = row["spps"][-1], as_float(row.get("seconds_at_top"))
    if var > 0 and math.isfinite(secs) and secs > 0:
        row["efficiency"] = M.efficiency(var / top, secs)
        row["efficiency_source"] = "reference variance / spp"
        # relMSE likewise from the reference's per-pixel variance (the same estimator)
        rel = row.get("by_metric", {}).get("relmse")
        if rel is not None:
            expected = float(np.mean(ref.variance * (ref.spp / max(ref.spp - 1.0, 1.0))
                                     / (ref.mean * ref.mean + RELMSE_EPS))) / top
            if expected > 0:
                rel.update(efficiency=M.efficiency(expected, secs), efficiency_source="reference variance / spp")


def _add_mitsuba_ratios(rows) -> None:
    """``*_vs_mitsuba``: each curve against Mitsuba's curve of the same scene and size."""
    for r, m in mitsuba_pairs(rows):
        r["efficiency_vs_mitsuba"] = _ratio(r.get("efficiency"), m.get("efficiency") if m else None)
        r["samples_per_second_vs_mitsuba"] = _ratio(r.get("samples_per_second"),
                                                    m.get("samples_per_second") if m else None)


def _curve_tails(scene, strategy, w, h, *, tail_spp, cache, threads, log, escalate=True):
    """The tail reference of one of our curves (cached; rendered when missing; with ``escalate``
    a larger budget where its variance rests on single samples: ``variance_tail_reference``),
    or None."""
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
    """A verdict whose tail reference's variance rests on single samples, when the larger tail
    reference that would settle it was not rendered (``escalate=False``, the quick preset):
    undetermined, never pass or fail, with the budget that would decide."""
    if tails is None or not T.variance_is_lower_bound(tails):
        return
    need = DEFAULT_MAX_TAIL_SAMPLES // (w * h)
    row["tail_spp_needed"] = need
    if row.get("bias_verdict") in ("pass", "fail"):
        row.update(bias_verdict="undetermined", bias_significant=None,
                   bias_reason=(f"the variance rests on single samples of the {tails.spp}-spp tail reference; a tail "
                                f"reference of about {need} spp would decide (--preset full renders it)"))


def summarize(store, *, alpha: float = BIAS_TEST_ALPHA, target_relative: float = TARGET_RELATIVE_RMSE,
              tail_spp: int | None = None, cache=None, threads=None, log=None, escalate: bool = True,
              bar=None, tail_plan=None) -> list:
    """Per (scene, renderer, strategy, width, height): the figures of ``summary.json``.

    From the store's records and images:

    * ``slope``, ``slope_ci`` (95%), ``slope_stderr``: least-squares fit of log RMSE over
      log spp, one point per spp, RMSE = sqrt of the seed-averaged reference-noise-
      corrected MSE (``slope_uncorrected`` uses the plain MSE); ``slope_status``: why the
      slope is not yet meaningful (heavy-tailed at every budget of the curve, or at all
      but one), else None; ``slope_excluded_spps``: with a tail reference, the budgets
      below ``slope_fit_from`` (:func:`mse_reliable_from`), where renders mostly miss the
      rare paths and the MSE reads low: left out of the fit;
    * ``bias2``, ``bias2_stderr``, ``bias_z``, ``bias_p``, ``bias_significant`` (level
      ``alpha``, one-sided), ``relative_bias``: ``metrics.bias_variance`` over the seeds at
      the highest spp (``bias_spp``); with one seed, the renderer's own per-sample
      variance is used instead (``bias_method``);
    * ``bias_verdict`` ('pass', 'fail', 'undetermined'), ``bias_reason``,
      ``bias_spp_needed``: with the tail reference of our estimator (``tail_spp`` spp,
      cached under ``cache``; our curves with 2+ seeds only), the gate's three-valued test
      of the seeds' mean (``benchmarks/STATISTICS.md``);
    * ``variance``: per-sample variance, mean over pixels: from the tail reference where
      there is one (``variance_lower_bound`` when single samples dominate it), else the
      between-seed variance of the image x spp;
    * ``efficiency``: 1 / (expected MSE x seconds) at the highest spp, the expected MSE of
      an estimator found unbiased being its tail-reference variance / spp; else
      1 / (corrected MSE x seconds) (``efficiency_source``);
    * ``time_to_target``: seconds to reach ``target_rmse`` (= ``target_relative`` x the
      reference's RMS radiance), log-log interpolated, null if not reached;
    * ``noise``, ``noise_se``, ``seconds_per_sample`` and the ``noise_vs_light`` ratios at
      equal spp and equal time (:mod:`benchmarks.sweep.headline`); ``headline``: one entry
      per scene and size, the first table of the report;
    * ``build``, ``build_git``: the build whose records make the curve (its latest one);
    * ``samples_per_second`` (pixel samples per second at the highest spp) and the
      ``*_vs_mitsuba`` ratios against Mitsuba's ``path`` curve of the same scene and size.

    Writes ``summary.json`` and returns its rows.
    """
    tail_spp = DEFAULT_TAIL_SPP if tail_spp is None else int(tail_spp)
    store = Path(store)
    records = read_records(store)
    meta = read_json(store / META, default={}) or {}
    refs_meta = meta.get("references_by_size") if isinstance(meta.get("references_by_size"), dict) else {}
    curves = collections.defaultdict(list)
    for r in records:
        curves[(r["scene"], r["renderer"], r["strategy"], r["width"], r["height"])].append(r)
    ref_cache, targets, rows, filters = {}, {}, [], {}
    for (scene, renderer, strategy, w, h), recs in curves.items():
        if (scene, w, h) not in ref_cache:
            ref_cache[(scene, w, h)] = _store_reference(store, refs_meta.get(f"{scene}@{w}x{h}"))
        ref = ref_cache[(scene, w, h)]
        target = target_rmse(ref.mean, relative=target_relative) if ref is not None else None
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
            _mitsuba_cost(row, ref)
        rows.append(row)
    _add_mitsuba_ratios(rows)
    add_noise_ratios(rows)
    add_metric_ratios(rows)
    order = {s: i for i, s in enumerate(STRATEGIES)}
    rows.sort(key=lambda r: (r["scene"], r["width"], r["height"], r["renderer"] != "ours",
                             order.get(r["strategy"], 9)))
    notes = {k: v.format(alpha=alpha, target=target_relative) for k, v in _NOTES.items()}
    write_json(store / SUMMARY, {"rows": rows, "headline": headline_rows(rows), "alpha": alpha,
                                 "target_relative_rmse": target_relative, "notes": notes})
    if targets:
        update_meta(store, target_rmse=targets)
    return rows
