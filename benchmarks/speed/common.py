"""What every speed measurement shares: timing (wall and process CPU time: :data:`WALL_CLOCK_NOTE`), robust summaries
(the median and its interval from order statistics), machine identity, Mitsuba variants."""
from __future__ import annotations

import math
import os
import platform
import statistics
import time

import numpy as np

import reference_tracer as rt
from mitsuba_scenes import to_mitsuba
from mitsuba_scenes.render import mesh_merge_safe
from mitsuba_scenes.variants import llvm_target, select_variant, set_llvm_target, versions
from reference_tracer.cpus import default_threads

from ..numbers import finite_values, median
from .builds import MITSUBA_TARGETS, mitsuba_isas

__all__ = ["WALL_CLOCK_NOTE", "environment", "timed", "median", "spread", "median_order_interval",
           "median_coverage", "rounds_for_coverage", "name_list", "use_variant", "available_variants",
           "check_jit_variant", "mitsuba_versions", "mitsuba_render_timed", "load_mitsuba", "use_mitsuba_kernels",
           "mitsuba_kernel_workers"]

#: printed under every table and stored in every JSON.
WALL_CLOCK_NOTE = ("wall-clock figures are noisy when the machine is shared (other processes steal "
                   "cores); process CPU time (all threads) is recorded beside them; cpu/wall well below "
                   "the thread count means contention or idle workers")


def name_list(name, values, allowed=None) -> list:
    """``values`` (a sequence or a comma-separated string) as a list of distinct names; ``ValueError`` naming ``name``
    when it is empty, has duplicates or a name outside ``allowed``."""
    if isinstance(values, str):
        values = [v for v in values.split(",") if v]
    values = list(values)
    if not values:
        raise ValueError(f"{name} must name at least one entry")
    bad = [v for v in values if allowed is not None and v not in allowed]
    if bad:
        raise ValueError(f"unknown {name} {bad}; choose from {', '.join(allowed)}")
    if len(set(values)) != len(values):
        raise ValueError(f"{name} has duplicates: {values}")
    return values


def spread(xs) -> float:
    """(max - min) / median of the finite values; NaN for fewer than two."""
    xs = finite_values(xs)
    m = statistics.median(xs) if len(xs) > 1 else 0.0
    return (max(xs) - min(xs)) / m if m > 0 else float("nan")


def median_coverage(n: int, k: int) -> float:
    """Coverage of ``[x_(k), x_(n+1-k)]``, the k-th lowest and highest of ``n`` independent draws, as a confidence
    interval for their median: ``1 - 2 P(Binomial(n, 1/2) <= k - 1)`` (exact for a continuous distribution, else a
    lower bound). ``ValueError`` unless ``1 <= k <= (n + 1) / 2``."""
    n, k = int(n), int(k)
    if n < 1 or not 1 <= k <= (n + 1) // 2:
        raise ValueError(f"need 1 <= k <= (n + 1) / 2 order statistics of n >= 1 values, got n={n}, k={k}")
    return 1 - 2 * sum(math.comb(n, i) for i in range(k)) / 2 ** n


def rounds_for_coverage(coverage: float = 0.90) -> int:
    """The fewest values whose lowest and highest bracket the median with ``coverage`` (5 for 90%)."""
    if isinstance(coverage, bool) or not isinstance(coverage, (int, float)) or not 0.0 < coverage < 1.0:
        raise ValueError(f"coverage must be in (0, 1), got {coverage!r}")
    n = 2
    while median_coverage(n, 1) < coverage:
        n += 1
    return n


def median_order_interval(values, *, coverage: float = 0.90) -> dict:
    """Median of the finite ``values`` and a distribution-free confidence interval for it: ``[x_(k), x_(n+1-k)]`` of
    the ``n`` sorted values with the largest ``k`` whose :func:`median_coverage` is at least ``coverage``, valid for
    any distribution of independent values (of paired rounds' ratios), in few rounds.

    Returns
    -------
    dict
        ``median`` (NaN without a finite value), ``rounds`` (finite values), ``low``, ``high``, ``coverage`` (the
        interval's own) and ``rank`` (``k``), all four None below ``rounds_needed`` (:func:`rounds_for_coverage`).

    Examples
    --------
    >>> iv = median_order_interval([1.6, 1.52, 1.7, 1.61, float("nan"), 1.65])
    >>> iv["median"], iv["low"], iv["high"], iv["coverage"], iv["rounds"]
    (1.61, 1.52, 1.7, 0.9375, 5)
    """
    needed = rounds_for_coverage(coverage)
    xs = sorted(float(x) for x in finite_values(values))
    n = len(xs)
    out = {"median": statistics.median(xs) if xs else float("nan"), "rounds": n, "low": None, "high": None,
           "coverage": None, "rank": None, "rounds_needed": needed}
    if n >= needed:
        k = 1
        while k + 1 <= (n + 1) // 2 and median_coverage(n, k + 1) >= coverage:
            k += 1
        out.update(low=xs[k - 1], high=xs[n - k], coverage=median_coverage(n, k), rank=k)
    return out


