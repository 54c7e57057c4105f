"""Observed-versus-expected images of chi-square results (PNG, matplotlib)."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..display import pyplot
from .pearson import Chi2Result

__all__ = ["save_histograms", "file_name"]


def file_name(label: str) -> str:
    """A file name for a routine label: ``bsdf.rough_conductor[theta_o=30, alpha=0.1]`` ->
    ``bsdf.rough_conductor-theta_o=30-alpha=0.1.png``."""
    stem = re.sub(r"[^A-Za-z0-9_.=+-]+", "-", label).strip("-")
    return f"{stem}.png"


def save_histograms(result: Chi2Result, path, title: str = "") -> Path:
    """Write observed counts, expected counts and Pearson residuals side by side (a bar
    chart for discrete outcomes). Returns the path written."""
    plt = pyplot()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    head = f"{title}\n{result.verdict}: p = {result.p_value:.3g}, chi2 = {result.statistic:.1f} on {result.dof} dof, " \
           f"n = {result.n}"
    if result.domain == "discrete":
        fig, ax = plt.subplots(figsize=(5, 3.2), constrained_layout=True)
        k = np.arange(len(result.observed))
        ax.bar(k - 0.2, result.observed, width=0.4, label="observed")
        ax.bar(k + 0.2, result.expected, width=0.4, label="expected")
        ax.set_xticks(k, ["reflect", "transmit"][:len(k)] if len(k) == 2 else [str(i) for i in k])
        ax.legend()
        ax.set_title(head, fontsize=8)
    else:
        lo, hi = result.cos_range if result.cos_range else (0.0, 1.0)
        extent = (0.0, 2.0 * np.pi, lo, hi)
        vmax = max(float(result.observed.max()), float(np.max(result.expected)), 1.0)
        res = result.residuals
        lim = max(3.0, float(np.abs(res).max()))
        fig, axes = plt.subplots(1, 3, figsize=(13, 3.8), constrained_layout=True)
        panels = ((result.observed, "observed", 0, vmax, "viridis"), (result.expected, "expected", 0, vmax, "viridis"),
                  (res, "(observed - expected) / sqrt(expected)", -lim, lim, "RdBu_r"))
        for ax, (data, name, vmin, top, cmap) in zip(axes, panels):
            im = ax.imshow(data, origin="lower", aspect="auto", extent=extent, vmin=vmin, vmax=top, cmap=cmap)
            ax.set_title(name)
            fig.colorbar(im, ax=ax)
            ax.set_xlabel("phi")
            ax.set_ylabel("r^2" if result.domain == "disk" else "cos theta")
        fig.suptitle(head, fontsize=9)
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path
