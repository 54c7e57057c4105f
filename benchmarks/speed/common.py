"""What every speed measurement shares: timing, robust summaries, machine identity and
Mitsuba variant selection.

Timing
------
Every timed call records wall time (``time.perf_counter``) and process CPU time
(``time.process_time``: all threads of this process, Dr.Jit's worker threads
included). The machine these run on may be shared: wall-clock figures are then noisy
and biased by other load, and ``cpu/wall`` below the thread count shows contention (or
idle workers). CPU-time throughputs (``paths_per_cpu_second``) are reported beside the
wall-clock ones for that reason. Speed is measured and reported, never asserted.

Robust summaries
----------------
Rounds are summarised by their median (:func:`median`), their scatter by
:func:`spread`, and the median's uncertainty by :func:`median_order_interval`: a
distribution-free confidence interval from order statistics, which assumes only that
the rounds are independent draws of one distribution (no normality, no bootstrap).
"""
from __future__ import annotations

import math
import os
from fractions import Fraction
import platform
import statistics
import time

import numpy as np

import reference_tracer as rt
from mitsuba_scenes import to_mitsuba
from mitsuba_scenes.render import mesh_merge_safe
from mitsuba_scenes.variants import select_variant, versions
from reference_tracer.cpus import default_threads

__all__ = ["WALL_CLOCK_NOTE", "environment", "timed", "median", "spread", "median_order_interval",
           "median_coverage", "rounds_for_coverage", "name_list", "use_variant",
           "available_variants", "check_jit_variant", "mitsuba_versions", "mitsuba_render_fn", "load_mitsuba"]

#: printed under every table and stored in every JSON.
WALL_CLOCK_NOTE = ("wall-clock figures are noisy when the machine is shared (other processes steal "
                   "cores); process CPU time (all threads) is recorded beside them; cpu/wall well below "
                   "the thread count means contention or idle workers")


def name_list(name, values, allowed=None) -> list:
    """``values`` (a sequence or a comma-separated string) as a list of distinct names.

    Raises ``ValueError`` naming ``name`` when the list is empty, has duplicates or holds
    a name outside ``allowed``.

    Examples
    --------
    >>> name_list("kinds", "primary,random", ("primary", "random"))
    ['primary', 'random']
    >>> name_list("kinds", ["bogus"], ("primary", "random"))
    Traceback (most recent call last):
    ValueError: unknown kinds ['bogus']; choose from primary, random
    """
    if isinstance(values, str):
        values = [v for v in values.split(",") if v]
    values = list(values)
    if not values:
        raise ValueError(f"{name} must name at least one entry")
    if allowed is not None:
        bad = [v for v in values if v not in allowed]
        if bad:
            raise ValueError(f"unknown {name} {bad}; choose from {', '.join(allowed)}")
    if len(set(values)) != len(values):
        raise ValueError(f"{name} has duplicates: {values}")
    return values


def median(xs) -> float:
    """Median of the finite values of ``xs`` (None skipped); NaN when none is left.

    Examples
    --------
    >>> median([3.0, None, float("nan"), 1.0, 2.0])
    2.0
    """
    xs = [x for x in xs if x is not None and math.isfinite(x)]
    return statistics.median(xs) if xs else float("nan")


def spread(xs) -> float:
    """(max - min) / median of the finite values; NaN for fewer than two.

    Examples
    --------
    >>> spread([1.0, 2.0, 3.0])
    1.0
    """
    xs = [x for x in xs if x is not None and math.isfinite(x)]
    if len(xs) < 2:
        return float("nan")
    m = statistics.median(xs)
    return (max(xs) - min(xs)) / m if m > 0 else float("nan")


