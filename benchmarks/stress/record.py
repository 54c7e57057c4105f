"""The result of one hard case: :class:`StressRecord` (case, figure, verdict, details)."""
from __future__ import annotations

import time
from dataclasses import dataclass, field

__all__ = ["StressRecord", "make_record"]


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


def make_record(case: str, figure: str, passed, details: dict, t0: float) -> StressRecord:
    """A :class:`StressRecord` timed from ``t0`` (a ``time.perf_counter()`` reading) to now."""
    return StressRecord(case=case, figure=figure, passed=bool(passed), details=details,
                        seconds=time.perf_counter() - t0)
