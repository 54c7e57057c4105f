"""How many threads "all cores" means for this process.

One answer for the tracer and the harness alike: the CPUs of the affinity mask, fewer where
a cgroup CPU quota (a container's ``--cpus``) allows fewer.
"""
from __future__ import annotations

import math
import os
from pathlib import Path

__all__ = ["cgroup_cpu_limit", "default_threads"]


def cgroup_cpu_limit(root="/sys/fs/cgroup", membership="/proc/self/cgroup") -> float | None:
    """CPUs the cgroup v2 CPU quota lets this process use, or None where no quota is set.

    ``cpu.max`` holds ``QUOTA PERIOD`` (microseconds of CPU time per period) or ``max
    PERIOD`` (no quota). The process's cgroup is read from ``membership`` (the ``0::/path``
    line); a quota anywhere from that cgroup up to ``root`` applies, so the smallest
    ``QUOTA / PERIOD`` of them is returned. In a container the ``root`` itself is usually
    the container's cgroup. Unreadable files count as no quota.

    Examples
    --------
    >>> cgroup_cpu_limit(root="/nonexistent", membership="/nonexistent") is None
    True
    """
    root = Path(root)
    rel = ""
    try:
        for line in Path(membership).read_text().splitlines():
            if line.startswith("0::"):
                rel = line[3:].strip().lstrip("/")
                break
    except OSError:
        pass
    folder = root / rel if rel and ".." not in Path(rel).parts else root
    limits = []
    while True:
        try:
            fields = (folder / "cpu.max").read_text().split()
            quota, period = int(fields[0]), int(fields[1])
        except (OSError, ValueError, IndexError):   # no file, "max", or garbage: no quota here
            pass
        else:
            if quota > 0 and period > 0:
                limits.append(quota / period)
        if folder == root or root not in folder.parents:
            break
        folder = folder.parent
    return min(limits) if limits else None


def default_threads() -> int:
    """All cores this process may use: the CPUs of its affinity mask (``taskset``, a
    cpuset), fewer where a cgroup CPU quota (:func:`cgroup_cpu_limit`, a container's
    ``--cpus``) allows fewer, rounded up; at least 1. What ``--threads`` means unset."""
    n = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    limit = cgroup_cpu_limit()
    if limit is not None:
        n = min(n, math.ceil(limit))
    return max(1, n)
