"""A curve's bias at its top budget: the unweighted ``bias2`` estimate over seeds, its relative
bias with a 95% interval, and the regression gate's verdict on the seeds' mean
(``benchmarks/STATISTICS.md``)."""
from __future__ import annotations

import math

import numpy as np
from scipy import stats

from reference_tracer.estimate import ImageEstimate

from .. import metrics as M
from ..gate import compare
from ..gate.filtered import filter_weights
from ..store import read_image
from .by_metric import tail_variance_image
from .headline import Z95


def _filtered_inputs(pixel_filter, mean, per_sample, tails) -> dict:
    """``compare``'s keywords for a tent or Gaussian filter (none for a box): the samples'
    moments from the tail reference, else the pixels' variance over the filter's reduction."""
    if pixel_filter is None or pixel_filter.is_box:
        return {}
    fw = filter_weights(pixel_filter)
    if tails is not None:
        samples = (np.asarray(tails.mean, dtype=np.float64), np.asarray(tails.moments.m2, dtype=np.float64))
    else:
        samples = (mean, per_sample / fw.variance_ratio)
    return {"pixel_samples": samples, "filter_weights": fw}


def bias_verdict(imgs, vars_, spp, ref_mean, ref_var, ref_spp, *, alpha, tails=None, pixel_filter=None):
    """Is the curve's expectation different from the reference's? The gate's test of the
    seeds' mean (``K * spp`` samples) at false-alarm rate ``alpha``.

    With ``tails`` (the tail reference of the same estimator) it is the gate's three-valued
    test ('pass', 'fail', 'undetermined' with ``bias_reason`` and ``bias_spp_needed``);
    without, the tile and image levels only (Bonferroni over the two). ``bias_z``: the
    normal quantile of the p-value, capped at 40. Fewer than two seeds: no verdict (one
    render's own variance misses heavy tails).
    """
    n = len(imgs) * spp
    if len(imgs) < 2 or n < 2:
        return {"bias_significant": None, "bias_p": None, "bias_z": None}
    mean = np.mean(np.stack(imgs), axis=0)
    per_sample = _per_sample_variance(imgs, vars_, spp)
    res = compare(mean, per_sample, n, ref_mean, ref_var, max(int(ref_spp), 2), alpha=alpha, var_ddof=1,
                  tails=None if tails is None else tails.moments,
                  **_filtered_inputs(pixel_filter, mean, per_sample, tails))
    if tails is not None:
        return {"bias_significant": {"fail": True, "pass": False}.get(res.verdict), "bias_p": res.p_value,
                "bias_z": _z_of(res.p_value), "bias_levels": res.failed_levels, "bias_verdict": res.verdict,
                "bias_reason": res.reason, "bias_spp_needed": res.spp_needed,
                "bias_min_detectable": res.min_detectable_bias}
    # pooled levels only: single pixels of a heavy-tailed estimator read rare paths not yet met as bias
    p = float(min(1.0, 2.0 * min(res.level_p["tile"], res.level_p["image"])))
    levels = [lv for lv in ("tile", "image") if 2.0 * res.level_p[lv] < alpha]
    return {"bias_significant": p < alpha, "bias_p": p, "bias_z": _z_of(p), "bias_levels": levels,
            "bias_verdict": "fail" if p < alpha else "pass", "bias_reason": "without tail diagnostics"}


def _z_of(p: float) -> float:
    return float(min(stats.norm.isf(p / 2.0), 40.0)) if p > 0 else 40.0


def _per_sample_variance(imgs, vars_, spp):
    """The seeds' own per-sample variance where recorded (de-biased), else the between-seed
    variance times ``spp``; None from one seed without its own."""
    if spp > 1 and all(v is not None for v in vars_):
        return np.mean(np.stack(vars_), axis=0) * (spp / (spp - 1.0))
    if len(imgs) >= 2:
        return np.var(np.stack(imgs), axis=0, ddof=1) * spp
    return None


def _read_stats_images(store, recs) -> tuple:
    """``(means, variances or None)`` of the records' kept images by seed; ``([], [])`` if one is unreadable."""
    imgs, vars_ = [], []
    for r in sorted(recs, key=lambda r: r["seed"]):
        try:
            imgs.append(read_image(store, r["stats_image"]))
            vars_.append(read_image(store, r["stats_variance_image"]) if r.get("stats_variance_image") else None)
        except Exception:  # noqa: BLE001 - a missing/corrupt image: no bias figure for this curve
            return [], []
    return imgs, vars_


def bias_stats(top_recs, top, ref: ImageEstimate | None, store, *, alpha, tails=None, pixel_filter=None) -> dict:
    """Bias and variance over the seeds at the highest spp ``top`` (the records that kept their
    images); from one seed, its own per-sample variance (``bias_method`` 'samples')."""
    row = dict(bias2=None, bias2_stderr=None, bias_z=None, bias_p=None, bias_significant=None, bias_levels=None,
               bias_spp=None, bias_seeds=None, relative_bias=None, variance=None, bias_method=None)
    kept = [r for r in top_recs if r.get("stats_image")]
    if ref is None or not kept:
        return row
    imgs, vars_ = _read_stats_images(store, kept)
    if len(imgs) >= 2:
        bv, method = M.bias_variance(np.stack(imgs), ref.mean, ref.variance, ref.spp, spp=top, alpha=alpha), "seeds"
    elif len(imgs) == 1 and vars_[0] is not None and top > 1:
        bv = M.bias_variance(np.stack(imgs), ref.mean, ref.variance, ref.spp, var_k=np.stack(vars_), spp=top,
                             alpha=alpha, variance_source="samples", var_ddof=1)
        method = "samples"
    else:
        return row
    row.update(bias2=bv.bias2, bias2_stderr=bv.bias2_se, bias_spp=top, bias_seeds=bv.k,
               relative_bias=bv.relative_bias, variance=bv.sample_variance, bias_method=method,
               relative_bias_ci=_relative_bias_ci(imgs, vars_, top, ref, tails))
    row.update(bias_verdict(imgs, vars_, top, ref.mean, ref.variance, ref.spp, alpha=alpha, tails=tails,
                            pixel_filter=pixel_filter))
    return row


def _relative_bias_ci(imgs, vars_, spp, ref, tails):
    """95% interval of ``sum(mean - ref) / sum(ref)``: the seeds' mean's variance (floored by
    the tail reference's) plus the reference's own."""
    per_sample = _per_sample_variance(imgs, vars_, spp)
    total = float(np.sum(ref.mean))
    if per_sample is None or not total > 0:
        return None
    if tails is not None:
        per_sample = np.maximum(per_sample, tail_variance_image(tails))
    var_sum = float(np.sum(per_sample) / (len(imgs) * spp) + np.sum(ref.variance) / max(int(ref.spp), 1))
    centre = float(np.sum(np.mean(np.stack(imgs), axis=0) - ref.mean)) / total
    half = Z95 * math.sqrt(var_sum) / total
    return [centre - half, centre + half]
