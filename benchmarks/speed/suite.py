"""The render benchmark's headline: one strategy against each Mitsuba variant, every scene
of the run and the geometric mean, per Russian-roulette configuration.

:func:`suite_summary` reads the ``summary`` rows of :func:`benchmarks.speed.render_benchmark`
and picks, for each configuration (in the run's order: Mitsuba's default ``rr_depth`` 5
first) and each scene, our row of the headline strategy (the first of the run's
strategies, ``mis`` by default: the one matched to Mitsuba's ``path`` integrator) with
its paired ratios against every variant. A ``geometric mean`` row closes each
configuration: the geometric mean over scenes of each ratio, so that every scene
weighs the same whatever its absolute speed.

Examples
--------
>>> row = {"scene": "a", "configuration": "no RR", "rr_depth": None, "renderer": "ours", "strategy": "mis",
...        "paths_per_second": 2.0e6, "ratio_v": 2.0, "cpu_ratio_v": 2.0, "efficiency_ratio_v": 4.0}
>>> out = suite_summary({"config": {"strategies": ["mis"], "rr_depths": [None]}, "available_variants": ["v"],
...                      "summary": [row, dict(row, scene="b", ratio_v=0.5, efficiency_ratio_v=1.0)]})
>>> [(r["scene"], round(r["ratio_v"], 9), round(r["efficiency_ratio_v"], 9)) for r in out["rows"]]
[('a', 2.0, 4.0), ('b', 0.5, 1.0), ('geometric mean', 1.0, 2.0)]
"""
from __future__ import annotations

import math

__all__ = ["GEOMEAN", "geometric_mean", "round_geometric_means", "suite_summary"]

#: the ``scene`` of each configuration's closing row.
GEOMEAN = "geometric mean"
#: the per-variant ratios carried into the headline (each suffixed ``_<variant>``).
_RATIOS = ("ratio", "cpu_ratio", "efficiency_ratio")
#: the per-round ratio lists carried into the headline (each suffixed ``_<variant>``).
_ROUNDS = ("round_ratios", "round_efficiency_ratios")


def geometric_mean(values) -> float:
    """Geometric mean of the finite positive ``values`` (None skipped); NaN when none is left.

    Examples
    --------
    >>> round(geometric_mean([1.0, 4.0, None, float("nan")]), 12)
    2.0
    >>> geometric_mean([])
    nan
    """
    xs = [float(v) for v in values if v is not None and math.isfinite(v) and v > 0]
    return math.exp(sum(math.log(x) for x in xs) / len(xs)) if xs else float("nan")


def round_geometric_means(rounds):
    """Each round's geometric mean over scenes: ``rounds`` holds one list per scene, round
    ``k`` of each at index ``k``.

    A round whose value is missing or not finite and positive in some scene has no mean
    (NaN), rather than a mean over fewer scenes. None when ``rounds`` is empty, a scene has
    no list, or the lists differ in length.

    Examples
    --------
    >>> [round(x, 9) for x in round_geometric_means([[1.0, 2.0, 3.0], [4.0, 8.0, float("nan")]])[:2]]
    [2.0, 4.0]
    >>> round_geometric_means([[1.0, 2.0], [1.0]]) is None
    True
    """
    rounds = list(rounds)
    if not rounds or not all(rounds) or len({len(x) for x in rounds}) != 1:
        return None

    def ok(v):
        return v is not None and math.isfinite(v) and v > 0

    return [geometric_mean(x[k] for x in rounds) if all(ok(x[k]) for x in rounds) else float("nan")
            for k in range(len(rounds[0]))]


def suite_summary(result) -> dict:
    """The headline rows of a render-benchmark ``result``.

    Parameters
    ----------
    result : dict
        :func:`benchmarks.speed.render_benchmark`'s output (``config``, ``summary``,
        ``available_variants``).

    Returns
    -------
    dict
        ``strategy`` and ``integrator`` (the headline's: the first of each), ``variants``
        and ``rows``: per configuration
        in run order, one row per scene in run order (``configuration``, ``rr_depth``,
        ``scene``, ``ours_paths_per_second``, ``mitsuba_paths_per_second_<variant>`` and
        ``ratio_`` / ``cpu_ratio_`` / ``efficiency_ratio_<variant>``,
        ``round_ratios_<variant>`` and ``round_efficiency_ratios_<variant>``, each round's
        paths/s and efficiency ratio), then a row with ``scene`` :data:`GEOMEAN` holding
        the geometric means of the ratios, each round's geometric mean over the scenes
        (:func:`round_geometric_means`), and ``scenes``, the number of scenes behind them.
    """
    strategy = result["config"]["strategies"][0]
    integrator = result["config"].get("integrators", ["wavefront"])[0]
    variants = list(result.get("available_variants", []))
    summary = result["summary"]
    configurations = _in_order(r["configuration"] for r in summary)
    rows = []
    for label in configurations:
        ours = [r for r in summary if r["configuration"] == label and r["renderer"] == "ours"
                and r["strategy"] == strategy and r.get("integrator", "wavefront") in (integrator, None)]
        block = [_headline_row(r, summary, variants) for r in ours]
        rows += block + [_geomean_row(label, block, variants)]
    return {"strategy": strategy, "integrator": integrator, "variants": variants, "rows": rows}


def _in_order(items) -> list:
    """Distinct ``items`` in first-seen order."""
    seen = []
    for x in items:
        if x not in seen:
            seen.append(x)
    return seen


def _headline_row(row, summary, variants) -> dict:
    """One scene's headline row from our summary ``row`` and the matching Mitsuba rows."""
    out = {"configuration": row["configuration"], "rr_depth": row["rr_depth"], "scene": row["scene"],
           "ours_paths_per_second": row["paths_per_second"]}
    for v in variants:
        theirs = [r for r in summary if r["scene"] == row["scene"] and r["configuration"] == row["configuration"]
                  and r["renderer"] == "mitsuba" and r["variant"] == v]
        out[f"mitsuba_paths_per_second_{v}"] = theirs[0]["paths_per_second"] if theirs else None
        for key in _RATIOS:
            out[f"{key}_{v}"] = row.get(f"{key}_{v}")
        for key in _ROUNDS:
            out[f"{key}_{v}"] = row.get(f"{key}_{v}")
    return out


def _geomean_row(label, block, variants) -> dict:
    """The closing row of configuration ``label``: geometric means of ``block``'s ratios."""
    out = {"configuration": label, "rr_depth": block[0]["rr_depth"] if block else None, "scene": GEOMEAN,
           "scenes": len(block), "ours_paths_per_second": None}
    for v in variants:
        out[f"mitsuba_paths_per_second_{v}"] = None
        for key in _RATIOS:
            out[f"{key}_{v}"] = geometric_mean(r[f"{key}_{v}"] for r in block)
        # Round k's geometric mean over the scenes; None where a scene lacks its rounds.
        for key in _ROUNDS:
            out[f"{key}_{v}"] = round_geometric_means(r.get(f"{key}_{v}") for r in block)
    return out
