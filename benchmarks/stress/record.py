"""The result of one hard case: :class:`StressRecord` (case, figure, verdict, details)."""
from __future__ import annotations

import functools
import time
from dataclasses import dataclass, field

__all__ = ["StressRecord", "stress_case"]


@dataclass
class StressRecord:
    """One hard case: its measured ``figure`` (one table line), the verdict, every number
    behind it (``details``, JSON-able) and the measurement's wall time.

    >>> StressRecord(case="demo", figure="0 leaks", passed=True).verdict
    'pass'
    """

    case: str
    figure: str
    passed: bool
    details: dict = field(default_factory=dict)
    seconds: float = 0.0

    @property
    def verdict(self) -> str:
        return "pass" if self.passed else "FAIL"


def stress_case(fn):
    """Turn a case function returning ``(figure, passed, details)`` into one returning its
    :class:`StressRecord`, named after the function and timed."""
    @functools.wraps(fn)
    def case(**kwargs) -> StressRecord:
        t0 = time.perf_counter()
        figure, passed, details = fn(**kwargs)
        return StressRecord(fn.__name__, figure, bool(passed), details, time.perf_counter() - t0)
    return case
