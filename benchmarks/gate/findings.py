"""Where a comparison found its strongest evidence, how large the bias is, and its power
(helpers of :func:`benchmarks.gate.compare`)."""
from __future__ import annotations

import math

import numpy as np
from scipy import stats

from .result import LEVELS

__all__ = ["locate", "relative_bias", "power", "POWER", "POWER_TILE"]

#: The probability of detection quoted by the minimum detectable bias.
POWER = 0.8
#: Tile side of the quoted tile power.
POWER_TILE = 8


def argworst(p: np.ndarray, s: np.ndarray) -> tuple:
    """Index of the smallest ``p``, ties broken by the largest ``|s|``."""
    flat = np.lexsort((-np.abs(s).ravel(), p.ravel()))[0]
    return tuple(int(i) for i in np.unravel_index(flat, p.shape))


def tested(lv) -> np.ndarray:
    """``lv.p`` with untested statistics at 2 (never the worst)."""
    return np.where(lv.valid, lv.p, 2.0)


def worst_tile_box(tiles, tile_levels, H: int, W: int) -> tuple:
    """Pixel box ``(row0, col0, row1, col1)`` of the tested tile of any size with the smallest p."""
    best = None
    for ts, lv in zip(tiles, tile_levels):
        pt = tested(lv)
        iy, ix, ic = argworst(pt, lv.z)
        key = (pt[iy, ix, ic], -abs(lv.z[iy, ix, ic]))
        if best is None or key < best[0]:
            best = (key, (iy * ts, ix * ts, min(H, (iy + 1) * ts), min(W, (ix + 1) * ts)))
    return best[1]


def locate(d, pix, tiles, tile_levels, level_p: dict) -> tuple:
    """``(worst pixel, worst tile, worst level, worst region)`` (see :class:`GateResult`)."""
    H, W, _ = d.x.shape
    wy, wx, wc = argworst(tested(pix), pix.z)
    worst_tile = worst_tile_box(tiles, tile_levels, H, W)
    worst_level = min(level_p, key=lambda k: (level_p[k], LEVELS.index(k)))
    worst_region = {"pixel": (wy, wx, wy + 1, wx + 1), "tile": worst_tile,
                    "image": (0, 0, H, W), "correlation": (0, 0, H, W)}[worst_level]
    return (wy, wx, wc), worst_tile, worst_level, worst_region


def relative_bias(d, worst_tile: tuple) -> tuple:
    """``(relative bias, its standard error, per channel, inside worst_tile)``; finite pixels only."""
    good = ~d.bad
    d_all = np.where(good, d.x - d.r, 0.0)
    r_all = np.where(good, d.r, 0.0)
    sum_r_c = r_all.sum(axis=(0, 1))
    with np.errstate(divide="ignore", invalid="ignore"):
        rel_c = np.where(sum_r_c != 0, d_all.sum(axis=(0, 1)) / sum_r_c, np.nan)
    sr = float(r_all.sum())
    rel = float(d_all.sum() / sr) if sr != 0 else math.nan
    se_sum = d.a + d.b if d.fa is None else np.maximum(d.a, d.fa) + d.b
    rel_se = float(math.sqrt(se_sum[good].sum()) / abs(sr)) if sr != 0 else math.nan
    y0, x0, y1, x1 = worst_tile
    srt = float(r_all[y0:y1, x0:x1].sum())
    rel_tile = float(d_all[y0:y1, x0:x1].sum() / srt) if srt != 0 else math.nan
    return rel, rel_se, rel_c, rel_tile


def power(img, tile8) -> tuple:
    """Minimum detectable relative bias with probability :data:`POWER`, ``(z_crit + z_power)
    sqrt(var) / |sum r|``, of the image (most sensitive channel) and of a :data:`POWER_TILE` tile
    (median); a noiseless statistic detects any bias beyond its tolerance; NaN if untested."""
    z_pow = float(stats.norm.isf(1.0 - POWER))

    def mdb(lv):
        if lv is None:
            return np.array([])
        ref = np.abs(lv.ref_sum)
        ok = lv.valid & (lv.var > 0) & (ref != 0)
        exact = (lv.var == 0) & (ref != 0) & np.broadcast_to(np.asarray(lv.tol) > 0, ref.shape)
        noisy = (lv.z_crit + z_pow) * np.sqrt(lv.var[ok]) / ref[ok]
        return np.concatenate([noisy.ravel(), (np.broadcast_to(lv.tol, ref.shape)[exact] / ref[exact]).ravel()])

    g, t = mdb(img), mdb(tile8)
    return (float(g.min()) if g.size else math.nan), (float(np.median(t)) if t.size else math.nan)
