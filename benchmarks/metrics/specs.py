"""The error metrics a summary reports (:data:`SPECS`, ``--metric``), and a summary row read under one.

:func:`view` reads a ``summary.json`` row under one metric (the sweep writes every metric's figures
in the row's ``by_metric``); :func:`cost_status` says where a row's efficiency must not be shown.

Examples
--------
>>> SPECS["relmse"].label, DEFAULT_METRIC in METRICS
('relMSE', True)
"""
from __future__ import annotations

from dataclasses import dataclass

from ..constants import RELMSE_EPS
from .flip import FLIP_PACKAGE, flip_available

__all__ = ["MetricSpec", "SPECS", "METRICS", "DEFAULT_METRIC", "COST_FIELDS", "require_metric", "cost_status", "view"]


@dataclass(frozen=True)
class MetricSpec:
    """How one metric enters the summary."""

    name: str
    label: str            # what plots and tables call the error
    field: str            # record field
    unbiased_slope: float | None
    target: float | None  # None: the scene's target RMSE
    note: str


SPECS = {
    "rmse": MetricSpec("rmse", "RMSE", "mse_corrected", -0.5, None,
                       "sqrt of the seed-mean reference-noise-corrected MSE"),
    "relmse": MetricSpec("relmse", "relMSE", "relmse", -1.0, 0.01,
                         f"seed-mean relMSE (eps {RELMSE_EPS:g}) minus the reference's own relative noise"),
    "ssim": MetricSpec("ssim", "1 - SSIM", "ssim", None, 0.05, "seed-mean 1 - SSIM of the display images"),
    "flip": MetricSpec("flip", "FLIP", "flip", None, 0.05, "seed-mean LDR-FLIP of the display images"),
}
METRICS = tuple(SPECS)
DEFAULT_METRIC = "relmse"
#: the figures a metric changes in a summary row.
COST_FIELDS = ("slope", "slope_ci", "slope_range", "slope_steep", "efficiency", "efficiency_vs_mitsuba",
               "time_to_target", "target")


def require_metric(metric: str) -> MetricSpec:
    """The spec of ``metric``; ``ValueError`` for an unknown one or for FLIP without its package.

    >>> require_metric("relmse").unbiased_slope
    -1.0
    """
    if metric not in SPECS:
        raise ValueError(f"unknown metric {metric!r}; choose from {', '.join(METRICS)}")
    if metric == "flip" and not flip_available():
        raise ValueError(f"--metric flip needs NVIDIA's FLIP: pip install {FLIP_PACKAGE}")
    return SPECS[metric]


def cost_status(row: dict) -> str | None:
    """``'biased'`` or ``'undetermined'`` where efficiency and time to target must not be shown, else None.

    >>> cost_status({"bias_verdict": "fail", "bias_significant": True}), cost_status({"bias_verdict": "pass"})
    ('biased', None)
    >>> cost_status({"bias_verdict": "undetermined", "bias_significant": None})
    'undetermined'
    """
    if row.get("bias_significant") is True or row.get("bias_verdict") == "fail":
        return "biased"
    if row.get("bias_verdict") == "undetermined":
        return "undetermined"
    return None


def view(row: dict, metric: str = DEFAULT_METRIC) -> dict:
    """``row`` with the figures of :data:`COST_FIELDS` under ``metric`` (RMSE's are the top-level ones).

    Adds ``metric``, ``metric_label``, ``unbiased_slope`` and ``cost_status``. A row written
    before ``by_metric`` existed keeps its RMSE figures only under ``rmse``; other metrics
    then read as null.

    >>> r = {"slope": -0.5, "target_rmse": 0.1, "by_metric": {"relmse": {"slope": -1.0, "target": 0.01}}}
    >>> v = view(r, "relmse"); v["slope"], v["target"], v["metric_label"]
    (-1.0, 0.01, 'relMSE')
    >>> view(r, "rmse")["target"]
    0.1
    """
    spec = SPECS[metric]
    out = dict(row)
    if metric == "rmse":
        out["target"] = row.get("target_rmse")
    else:
        fig = (row.get("by_metric") or {}).get(metric) or {}
        for k in COST_FIELDS:
            out[k] = fig.get(k)
    out.update(metric=metric, metric_label=spec.label, unbiased_slope=spec.unbiased_slope,
               cost_status=cost_status(row))
    return out
