"""Pearson's chi-square test (the method: README.md here): :func:`chi2_test` of ``sample(u)`` against
``pdf(points)`` on an equal-area grid, with the density's mass against the share of valid samples;
:func:`discrete_test` of the counts of a finite set of outcomes.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from scipy import stats

from ..stats import sidak

__all__ = ["DOMAINS", "DEFAULT_N", "DEFAULT_RESOLUTION", "DEFAULT_ALPHA", "MIN_EXPECTED", "Grid", "Chi2Result",
           "sidak", "pearson", "integrate", "chi2_test", "discrete_test", "excess_p_value", "uniform_chunks"]

#: directions on the unit sphere or upper hemisphere, binned in (cos theta, phi); points of
#: the unit disk, binned in (r^2, phi): equal-area grids
DOMAINS = ("sphere", "hemisphere", "disk")

#: samples per test when the caller gives none
DEFAULT_N = 200_000

#: (cells along cos theta or r^2, cells along phi): about 100 samples a cell at DEFAULT_N
DEFAULT_RESOLUTION = (32, 64)

#: false-positive rate of one chi2_test call (all its sub-tests), as Mitsuba's ChiSquareTest
DEFAULT_ALPHA = 0.01

#: cells expecting fewer samples than this are pooled (Mitsuba's threshold)
MIN_EXPECTED = 5.0

# Quadrature of the density over a cell (README.md, step 3): adaptive 4 x 4 Gauss-Lobatto on a
# quadtree; a cell's tolerance is _PRECISION times its count's Poisson noise, a rectangle at
# depth d gets 2^-d of it; a quarter holding an edge of the support is split while half its
# mass exceeds _EDGE_PRECISION / _PRECISION times its tolerance.
_LOBATTO_T = np.array([0.0, (1.0 - 1.0 / math.sqrt(5.0)) / 2.0, (1.0 + 1.0 / math.sqrt(5.0)) / 2.0, 1.0])
_LOBATTO_W = np.array([1.0, 5.0, 5.0, 1.0]) / 12.0
_PRECISION, _EDGE_PRECISION, _MAX_DEPTH = 0.05, 0.2, 12
# Cells holding samples where the first level's nodes found no density (README.md, step 4): stratified
# Monte Carlo of _SLIVER_SIDE^2 jittered points, for the _SLIVER_CELLS of them holding the most samples
# (about a second each; more such cells are a sampler drawing where its density is 0, reported as such).
_SLIVER_SIDE, _SLIVER_CELLS = 1024, 64
_CHUNK = 1 << 20   # points handed to `sample` / `pdf` per call
# Samples this close outside the grid's range (rounding) go to the edge cells; |d| may differ from 1 by _UNIT_TOL.
_EDGE_EPS, _UNIT_TOL = 1e-9, 1e-6
# Relative tolerance of the mass check beyond the quadrature's error estimate: the errors
# along a support's edges add up to about 1e-4 over the domain.
_MASS_RTOL = 1e-3


@dataclass(frozen=True)
class Grid:
    """The binning grid: ``n_u`` cells along u (cos theta in [lo, hi], or r^2 for the
    disk) times ``n_phi`` cells along phi in [0, 2 pi); every cell has the same measure."""

    domain: str
    n_u: int
    n_phi: int
    lo: float
    hi: float

    @classmethod
    def make(cls, domain: str, resolution=DEFAULT_RESOLUTION, cos_range=None) -> "Grid":
        if domain not in DOMAINS:
            raise ValueError(f"domain must be one of {DOMAINS}, got {domain!r}")
        n_u, n_phi = (int(r) for r in resolution)
        if n_u < 1 or n_phi < 1:
            raise ValueError(f"resolution must be positive, got {resolution}")
        lo, hi = {"sphere": (-1.0, 1.0), "hemisphere": (0.0, 1.0), "disk": (0.0, 1.0)}[domain]
        if cos_range is not None:
            if domain == "disk":
                raise ValueError("cos_range applies to directions, not to the disk")
            lo, hi = (float(c) for c in cos_range)
            if not -1.0 <= lo < hi <= 1.0:
                raise ValueError(f"cos_range must satisfy -1 <= lo < hi <= 1, got {cos_range}")
        return cls(domain, n_u, n_phi, lo, hi)

    @property
    def dims(self) -> int:
        return 2 if self.domain == "disk" else 3

    def points(self, u: np.ndarray, phi: np.ndarray) -> np.ndarray:
        """Points of the domain at grid coordinates (u, phi)."""
        if self.domain == "disk":
            r = np.sqrt(np.clip(u, 0.0, None))
            return np.stack([r * np.cos(phi), r * np.sin(phi)], axis=-1)
        s = np.sqrt(np.clip(1.0 - u * u, 0.0, None))
        return np.stack([s * np.cos(phi), s * np.sin(phi), u], axis=-1)

    def bin(self, pts: np.ndarray):
        """Flat cell index of each point, with the counts of points outside the range and of
        directions that are not unit vectors (both left out of the index)."""
        if self.domain == "disk":
            u = pts[:, 0] ** 2 + pts[:, 1] ** 2
            nonunit = np.zeros(len(pts), bool)
        else:
            nonunit = np.abs(np.sqrt(np.einsum("ij,ij->i", pts, pts)) - 1.0) > _UNIT_TOL
            u = pts[:, 2]
        inside = (u >= self.lo - _EDGE_EPS) & (u <= self.hi + _EDGE_EPS) & ~nonunit
        phi = np.mod(np.arctan2(pts[:, 1], pts[:, 0]), 2.0 * math.pi)
        i = np.clip(((u - self.lo) / (self.hi - self.lo) * self.n_u).astype(np.int64), 0, self.n_u - 1)
        j = np.clip((phi / (2.0 * math.pi) * self.n_phi).astype(np.int64), 0, self.n_phi - 1)
        idx = (i * self.n_phi + j)[inside]
        return idx, int((~inside & ~nonunit).sum()), int(nonunit.sum())


def uniform_chunks(n: int, seed: int, dims: int = 3):
    """The uniform numbers of ``n`` samples of numpy's default generator, in chunks (bounded memory)."""
    rng = np.random.default_rng(seed)
    for start in range(0, n, _CHUNK):
        yield rng.random((min(_CHUNK, n - start), dims))


