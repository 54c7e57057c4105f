"""One routine of the catalogue with its parameters (:class:`Routine`), and the outcome of
its tests (:class:`Row`)."""
from __future__ import annotations

import zlib
from dataclasses import dataclass, field
from typing import Callable

from .pearson import Chi2Result

__all__ = ["Routine", "Row"]


@dataclass(frozen=True)
class Routine:
    """One routine with one set of parameters. ``make()`` builds its probe lazily."""

    name: str
    params: tuple              # ((key, value), ...), shown in tables
    kind: str                  # 'warp', 'bsdf', 'mixed' (a Dirac lobe beside a density), 'lobes' or 'light'
    make: Callable[[], dict] = field(compare=False, repr=False)   # -> the probe and its test settings

    @property
    def param_text(self) -> str:
        return ", ".join(f"{k}={v}" for k, v in self.params)

    @property
    def label(self) -> str:
        return f"{self.name}[{self.param_text}]" if self.params else self.name

    def seed(self, base: int) -> int:
        """A seed of its own per routine (stable whatever else is run), from ``base``."""
        return (zlib.crc32(self.label.encode()) + 7919 * int(base)) % 2**32


@dataclass
class Row:
    """The outcome of one routine's tests: ``verdict`` over all its checks."""

    routine: str
    params: str
    n: int
    p_value: float
    verdict: str
    seconds: float
    message: str = ""
    checks: dict = field(default_factory=dict)
    result: Chi2Result | None = field(default=None, repr=False)

    @property
    def passed(self) -> bool:
        return self.verdict == "pass"

    def to_json(self) -> dict:
        r = self.result
        return {"routine": self.routine, "params": self.params, "n": self.n, "p_value": self.p_value,
                "verdict": self.verdict, "seconds": round(self.seconds, 3), "message": self.message,
                "alpha": r.alpha if r else None, "statistic": r.statistic if r else None,
                "dof": r.dof if r else None, "n_valid": r.n_valid if r else None,
                "mass": r.mass if r else None, "mass_p_value": r.mass_p_value if r else None,
                "pooled_in": r.pooled_in if r else None, "pooled_out": r.pooled_out if r else None,
                "checks": self.checks}
