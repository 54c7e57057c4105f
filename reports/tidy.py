"""Tidy CSVs of a results store: every curve point, and the summary under every metric.

One observation per line, one variable per column, so a paper's plots can be redrawn
with any tool: ``curves.csv`` has a line per (scene, size, renderer, strategy, spp,
metric) with the median, minimum and maximum over seeds and the number of seeds;
``summary.csv`` a line per (scene, size, renderer, strategy, metric) with the slope, the
bias verdict and, where no bias was detected, efficiency and time to target (empty
otherwise, with ``cost_status`` saying why).
"""
from __future__ import annotations

import csv
import io
import math

from benchmarks.metrics import METRICS, view
from benchmarks.text import csv_cell

from .curves import curves
from .headline import headline_entries
from .store import Store, num

__all__ = ["CURVE_COLUMNS", "SUMMARY_COLUMNS", "HEADLINE_COLUMNS", "curves_csv", "summary_csv", "headline_csv"]

#: columns of ``curves.csv``.
CURVE_COLUMNS = ("scene", "width", "height", "renderer", "strategy", "spp", "metric", "median", "min", "max",
                 "seeds", "seconds_median")
#: the record field behind each metric of ``curves.csv`` (the values as recorded: SSIM itself, not 1 - SSIM).
CURVE_METRICS = {"rmse": "rmse", "mse_corrected": "mse_corrected", "relmse": "relmse", "ssim": "ssim",
                 "flip": "flip"}
#: columns of ``summary.csv``.
SUMMARY_COLUMNS = ("scene", "width", "height", "renderer", "strategy", "metric", "slope", "slope_ci_low",
                   "slope_ci_high", "unbiased_slope", "bias_verdict", "bias_p", "cost_status", "efficiency",
                   "efficiency_vs_mitsuba", "time_to_target", "target", "variance", "samples_per_second",
                   "samples_per_second_vs_mitsuba")


def _cell(v):
    """A CSV cell: numbers with full precision (repr), None and NaN empty, text never a
    spreadsheet formula (:func:`benchmarks.text.csv_cell`: store fields are untrusted)."""
    if v is None or isinstance(v, bool):
        return "" if v is None else str(v).lower()
    if isinstance(v, float):
        return repr(v) if math.isfinite(v) else ""
    return csv_cell(v)


def _write(header, rows) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(header)
    for r in rows:
        w.writerow([_cell(r.get(k)) for k in header])
    return buf.getvalue()


#: columns of ``headline.csv``: one line per (scene, size, curve) of the report's first table.
HEADLINE_COLUMNS = ("scene", "width", "height", "renderer", "strategy", "scene_verdict", "scene_min_detectable_bias",
                    "reference", "noise", "noise_se", "noise_lower_bound", "exact", "noise_vs_light",
                    "noise_vs_light_low", "noise_vs_light_high", "time_noise_vs_light", "time_noise_vs_light_low",
                    "time_noise_vs_light_high", "seconds_per_sample", "bias_verdict", "relative_bias",
                    "relative_bias_low", "relative_bias_high")


def headline_csv(store: Store) -> str:
    """``headline.csv``: the report's first table as numbers, one line per (scene, size, curve);
    verdicts in the page's words (pass, fail, undetermined)."""
    def ci(c, key, i):
        v = c.get(key)
        return v[i] if isinstance(v, list) and len(v) == 2 else None

    rows = []
    for e in headline_entries(store):
        for c in e.get("curves") or []:
            rows.append({"scene": e["scene"], "width": e.get("width"), "height": e.get("height"),
                         "renderer": c.get("renderer"), "strategy": c.get("strategy"),
                         "scene_verdict": e.get("verdict"), "scene_min_detectable_bias": e.get("min_detectable_bias"),
                         "reference": e.get("reference"),
                         **{k: c.get(k) for k in ("noise", "noise_se", "noise_lower_bound", "exact", "noise_vs_light",
                                                  "time_noise_vs_light", "seconds_per_sample", "bias_verdict",
                                                  "relative_bias")},
                         "noise_vs_light_low": ci(c, "noise_vs_light_ci", 0),
                         "noise_vs_light_high": ci(c, "noise_vs_light_ci", 1),
                         "time_noise_vs_light_low": ci(c, "time_noise_vs_light_ci", 0),
                         "time_noise_vs_light_high": ci(c, "time_noise_vs_light_ci", 1),
                         "relative_bias_low": ci(c, "relative_bias_ci", 0),
                         "relative_bias_high": ci(c, "relative_bias_ci", 1)})
    return _write(HEADLINE_COLUMNS, rows)


def curves_csv(store: Store) -> str:
    """``curves.csv``: every curve point of every section (median, min, max over seeds per spp).

    Returns
    -------
    str
        The CSV text, with the header :data:`CURVE_COLUMNS`.
    """
    rows = []
    for scene, w, h in store.sections():
        recs = store.section_records(scene, w, h)
        for metric, field in CURVE_METRICS.items():
            for c in curves(recs, field):
                for i, spp in enumerate(c.spp):
                    rows.append({"scene": scene, "width": w, "height": h, "renderer": c.renderer,
                                 "strategy": c.strategy, "spp": int(spp), "metric": metric,
                                 "median": float(c.median[i]), "min": float(c.lo[i]), "max": float(c.hi[i]),
                                 "seeds": int(c.nseeds[i]), "seconds_median": float(c.seconds[i])})
    return _write(CURVE_COLUMNS, rows)


def summary_csv(store: Store) -> str:
    """``summary.csv``: the summary rows under every metric (RMSE, relMSE, SSIM as 1 - SSIM, FLIP).

    Efficiency, its ratio to Mitsuba and time to target are empty where the bias test found a
    bias or could not decide (``cost_status``: 'biased' or 'undetermined').
    """
    rows = []
    for scene, w, h in store.sections():
        for r in store.section_rows(scene, w, h):
            for metric in METRICS:
                v = view(r, metric)
                ci = v.get("slope_ci") if isinstance(v.get("slope_ci"), (list, tuple)) else (None, None)
                out = {k: v.get(k) for k in SUMMARY_COLUMNS}
                out.update(scene=scene, width=w, height=h, slope_ci_low=num(ci[0]) if ci[0] is not None else None,
                           slope_ci_high=num(ci[1]) if ci[1] is not None else None)
                if v.get("cost_status"):
                    out.update(efficiency=None, efficiency_vs_mitsuba=None, time_to_target=None)
                rows.append(out)
    return _write(SUMMARY_COLUMNS, rows)