def _rect_integrals(fn, grid: Grid, u0, du, p0, dp):
    """Gauss-Lobatto integral of fn over each rectangle [u0, u0 + du] x [p0, p0 + dp] of grid
    coordinates; whether fn is 0 at some nodes and positive at others; the count of
    non-finite or negative values (taken as 0)."""
    t, w = _LOBATTO_T, _LOBATTO_W
    k = len(t)
    out = np.empty(len(u0))
    mixed = np.empty(len(u0), bool)
    bad = 0
    jac = 0.5 if grid.domain == "disk" else 1.0
    step = max(1, _CHUNK // (k * k))
    for s in range(0, len(u0), step):
        e = slice(s, s + step)
        u = u0[e, None] + t[None, :] * du[e, None]
        ph = p0[e, None] + t[None, :] * dp[e, None]
        pts = np.ascontiguousarray(grid.points(np.repeat(u, k, axis=1).ravel(), np.tile(ph, k).ravel()))
        v = np.asarray(fn(pts), dtype=np.float64).reshape(-1, k, k)
        wrong = ~np.isfinite(v) | (v < 0)
        bad += int(wrong.sum())
        v = np.where(wrong, 0.0, v)
        out[e] = np.einsum("ckl,k,l->c", v, w, w) * du[e] * dp[e] * jac
        pos = v > 0
        mixed[e] = pos.any(axis=(1, 2)) & ~pos.all(axis=(1, 2))
    return out, mixed, bad


def _sliver_integrals(fn, grid: Grid, cells) -> tuple:
    """Stratified Monte Carlo integrals of fn over ``cells`` of grid, one call of fn each: one jittered
    point in each of _SLIVER_SIDE^2 equal parts of a cell. ``(integrals, standard errors, bad values)``."""
    du, dp = (grid.hi - grid.lo) / grid.n_u, 2.0 * math.pi / grid.n_phi
    jac = 0.5 if grid.domain == "disk" else 1.0
    k = np.arange(_SLIVER_SIDE)
    m = _SLIVER_SIDE * _SLIVER_SIDE
    out, errs, bad = [], [], 0
    for c in cells:
        i, j = divmod(int(c), grid.n_phi)
        rng = np.random.default_rng(int(c))
        u = grid.lo + (i + (k[:, None] + rng.random((_SLIVER_SIDE, _SLIVER_SIDE))) / _SLIVER_SIDE) * du
        ph = (j + (k[None, :] + rng.random((_SLIVER_SIDE, _SLIVER_SIDE))) / _SLIVER_SIDE) * dp
        v = np.asarray(fn(np.ascontiguousarray(grid.points(u.ravel(), ph.ravel()))), dtype=np.float64)
        wrong = ~np.isfinite(v) | (v < 0)
        bad += int(wrong.sum())
        v = np.where(wrong, 0.0, v)
        mean = float(v.sum()) / m
        out.append(mean * du * dp * jac)
        errs.append(math.sqrt(max(float((v * v).sum()) / m - mean * mean, 0.0) / m) * du * dp * jac)
    return np.array(out), np.array(errs), bad


def integrate(fn: Callable[[np.ndarray], np.ndarray], grid: Grid, *, n: int = DEFAULT_N, observed=None):
    """Integral of ``fn`` (points -> values >= 0) over every cell of ``grid``, precise to a
    small fraction of the Poisson noise of ``n`` samples; cells with ``observed`` samples
    but no density at the first level's nodes are integrated by stratified Monte Carlo
    (a sliver of support may lie between the nodes).

    Returns ``(integrals (n_u, n_phi), error_estimate, rectangles, bad_values)``
    (``bad_values``: non-finite or negative values of ``fn``).
    """
    ncell = grid.n_u * grid.n_phi
    cell = np.arange(ncell)
    du0, dp0 = (grid.hi - grid.lo) / grid.n_u, 2.0 * math.pi / grid.n_phi
    u0 = grid.lo + (cell // grid.n_phi) * du0
    p0 = (cell % grid.n_phi) * dp0
    du = np.full(ncell, du0)
    dp = np.full(ncell, dp0)
    est, mixed, bad = _rect_integrals(fn, grid, u0, du, p0, dp)
    total = est.copy()
    tol_cell = _PRECISION * np.sqrt(np.maximum(n * est, 1.0)) / n
    err = 0.0
    rects = ncell
    if observed is not None:
        seen = np.asarray(observed).ravel()
        sliver = np.nonzero((est == 0) & (seen > 0))[0]
        sliver = np.sort(sliver[np.argsort(-seen[sliver], kind="stable")[:_SLIVER_CELLS]])
        total[sliver], sliver_err, b = _sliver_integrals(fn, grid, sliver)
        err += float(sliver_err.sum())
        bad += b
        # their nodes are all 0: the quadtree below has nothing to refine there
        cell, u0, p0, du, dp, est, mixed = (np.delete(x, sliver) for x in (cell, u0, p0, du, dp, est, mixed))
    depth = 0
    while len(cell):
        depth += 1
        hu, hp = du / 2.0, dp / 2.0
        qu0 = np.stack([u0, u0 + hu, u0, u0 + hu], axis=1).ravel()
        qp0 = np.stack([p0, p0, p0 + hp, p0 + hp], axis=1).ravel()
        qdu, qdp = np.repeat(hu, 4), np.repeat(hp, 4)
        q, qmixed, b = _rect_integrals(fn, grid, qu0, qdu, qp0, qdp)
        bad += b
        rects += len(q)
        sums = q.reshape(-1, 4).sum(axis=1)
        np.add.at(total, cell, sums - est)
        diff = np.abs(sums - est)
        unconverged = diff > tol_cell[cell] * 0.5 ** (depth - 1)
        qcell = np.repeat(cell, 4)
        edge = (qmixed | np.repeat(mixed, 4)) & (q > 0)
        edge_tol = _EDGE_PRECISION / _PRECISION * tol_cell[qcell] * 0.5 ** depth
        go = (np.repeat(unconverged, 4) | (edge & (0.5 * q > edge_tol))) & (depth < _MAX_DEPTH)
        err += float(diff[~unconverged].sum()) + float(q[edge & ~go].sum())
        if depth >= _MAX_DEPTH:
            err += float(diff[unconverged].sum())
        cell = qcell[go]
        u0, p0, du, dp, est, mixed = qu0[go], qp0[go], qdu[go], qdp[go], q[go], qmixed[go]
    return total.reshape(grid.n_u, grid.n_phi), err, rects, bad


def pearson(observed, expected, min_expected: float = MIN_EXPECTED):
    """Pearson's statistic with cells expecting less than ``min_expected`` pooled (README.md,
    step 4). Cells expecting 0 are left out, their samples returned apart.

    Returns ``(statistic, bins, pooled_in, pooled_out, samples_where_zero_expected)``.
    """
    obs = np.asarray(observed, dtype=np.float64).ravel()
    exp = np.asarray(expected, dtype=np.float64).ravel()
    zero = exp <= 0
    stray = float(obs[zero].sum())
    order = np.argsort(exp[~zero], kind="stable")
    o, e = obs[~zero][order], exp[~zero][order]
    bins_o, bins_e = [], []
    po = pe = 0.0
    pooled_in = pooled_out = 0
    members = 0
    for oi, ei in zip(o, e):
        po += oi
        pe += ei
        members += 1
        if pe >= min_expected:
            bins_o.append(po)
            bins_e.append(pe)
            if members > 1:
                pooled_in += members
                pooled_out += 1
            po = pe = 0.0
            members = 0
    if members:
        if bins_o:
            bins_o[-1] += po
            bins_e[-1] += pe
            pooled_in += members
        else:
            bins_o.append(po)
            bins_e.append(pe)
    bo, be = np.array(bins_o), np.array(bins_e)
    stat = float(((bo - be) ** 2 / be).sum()) if len(be) else 0.0
    return stat, len(be), pooled_in, pooled_out, stray


def excess_p_value(diff: float, tol: float, sigma: float) -> float:
    """Two-sided normal p-value of ``max(0, |diff| - tol) / sigma`` (sigma 0: 1 within tol, else 0)."""
    excess = max(0.0, abs(diff) - tol)
    if excess == 0.0:
        return 1.0
    if not sigma > 0:
        return 0.0
    return float(2.0 * stats.norm.sf(excess / sigma))


@dataclass
class Chi2Result:
    """Outcome of :func:`chi2_test` or :func:`discrete_test`: ``verdict`` ``pass``, ``fail`` or
    ``undetermined`` (nothing to test); per-cell ``observed`` and ``expected`` counts (the
    latter summing to ``n_valid``); ``mass``, the density's integral, tested against
    ``n_valid / n`` (``mass_p_value``)."""

    verdict: str
    p_value: float
    statistic: float
    dof: int
    alpha: float
    n: int
    n_valid: int
    mass: float
    mass_p_value: float
    observed: np.ndarray
    expected: np.ndarray
    domain: str
    resolution: tuple = ()
    cos_range: tuple | None = None
    pooled_in: int = 0
    pooled_out: int = 0
    integration_error: float = 0.0
    message: str = ""
    details: dict = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        return self.verdict == "pass"

    @property
    def residuals(self) -> np.ndarray:
        """Pearson residuals (observed - expected) / sqrt(expected), 0 where nothing is expected."""
        e = np.asarray(self.expected, dtype=np.float64)
        return np.where(e > 0, (self.observed - e) / np.sqrt(np.where(e > 0, e, 1.0)), 0.0)


def _verdict(problems: list[str], undetermined: str | None) -> tuple[str, str]:
    if problems:
        return "fail", "; ".join(problems)
    if undetermined:
        return "undetermined", undetermined
    return "pass", ""


def chi2_test(sample: Callable[[np.ndarray], np.ndarray], pdf: Callable[[np.ndarray], np.ndarray], *,
              domain: str, n: int = DEFAULT_N, seed: int = 0, resolution=DEFAULT_RESOLUTION,
              alpha: float = DEFAULT_ALPHA, dims: int = 2, cos_range=None) -> Chi2Result:
    """Test that ``sample`` draws from the density ``pdf``.

    Parameters
    ----------
    sample : callable
        ``sample(u) -> points``: ``(m, dims)`` uniforms to ``(m, 3)`` unit vectors (``(m, 2)``
        on the disk); a row with a non-finite entry is a failed sample.
    pdf : callable
        ``pdf(points) -> (m,)`` density in solid angle (area on the disk).
    domain : {'sphere', 'hemisphere', 'disk'}
    n, seed : samples drawn, and the seed of numpy's default generator.
    resolution : (cells along cos theta or r^2, cells along phi).
    alpha : false-positive rate of the call (its distribution and mass tests at ``sidak(alpha, 2)``).
    dims : uniform numbers per sample.
    cos_range : (lo, hi): bin only cos theta in [lo, hi] (a cap holding the whole support).

    Returns
    -------
    Chi2Result
        Failed by Pearson's test on the valid samples, by the mass test, and by any sample
        outside the domain, off the unit sphere or where the density is 0, or any
        non-finite or negative density value (README.md, "The test").

    Examples
    --------
    >>> from benchmarks.chi2.probes import warp
    >>> chi2_test(*warp("cosine_hemisphere"), domain="hemisphere", n=20_000, resolution=(8, 16)).verdict
    'pass'
    """
    grid = Grid.make(domain, resolution, cos_range)
    if n < 1:
        raise ValueError(f"n must be positive, got {n}")
    counts = np.zeros(grid.n_u * grid.n_phi, dtype=np.int64)
    n_valid = outside = nonunit = 0
    for u in uniform_chunks(n, seed, dims):
        pts = np.asarray(sample(u), dtype=np.float64)
        if pts.shape != (len(u), grid.dims):
            raise ValueError(f"sample returned shape {pts.shape}, expected {(len(u), grid.dims)}")
        ok = np.isfinite(pts).all(axis=1)
        idx, out_, nonu = grid.bin(pts[ok])
        counts += np.bincount(idx, minlength=counts.size)
        n_valid += int(ok.sum())
        outside += out_
        nonunit += nonu
    in_grid = int(counts.sum())

    integrals, err, refined, bad = integrate(pdf, grid, n=n, observed=counts)
    mass = float(integrals.sum())
    level = sidak(alpha, 2)
    expected = integrals * (in_grid / mass) if mass > 0 else np.zeros_like(integrals)
    stat, bins, pooled_in, pooled_out, stray = pearson(counts, expected)
    dof = bins - 1
    p = float(stats.chi2.sf(stat, dof)) if dof >= 1 else 1.0
    frac = n_valid / n
    sigma = math.sqrt(max(mass * (1.0 - mass), 0.0) / n) if 0 < mass < 1 else math.sqrt(frac * (1 - frac) / n)
    mass_p = excess_p_value(mass - frac, err + _MASS_RTOL * max(mass, frac), sigma)

    problems = [text for failed, text in (
        (nonunit, f"{nonunit} samples are not unit vectors"),
        (outside, f"{outside} samples outside the {domain}"
                  + (f" range cos theta in [{grid.lo:g}, {grid.hi:g}]" if cos_range is not None else "")),
        (bad, f"pdf gave {bad} non-finite or negative values"),
        (stray, f"{int(stray)} samples in cells where the pdf is 0"),
        (mass_p < level, f"pdf integrates to {mass:.6g} but {frac:.6g} of the samples are valid (p = {mass_p:.2e})"),
        (dof >= 1 and p < level, f"chi2 = {stat:.1f} on {dof} dof (p = {p:.2e})")) if failed]
    undetermined = ("no valid sample: nothing to test" if n_valid == 0 else
                    "all samples fall into one pooled bin: raise n or the resolution" if dof < 1 else None)
    verdict, message = _verdict(problems, undetermined)
    return Chi2Result(
        verdict=verdict, p_value=p, statistic=stat, dof=dof, alpha=alpha, n=n, n_valid=n_valid, mass=mass,
        mass_p_value=mass_p, observed=counts.reshape(grid.n_u, grid.n_phi), expected=expected,
        domain=domain, resolution=(grid.n_u, grid.n_phi), cos_range=(grid.lo, grid.hi),
        pooled_in=pooled_in, pooled_out=pooled_out, integration_error=err, message=message,
        details={"quadrature_rectangles": refined, "outside": outside, "nonunit": nonunit, "level": level})


def discrete_test(counts, probabilities, *, alpha: float = DEFAULT_ALPHA) -> Chi2Result:
    """Pearson's test of observed ``counts`` of k outcomes against their ``probabilities``
    (which must sum to 1). Outcomes of probability 0 must not occur; when only one outcome
    is possible the test is exact (p = 1 if every count is in it, else it fails)."""
    obs = np.asarray(counts, dtype=np.float64)
    prob = np.asarray(probabilities, dtype=np.float64)
    if obs.shape != prob.shape or obs.ndim != 1:
        raise ValueError("counts and probabilities must be 1-D arrays of the same length")
    if not (np.all(prob >= 0) and abs(prob.sum() - 1.0) < 1e-9):
        raise ValueError(f"probabilities must be >= 0 and sum to 1, got {prob}")
    n = int(obs.sum())
    expected = n * prob
    stat, bins, pooled_in, pooled_out, stray = pearson(obs, expected)
    dof = bins - 1
    p = float(stats.chi2.sf(stat, dof)) if dof >= 1 else 1.0
    problems = []
    if stray:
        problems.append(f"{int(stray)} samples of an outcome of probability 0")
    if dof >= 1 and p < alpha:
        problems.append(f"chi2 = {stat:.1f} on {dof} dof (p = {p:.2e})")
    verdict, message = _verdict(problems, None if n else "no samples")
    return Chi2Result(verdict=verdict, p_value=p if not stray else 0.0, statistic=stat, dof=dof, alpha=alpha, n=n,
                      n_valid=n, mass=1.0, mass_p_value=1.0, observed=obs, expected=expected, domain="discrete",
                      resolution=(len(obs),), pooled_in=pooled_in, pooled_out=pooled_out, message=message)