def median_coverage(n: int, k: int) -> float:
    """Coverage of ``[x_(k), x_(n+1-k)]``, the k-th lowest and k-th highest of ``n``
    independent draws, as a confidence interval for their distribution's median.

    Each draw falls below the median with probability 1/2, so the interval misses it when
    fewer than ``k`` draws fall on one side: the coverage is
    ``1 - 2 P(Binomial(n, 1/2) <= k - 1)``, exact for a continuous distribution and a
    lower bound otherwise. ``ValueError`` unless ``1 <= k <= n / 2`` (rounded up).

    Examples
    --------
    >>> median_coverage(5, 1), median_coverage(9, 2)
    (0.9375, 0.9609375)
    """
    n, k = int(n), int(k)
    if n < 1 or not 1 <= k <= (n + 1) // 2:
        raise ValueError(f"need 1 <= k <= (n + 1) / 2 order statistics of n >= 1 values, got n={n}, k={k}")
    return float(_coverage(n, k))


def _coverage(n: int, k: int) -> Fraction:
    """:func:`median_coverage` as an exact fraction."""
    return 1 - Fraction(2 * sum(math.comb(n, i) for i in range(k)), 2 ** n)


def rounds_for_coverage(coverage: float = 0.90) -> int:
    """The fewest values whose lowest and highest bracket the median with ``coverage``.

    Examples
    --------
    >>> rounds_for_coverage(0.90), rounds_for_coverage(0.95), rounds_for_coverage(0.99)
    (5, 6, 8)
    """
    target = _check_coverage(coverage)
    n = 2
    while _coverage(n, 1) < target:
        n += 1
    return n


def _check_coverage(coverage) -> Fraction:
    """``coverage`` as an exact fraction; ``ValueError`` unless ``0 < coverage < 1``."""
    if isinstance(coverage, bool) or not isinstance(coverage, (int, float)) or not 0.0 < coverage < 1.0:
        raise ValueError(f"coverage must be in (0, 1), got {coverage!r}")
    return Fraction(coverage)


def median_order_interval(values, *, coverage: float = 0.90) -> dict:
    """Median of the finite ``values`` and a distribution-free confidence interval for it.

    The interval is ``[x_(k), x_(n+1-k)]`` of the ``n`` sorted finite values, with the
    largest ``k`` whose coverage (:func:`median_coverage`) is at least ``coverage``: the
    narrowest such interval from order statistics. Valid for any distribution of
    independent values (for paired rounds: any distribution of the per-round ratio), and
    its coverage holds in few rounds, where that of a bootstrap interval (the A/B runs'
    ``benchmarks.speed.builds.median_interval``, over 40 rounds and more) is approximate.

    Parameters
    ----------
    values : iterable of float or None
        E.g. the per-round ratios; None, NaN and infinities are left out.
    coverage : float, keyword-only
        Least coverage asked for, in (0, 1).

    Returns
    -------
    dict
        ``median`` (NaN when no value is finite), ``rounds`` (the finite values counted),
        ``low`` and ``high`` (None when ``rounds`` is too few for ``coverage``: fewer than
        :func:`rounds_for_coverage`), ``coverage`` (the interval's own, at least the one
        asked for; None without an interval), ``rank`` (``k``; None without an interval)
        and ``rounds_needed`` (:func:`rounds_for_coverage`).

    Examples
    --------
    >>> iv = median_order_interval([1.6, 1.52, 1.7, 1.61, float("nan"), 1.65])
    >>> iv["median"], iv["low"], iv["high"], iv["coverage"], iv["rounds"]
    (1.61, 1.52, 1.7, 0.9375, 5)
    >>> median_order_interval([1.0, 2.0])["low"] is None
    True
    """
    target = _check_coverage(coverage)
    xs = sorted(float(x) for x in values if x is not None and math.isfinite(x))
    n = len(xs)
    out = {"median": statistics.median(xs) if xs else float("nan"), "rounds": n, "low": None, "high": None,
           "coverage": None, "rank": None, "rounds_needed": rounds_for_coverage(coverage)}
    if n < 2 or _coverage(n, 1) < target:
        return out
    k = 1
    while k + 1 <= (n + 1) // 2 and _coverage(n, k + 1) >= target:
        k += 1
    out.update(low=xs[k - 1], high=xs[n - k], coverage=float(_coverage(n, k)), rank=k)
    return out


