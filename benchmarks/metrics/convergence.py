"""Convergence and cost: log-log slope of RMSE over spp, efficiency, time to reach an error."""
from __future__ import annotations

import functools
import math
from dataclasses import asdict, dataclass

import numpy as np
from scipy import stats

from ._checks import nan_mask

__all__ = ["SlopeFit", "convergence_slope", "efficiency", "time_to_error"]


@dataclass(frozen=True)
class SlopeFit:
    """Least-squares fit ``log(rmse) = intercept + slope * log(spp)``, with the slope's standard
    error and two-sided Student-t ``confidence`` interval (NaN when ``n < 3``) and ``r2``."""

    slope: float
    intercept: float
    stderr: float
    ci_low: float
    ci_high: float
    confidence: float
    r2: float
    n: int

    def to_dict(self) -> dict:
        return asdict(self)


@functools.lru_cache(maxsize=64)
def _t_quantile(q: float, dof: int) -> float:
    """Student t quantile, cached: bootstraps fit thousands of slopes at a few (q, dof)."""
    return float(stats.t.ppf(q, dof))


def convergence_slope(spp, rmse, *, confidence: float = 0.95,
                      nan_policy: str = "propagate") -> SlopeFit:
    r"""Slope of log RMSE over log spp, with a confidence interval.

    Unbiased Monte Carlo has :math:`\mathrm{RMSE} = \sigma / \sqrt{N}`: slope -0.5; a bias
    ``b`` (or a noisy reference) flattens :math:`\sqrt{b^2 + \sigma^2/N}` towards 0 at high
    ``N``. Every (spp, rmse) pair is one point, taken as independent with equal log-scale noise.

    Parameters
    ----------
    spp, rmse : array_like, 1-D, same length
        Positive sample counts and RMSEs.
    confidence : float
    nan_policy : {'propagate', 'omit', 'raise'}
        ``'omit'`` drops the points where either value is NaN.

    Examples
    --------
    >>> s = [1, 4, 16, 64]
    >>> fit = convergence_slope(s, [1 / np.sqrt(n) for n in s])
    >>> round(fit.slope, 6), round(fit.stderr, 6)
    (-0.5, 0.0)
    """
    x = np.asarray(spp, dtype=np.float64).ravel()
    y = np.asarray(rmse, dtype=np.float64).ravel()
    if x.shape != y.shape:
        raise ValueError(f"spp and rmse have different lengths: {x.shape} vs {y.shape}")
    if not 0 < confidence < 1:
        raise ValueError(f"confidence must be in (0, 1); got {confidence}")
    keep = nan_mask(nan_policy, spp=x, rmse=y)
    if isinstance(keep, str):
        return SlopeFit(math.nan, math.nan, math.nan, math.nan, math.nan, float(confidence), math.nan, int(x.size))
    if keep is not None:
        x, y = x[keep], y[keep]
    if np.any(x <= 0) or np.any(y <= 0):
        raise ValueError("spp and rmse must be positive to fit on a log-log scale")
    n = x.size
    if n < 2:
        raise ValueError(f"need at least 2 points to fit a slope; got {n}")
    lx, ly = np.log(x), np.log(y)
    mx, my = lx.mean(), ly.mean()
    sxx = float(((lx - mx) ** 2).sum())
    if sxx == 0:
        raise ValueError("all spp values are equal: slope undefined")
    slope = float(((lx - mx) * (ly - my)).sum() / sxx)
    intercept = float(my - slope * mx)
    resid = ly - (intercept + slope * lx)
    ss_res = float((resid ** 2).sum())
    ss_tot = float(((ly - my) ** 2).sum())
    r2 = 1.0 - ss_res / ss_tot if ss_tot > 0 else 1.0
    if n >= 3:
        stderr = math.sqrt(ss_res / (n - 2) / sxx)
        half = _t_quantile(0.5 + confidence / 2, n - 2) * stderr
        lo, hi = slope - half, slope + half
    else:
        stderr, lo, hi = math.nan, math.nan, math.nan
    return SlopeFit(slope, intercept, stderr, lo, hi, float(confidence), float(r2), int(n))


def efficiency(mse, seconds):
    r"""Monte Carlo efficiency, :math:`1 / (\mathrm{MSE} \cdot t)`: higher is better.

    Vectorised; ``mse == 0`` gives ``inf``, NaN propagates; ``mse < 0`` or ``seconds <= 0``
    raise ``ValueError`` (undefined, not merely large).

    Examples
    --------
    >>> efficiency(0.01, 2.0)
    50.0
    """
    m = np.asarray(mse, dtype=np.float64)
    t = np.asarray(seconds, dtype=np.float64)
    if np.any(m < 0):
        raise ValueError("efficiency: mse must be >= 0")
    if np.any(t <= 0):
        raise ValueError("efficiency: seconds must be > 0")
    with np.errstate(divide="ignore"):
        out = 1.0 / (m * t)
    return float(out) if out.ndim == 0 else out


def time_to_error(seconds, rmse, target: float) -> float:
    r"""Seconds needed to reach ``rmse <= target``, interpolated on a log-log scale.

    The first segment (by time) with :math:`e_i > \mathrm{target} \ge e_{i+1}` is interpolated
    linearly in :math:`(\log t, \log e)`. Never reached: NaN (no extrapolation); reached at the
    cheapest point: ``seconds[0]`` (an upper bound); NaN points are ignored.

    Examples
    --------
    >>> time_to_error([1.0, 4.0, 16.0], [0.4, 0.2, 0.1], 0.2)
    4.0
    >>> round(time_to_error([1.0, 4.0], [0.4, 0.2], 0.2828427), 4)  # halfway in log
    2.0
    >>> time_to_error([1.0, 4.0], [0.4, 0.2], 0.01)
    nan
    """
    t = np.asarray(seconds, dtype=np.float64).ravel()
    e = np.asarray(rmse, dtype=np.float64).ravel()
    if t.shape != e.shape:
        raise ValueError(f"seconds and rmse have different lengths: {t.shape} vs {e.shape}")
    if not target > 0:
        raise ValueError(f"target must be positive; got {target}")
    ok = ~(np.isnan(t) | np.isnan(e))
    t, e = t[ok], e[ok]
    if np.any(t <= 0) or np.any(e < 0):
        raise ValueError("seconds must be > 0 and rmse >= 0")
    order = np.argsort(t, kind="stable")
    t, e = t[order], e[order]
    reached = np.flatnonzero(e <= target)
    if reached.size == 0:
        return math.nan
    i = reached[0]
    if i == 0 or e[i] == 0 or t[i] == t[i - 1]:
        return float(t[i])
    frac = (math.log(target) - math.log(e[i - 1])) / (math.log(e[i]) - math.log(e[i - 1]))
    return float(math.exp(math.log(t[i - 1]) + frac * (math.log(t[i]) - math.log(t[i - 1]))))
