"""A curve's bias at its top budget: the unweighted ``bias2`` estimate over seeds, its relative
bias with a 95% interval, and the regression gate's verdict on the seeds' mean.
"""
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

__all__ = ["bias_stats", "bias_verdict"]


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


def bias_verdict(imgs, vars_, spp, ref_mean, ref_var, ref_spp, *, alpha, tails=None, pixel_filter=None):
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
    n = k * spp
    if k < 2 or n < 2:
        # One render's own sample variance is no basis for a verdict where the samples
        # are heavy-tailed: uniform sampling at 50 spp (the 400x400 seed comparison) has
        # tiles whose rare paths did not occur, and was flagged at z = 18 while its slope
        # was -0.50. Independent seeds are required.
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
    # Tile and image levels only (Bonferroni over the two): a biased *estimator* shows in
    # pooled statistics, while single-pixel tests are unreliable where a pixel's samples
    # are dominated by rare events (uniform sampling of a small light: a few seeds carry
    # all of its variance even at thousands of samples).
    p = float(min(1.0, 2.0 * min(res.level_p["tile"], res.level_p["image"])))
    levels = [lv for lv in ("tile", "image") if 2.0 * res.level_p[lv] < alpha]
    return {"bias_significant": p < alpha, "bias_p": p, "bias_z": _z_of(p), "bias_levels": levels,
            "bias_verdict": "fail" if p < alpha else "pass", "bias_reason": "without tail diagnostics"}


def _z_of(p: float) -> float:
    """The normal quantile of a two-sided p-value, capped at 40."""
    return float(min(stats.norm.isf(p / 2.0), 40.0)) if p > 0 else 40.0


def _per_sample_variance(imgs, vars_, spp):
    """The seeds' per-sample variance: their own where recorded (ours: ``rt.render``'s
    E[x^2] - E[x]^2 over each seed's ``spp`` samples, de-biased), else the between-seed
    variance times ``spp`` (Mitsuba's sweep renders carry no variance image); None from one
    seed without its own."""
    if spp > 1 and all(v is not None for v in vars_):
        return np.mean(np.stack(vars_), axis=0) * (spp / (spp - 1.0))
    if len(imgs) >= 2:
        return np.var(np.stack(imgs), axis=0, ddof=1) * spp
    return None


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


def bias_stats(top_recs, top, ref: ImageEstimate | None, store, *, alpha, tails=None, pixel_filter=None) -> dict:
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
        row.update(bias_verdict(imgs, vars_, top, ref.mean, ref.variance, ref.spp, alpha=alpha, tails=tails,
                                pixel_filter=pixel_filter))
    return row


def _relative_bias_ci(imgs, vars_, spp, ref, tails):
    """95% interval of the relative bias ``sum(mean - ref) / sum(ref)`` at the top budget: the
    variance of the summed difference is the seeds' mean's (per-sample variance, floored by
    the tail reference's where there is one, over K spp samples) plus the reference's own."""
    k = len(imgs)
    mean = np.mean(np.stack(imgs), axis=0)
    per_sample = _per_sample_variance(imgs, vars_, spp)
    if per_sample is None:
        return None
    if tails is not None:
        per_sample = np.maximum(per_sample, tail_variance_image(tails))
    total = float(np.sum(ref.mean))
    if not total > 0:
        return None
    var_sum = float(np.sum(per_sample) / (k * spp) + np.sum(ref.variance) / max(int(ref.spp), 1))
    centre, half = float(np.sum(mean - ref.mean)) / total, 1.959963984540054 * math.sqrt(var_sum) / total
    return [centre - half, centre + half]