def timed(fn):
    """``(result, wall_seconds, cpu_seconds)`` of ``fn()``."""
    c0, t0 = time.process_time(), time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t0, time.process_time() - c0


def environment() -> dict:
    """Machine and software identity for a JSON record (load average included)."""
    return {"cpu_count": default_threads(), "loadavg": list(os.getloadavg()) if hasattr(os, "getloadavg") else None,
            "machine": platform.machine(), "python": platform.python_version(),
            "reference_tracer": getattr(rt, "__version__", None), "note": WALL_CLOCK_NOTE}


def use_variant(variant, threads=None):
    """Select ``variant`` (and Dr.Jit's thread count); ``(mitsuba, drjit)``. ``RuntimeError`` or ``ValueError`` where
    it does not work here."""
    select_variant(variant)
    import drjit as dr  # deferred: after the variant and libLLVM are chosen (select_variant)
    import mitsuba as mi  # deferred: after the variant and libLLVM are chosen (select_variant)

    if threads is not None:
        dr.set_thread_count(int(threads))
    return mi, dr


def available_variants(variants, log):
    """The working subset of ``variants`` and ``{variant: reason}`` for the rest; LLVM ones are tried first, since
    Dr.Jit reads the libLLVM path when it is first imported."""
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
    """``(usable, skipped)`` for a JIT ``variant`` (or None: not usable); ``ValueError`` for a scalar one."""
    if variant is None:
        return False, {}
    if variant.startswith("scalar"):
        raise ValueError(f"the {benchmark} benchmark needs a JIT Mitsuba variant (llvm_ad_rgb) or None")
    ok, skipped = available_variants([variant], log)
    return bool(ok), skipped


def mitsuba_versions() -> dict:
    """Mitsuba's and Dr.Jit's versions, the libLLVM in use and its kernels' target (``llvm_target``)."""
    v = versions()
    return {"mitsuba": v["mitsuba"], "drjit": v["drjit"], "libllvm": os.environ.get("DRJIT_LIBLLVM_PATH"),
            "llvm_target": v["llvm_target"]}


def mitsuba_render_timed(variant, mscene, *, spp, seed, threads=None):
    """:func:`timed` render of ``mscene`` in ``variant`` (selected first, untimed), the image as float64."""
    mi, _ = use_variant(variant, threads)
    return timed(lambda: np.array(mi.render(mscene, spp=int(spp), seed=int(seed)), dtype=np.float64))   # waits for it


def load_mitsuba(variant, scene, threads, *, check_merge=True):
    """``(Mitsuba scene, load seconds)`` of ``scene`` in ``variant`` with ``threads`` Dr.Jit threads; ``check_merge``
    turns Mitsuba's mesh merging off where it would flip normals."""
    mi, _ = use_variant(variant, threads)
    kwargs = {"optimize": mesh_merge_safe(scene)} if check_merge else {}
    mscene, load, _ = timed(lambda: mi.load_dict(to_mitsuba(scene), **kwargs))
    return mscene, load


def use_mitsuba_kernels(variant, isa, threads=None) -> dict:
    """Select ``variant`` with its LLVM kernels compiled for ``isa`` (:data:`.builds.MITSUBA_TARGETS`), in a
    :class:`.builds.CoreWorker`: the target holds for the worker's process, set before its first kernel; the target
    (``llvm_target()``). ``RuntimeError`` where it cannot be set."""
    use_variant(variant, threads)
    cpu, features, width = MITSUBA_TARGETS[isa]
    now = llvm_target()
    if now is None or (now["cpu"], now["vector_width"]) != (cpu, width):
        now = set_llvm_target(cpu, features, width)
    return now


def mitsuba_kernel_workers(workers, variant, log=None) -> tuple:
    """The build workers in which Mitsuba ``variant`` also runs, with kernels for the build's ISA where this CPU's are
    wider (:func:`.builds.mitsuba_isas`): ``({build: worker}, {build: target}, {build: why not})``. A worker where the
    target cannot be set is left out with the reason (its build then pairs with this CPU's kernels), logged."""
    chosen, targets, skipped = {}, {}, {}
    if variant is None or not variant.startswith("llvm"):
        return chosen, targets, skipped
    for b in mitsuba_isas(workers, llvm_target()):
        try:
            target = workers[b]("benchmarks.speed.common.use_mitsuba_kernels", variant, b)
        except RuntimeError as e:
            skipped[b] = str(e).strip().splitlines()[-1]
            if log:
                log(f"Mitsuba {variant} with {b} kernels cannot run here ({skipped[b]}): the {b} build pairs with "
                    f"this CPU's kernels")
            continue
        chosen[b], targets[b] = workers[b], f"{target['cpu']}, {target['vector_width']} lanes"
    return chosen, targets, skipped
