"""Mismatch maps of a parity check: one PNG panel per AOV and an EXR of the masks."""
from __future__ import annotations

from pathlib import Path

import numpy as np

import reference_tracer as rt

from ..files import slug
from .compare import AOVS, ParityReport

__all__ = ["write_mismatch_maps"]


def _grey(report: ParityReport) -> np.ndarray:
    """Our hit distance as a grey backdrop (near bright, misses black)."""
    t = report.ours["t"]
    fin = np.isfinite(t)
    if not fin.any():
        return np.zeros(t.shape)
    lo, hi = float(t[fin].min()), float(t[fin].max())
    g = np.where(fin, 1.0 - (t - lo) / (hi - lo + 1e-12), 0.0)
    return 0.25 + 0.5 * g * fin


def write_mismatch_maps(report: ParityReport, out) -> list:
    """Write ``<scene>_parity.png`` (per AOV: mismatching pixels in red over our depth) and
    ``<scene>_parity.exr`` (R: shape or distance, G: normal, B: albedo or emitted mismatch).
    Returns the paths written."""
    import matplotlib  # deferred: matplotlib only when plotting (0.5-1.5 s)

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # deferred: matplotlib only when plotting (0.5-1.5 s)

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    png, exr = out / f"{slug(report.scene)}_parity.png", out / f"{slug(report.scene)}_parity.exr"
    m = report.masks
    rt.write_exr(exr, np.stack([m["shape"] | m["t"], m["normal"], m["albedo"] | m["emitted"]], axis=-1)
                 .astype(np.float32))
    grey = _grey(report)
    fig, axes = plt.subplots(1, len(AOVS), figsize=(2.6 * len(AOVS), 2.6 * report.height / report.width + 0.7), dpi=100)
    for ax, aov in zip(np.atleast_1d(axes), AOVS):
        img = np.repeat(grey[..., None], 3, axis=-1)
        img[m[aov]] = (1.0, 0.1, 0.1)
        ax.imshow(img, interpolation="nearest")
        ax.set_title(f"{aov}: {int(m[aov].sum())}", fontsize=9)
        ax.set_xticks([])
        ax.set_yticks([])
    fig.suptitle(f"{report.scene}: pixel centres that differ from Mitsuba (red)", fontsize=9)
    fig.tight_layout()
    fig.savefig(png)
    plt.close(fig)
    return [png, exr]