def timed(fn):
    """``(result, wall_seconds, cpu_seconds)`` of ``fn()``."""
    c0, t0 = time.process_time(), time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t0, time.process_time() - c0


def environment() -> dict:
    """Machine and software identity for a JSON record (load average included).

    Examples
    --------
    >>> sorted(environment())[:3]
    ['cpu_count', 'loadavg', 'machine']
    """
    try:
        load = list(os.getloadavg())
    except OSError:
        load = None

    return {"cpu_count": default_threads(), "loadavg": load, "machine": platform.machine(),
            "python": platform.python_version(), "reference_tracer": getattr(rt, "__version__", None),
            "note": WALL_CLOCK_NOTE}


def use_variant(variant, threads=None):
    """Select ``variant`` (and Dr.Jit's thread count when given); ``(mitsuba, drjit)``.

    Raises ``RuntimeError`` or ``ValueError`` when the variant does not work here.
    """
    select_variant(variant)
    import drjit as dr
    import mitsuba as mi

    if threads is not None:
        dr.set_thread_count(int(threads))
    return mi, dr


def available_variants(variants, log):
    """The working subset of ``variants`` and ``{variant: reason}`` for the rest.

    A variant named in ``variants`` that is not compiled in or does not run here (e.g.
    no usable libLLVM) is skipped with its reason; LLVM is selected first because Dr.Jit
    reads the libLLVM path when it is first imported.
    """
    ok, skipped = [], {}
    for v in sorted(variants, key=lambda v: not v.startswith("llvm")):
        try:
            use_variant(v)
            ok.append(v)
        except (RuntimeError, ValueError) as exc:
            skipped[v] = str(exc)
            if log:
                log(f"Mitsuba {v}: skipped ({exc})")
    return [v for v in variants if v in ok], skipped


def check_jit_variant(variant, benchmark, log):
    """Check that ``variant`` is a JIT variant (or None) and whether it works here.

    Returns ``(usable, skipped)``: ``usable`` is True when Mitsuba can be timed with it,
    ``skipped`` the ``{variant: reason}`` of :func:`available_variants`.
    """
    if variant is None:
        return False, {}
    if variant.startswith("scalar"):
        raise ValueError(f"the {benchmark} benchmark needs a JIT Mitsuba variant (llvm_ad_rgb) or None")
    ok, skipped = available_variants([variant], log)
    return bool(ok), skipped


def mitsuba_versions() -> dict:
    """Mitsuba's and Dr.Jit's versions, the libLLVM in use and its kernels' target
    (``llvm_target``: CPU and vector width, None where the LLVM backend did not run)."""
    v = versions()
    return {"mitsuba": v["mitsuba"], "drjit": v["drjit"], "libllvm": os.environ.get("DRJIT_LIBLLVM_PATH"),
            "llvm_target": v["llvm_target"]}


def mitsuba_render_fn(mi, mscene, spp, seed):
    """A function rendering ``mscene`` once and returning the image as float64."""
    def go():
        img = mi.render(mscene, spp=int(spp), seed=int(seed))
        return np.array(img, dtype=np.float64)   # forces evaluation and waits for it
    return go


def load_mitsuba(variant, scene, threads, *, check_merge=True):
    """Load ``scene`` in ``variant`` with ``threads`` Dr.Jit threads; ``(mscene, load_seconds)``.

    ``check_merge`` passes ``optimize=mesh_merge_safe(scene)`` (Mitsuba's mesh merging
    turned off where it would flip normals); ``False`` keeps Mitsuba's defaults (the ray
    benchmark's lone torus).
    """
    mi, _ = use_variant(variant, threads)
    kwargs = {"optimize": mesh_merge_safe(scene)} if check_merge else {}
    mscene, load, _ = timed(lambda: mi.load_dict(to_mitsuba(scene), **kwargs))
    return mscene, load
