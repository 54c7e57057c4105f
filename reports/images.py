"""Image panels: display PNGs, false-colour error maps, and which spp the image rows show.

Tone mapping (exposure and sRGB curve) is :mod:`benchmarks.display`'s, the same as the
SSIM metric's; the error maps use relMSE's epsilon (``benchmarks.constants.RELMSE_EPS``).
"""
from __future__ import annotations

import io
import math

import numpy as np

from benchmarks import metrics as M
from benchmarks.constants import RELMSE_EPS
from benchmarks.display import to_display

__all__ = ["display_png", "error_map", "error_png", "error_range", "pick_spps", "ERROR_CMAP", "FLIP_CMAP",
           "flip_map", "flip_png"]

#: colour map of the error maps.
ERROR_CMAP = "inferno"
#: colour map of the FLIP maps (FLIP's own convention).
FLIP_CMAP = "magma"


def _png(rgb_uint8: np.ndarray) -> bytes:
    from PIL import Image  # deferred: Pillow only when an 8-bit image is read or written

    buf = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(rgb_uint8)).save(buf, format="PNG", optimize=False)
    return buf.getvalue()


def display_png(img: np.ndarray, exposure: float) -> bytes:
    """Linear radiance -> 8-bit sRGB PNG bytes, ``exposure`` in stops (non-finite pixels black)."""
    d = to_display(np.asarray(img)[..., :3], exposure)
    return _png(np.round(np.clip(d, 0.0, 1.0) * 255.0).astype(np.uint8))


def error_map(img: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """Per-pixel relative squared error, mean over channels: (x - ref)^2 / (ref^2 + RELMSE_EPS).

    Its mean over the image is the record's relMSE (for the same image and reference).
    """
    img = np.asarray(img, dtype=np.float64)
    ref = np.asarray(ref, dtype=np.float64)
    if img.shape != ref.shape:
        raise ValueError(f"error_map: image {img.shape} and reference {ref.shape} differ in shape")
    e = (img - ref) ** 2 / (ref ** 2 + RELMSE_EPS)
    return np.nan_to_num(e.mean(axis=-1), nan=np.inf, posinf=np.inf)


def error_range(maps: list[np.ndarray]) -> tuple[float, float]:
    """Shared log colour range of a group of error maps: 2nd to 99.5th percentile of positive values."""
    vals = [m[np.isfinite(m) & (m > 0)] for m in maps]
    vals = np.concatenate(vals) if vals else np.zeros(0)
    if vals.size == 0:
        return 1e-4, 1.0
    lo = float(np.percentile(vals, 2.0))
    hi = float(np.percentile(vals, 99.5))
    lo = max(lo, hi * 1e-6, 1e-12)
    if hi <= lo * 10:
        hi = lo * 10
    return lo, hi


def error_png(emap: np.ndarray, vmin: float, vmax: float) -> bytes:
    """False-colour PNG of an error map on a log scale [vmin, vmax] (:data:`ERROR_CMAP`)."""
    from matplotlib import colormaps  # deferred: matplotlib only when plotting (0.5-1.5 s)

    if not (0 < vmin < vmax):
        raise ValueError(f"error_png: need 0 < vmin < vmax, got {vmin}, {vmax}")
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (np.log10(np.maximum(emap, vmin * 1e-3)) - math.log10(vmin)) / (math.log10(vmax) - math.log10(vmin))
    t = np.clip(np.nan_to_num(t, nan=1.0, posinf=1.0, neginf=0.0), 0.0, 1.0)
    rgba = colormaps[ERROR_CMAP](t, bytes=True)
    return _png(rgba[..., :3])


def flip_map(img: np.ndarray, ref: np.ndarray):
    """Per-pixel FLIP of an image against the reference (:func:`benchmarks.metrics.flip`), or None without FLIP.

    Its mean is the record's ``flip`` (same display images).
    """
    if not M.flip_available():
        return None
    _, fmap = M.flip(np.asarray(img)[..., :3], np.asarray(ref)[..., :3], error_map=True)
    return fmap


def flip_png(fmap: np.ndarray) -> bytes:
    """False-colour PNG of a FLIP map on FLIP's linear [0, 1] scale (:data:`FLIP_CMAP`)."""
    from matplotlib import colormaps  # deferred: matplotlib only when plotting (0.5-1.5 s)

    t = np.clip(np.nan_to_num(np.asarray(fmap, dtype=np.float64), nan=1.0), 0.0, 1.0)
    return _png(colormaps[FLIP_CMAP](t, bytes=True)[..., :3])


def pick_spps(available, *, preferred=(4, 16, 64), count: int = 3) -> list:
    """Sample counts for the equal-spp image rows: ``preferred`` when all present, else spread in log spp."""
    avail = sorted({float(s) for s in available if s and float(s) > 0})
    if not avail:
        return []
    if all(float(p) in avail for p in preferred):
        return [float(p) for p in preferred]
    if len(avail) <= count:
        return avail
    logs = np.log(avail)
    targets = np.linspace(logs[0], logs[-1], count)
    picked = []
    for t in targets:
        i = int(np.argmin([abs(v - t) if a not in picked else np.inf for v, a in zip(logs, avail)]))
        picked.append(avail[i])
    return sorted(picked)
