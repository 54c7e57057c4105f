"""One render judged against another render of the same estimator: ``rtbench compare``'s verdict.

:func:`judge` is :func:`~benchmarks.gate.statistics.compare` of image B against image A as the
reference, with what is known of B's estimator at a high budget (:class:`EstimatorKnowledge`)
floored into both sides.

Examples
--------
>>> import numpy as np
>>> a = (np.full((8, 8, 3), 0.5), np.full((8, 8, 3), 0.25), 64)
>>> judge(a, a, known=EstimatorKnowledge("none"), alpha=0.01).verdict
'pass'
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .heavy_tails import tail_moments
from .statistics import compare

__all__ = ["EstimatorKnowledge", "judge"]


@dataclass
class EstimatorKnowledge:
    """What is known of B's estimator at a high budget: ``moments`` (our tail reference's
    :class:`reference_tracer.SampleMoments`) or ``variance`` (an external renderer's per-sample
    variance), and a ``note`` saying which, or why neither."""

    note: str
    moments: object = None
    variance: np.ndarray | None = None


def _with_knowledge(known: EstimatorKnowledge, ref, test) -> tuple:
    """``(ref, test, moments)`` with B's known variance floored into both sides (under the null
    hypothesis A's estimator is B's; a floor only widens the test)."""
    if known.moments is not None:
        m2, _, _ = tail_moments(known.moments, np.shape(test[0]))
        floor = m2 * (known.moments.n / (known.moments.n - 1.0))
        moments = known.moments
    elif known.variance is not None:
        floor, moments = np.asarray(known.variance, dtype=np.float64), None
    else:
        return ref, test, None
    test = (test[0], np.maximum(test[1], floor), test[2])
    ref = (ref[0], np.maximum(ref[1], floor), ref[2])
    return ref, test, moments


def judge(ref, test, *, known: EstimatorKnowledge, alpha: float):
    """The gate's verdict of B's image against A's, as :func:`benchmarks.compare.compare_stores` gives it.

    Parameters
    ----------
    ref, test : tuple
        ``(mean, per-sample variance, spp)`` of A (the baseline) and of B.
    known : EstimatorKnowledge, keyword-only
        B's estimator at a high budget.
    alpha : float, keyword-only
        Level of this one comparison.

    Returns
    -------
    benchmarks.gate.GateResult
    """
    ref, test, moments = _with_knowledge(known, ref, test)
    return compare(test[0], test[1], test[2], ref[0], ref[1], ref[2], alpha=alpha, tails=moments)
