"""Statistics shared by the ours-vs-Mitsuba tests: per-pixel z-tests with both variances.

Two checks, each at family-wise false-positive rate ``alpha`` under the normal
approximation of pixel means (so ``2 * alpha`` in all per image):

* per pixel and channel, ``z = (m_a - m_b) / sqrt(v_a / n_a + v_b / n_b)``; the image
  fails if any ``|z|`` exceeds the Sidak threshold for ``N`` tests,
  ``z* = Phi^-1(1 - (1 - (1 - alpha)^(1/N)) / 2)`` (about 5.0 for 3 x 32 x 32 pixels at
  alpha = 1e-3). Catches local disagreements: a shifted, mirrored or wrongly lit feature.
* per channel, the whole-image sum of differences against its standard error,
  Bonferroni over 3 channels. Pixels are independent, so this sum is very nearly
  normal and its variance well estimated: it catches a small global bias (a wrong
  Fresnel, a missing bounce) that no single pixel shows.

Pixels where both variances are 0 are deterministic in both renderers and must agree
to float32 rounding; elsewhere a float32 rounding floor of 1e-5 of the pixel value is
added to the standard error (it matters only for near-deterministic pixels).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from benchmarks.stats import sidak


#: Relative float32 rounding allowed between renderers (a few ulps of a pixel mean).
RELATIVE_ROUNDING = 1e-5


@dataclass
class Agreement:
    ok: bool
    max_z: float
    z_crit: float
    global_z: tuple
    global_crit: float
    worst_pixel: tuple
    deterministic_mismatch: int
    message: str


def sidak_z(alpha: float, n_tests: int) -> float:
    return float(stats.norm.isf(sidak(alpha, n_tests) / 2.0))


def compare(mean_a, var_a, n_a, mean_b, var_b, n_b, *, alpha: float = 1e-3) -> Agreement:
    mean_a, mean_b = np.asarray(mean_a, np.float64), np.asarray(mean_b, np.float64)
    se2 = np.asarray(var_a, np.float64) / n_a + np.asarray(var_b, np.float64) / n_b
    # Float32 rounding floor: a pixel whose samples are all (nearly) equal, e.g. a mirror
    # showing a constant background, differs between renderers by rounding alone.
    se2 = np.where(se2 > 0, se2 + (RELATIVE_ROUNDING * np.abs(mean_b)) ** 2, 0.0)
    if not (np.all(np.isfinite(mean_a)) and np.all(np.isfinite(mean_b)) and np.all(np.isfinite(se2))):
        return Agreement(False, np.inf, 0, (), 0, (), 0, "non-finite mean or variance")
    diff = mean_a - mean_b
    det = se2 == 0
    tol = 1e-5 * (1.0 + np.abs(mean_a))
    det_bad = int(np.count_nonzero(det & (np.abs(diff) > tol)))
    z = np.zeros_like(diff)
    z[~det] = diff[~det] / np.sqrt(se2[~det])
    n = max(int(np.count_nonzero(~det)), 1)
    zc = sidak_z(alpha, n)
    worst = np.unravel_index(int(np.argmax(np.abs(z))), z.shape)
    gz = tuple(float(diff[..., c].sum() / np.sqrt(se2[..., c].sum())) if se2[..., c].sum() > 0 else 0.0
               for c in range(diff.shape[-1]))
    gc = sidak_z(alpha, diff.shape[-1])
    ok = det_bad == 0 and float(np.abs(z).max()) <= zc and max(abs(g) for g in gz) <= gc
    msg = (f"max |z| = {np.abs(z).max():.2f} (crit {zc:.2f}) at pixel {worst} "
           f"(a={mean_a[worst]:.5g}, b={mean_b[worst]:.5g}); global z per channel = "
           f"{tuple(round(g, 2) for g in gz)} (crit {gc:.2f}); deterministic mismatches = {det_bad}; "
           f"image means a={mean_a.mean(axis=(0, 1))}, b={mean_b.mean(axis=(0, 1))}")
    return Agreement(ok, float(np.abs(z).max()), zc, gz, gc, tuple(int(i) for i in worst), det_bad, msg)
