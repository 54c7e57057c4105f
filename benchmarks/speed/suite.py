"""The render benchmark's headline: one strategy against each Mitsuba variant, every scene of the run and the
geometric mean (each scene weighs the same), per Russian-roulette configuration.

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
#: the per-variant ratios (suffixed ``_<variant>``) carried into the headline, then the per-round ones.
_RATIOS = ("ratio", "cpu_ratio", "efficiency_ratio")
_ROUNDS = ("round_ratios", "round_efficiency_ratios")


def _ok(v) -> bool:
    return v is not None and math.isfinite(v) and v > 0


def geometric_mean(values) -> float:
    """Geometric mean of the finite positive ``values`` (None skipped); NaN when none is left."""
    xs = [math.log(v) for v in values if _ok(v)]
    return math.exp(sum(xs) / len(xs)) if xs else float("nan")


def round_geometric_means(rounds):
    """Each round's geometric mean over scenes (``rounds``: one list per scene, round ``k`` at index ``k``): NaN for a
    round missing or not positive in some scene, None when a scene has no list or the lists differ in length."""
    rounds = list(rounds)
    if not rounds or not all(rounds) or len({len(x) for x in rounds}) != 1:
        return None
    return [geometric_mean(x[k] for x in rounds) if all(_ok(x[k]) for x in rounds) else float("nan")
            for k in range(len(rounds[0]))]


def suite_summary(result, *, build=None) -> dict:
    """The headline rows of a render-benchmark ``result`` for our ``build`` (None: the installed core).

    Returns
    -------
    dict
        ``strategy`` and ``integrator`` (the headline's: the first of each), ``variants`` and ``rows``: per
        configuration in run order, one row per scene (``configuration``, ``rr_depth``, ``scene``,
        ``ours_paths_per_second``, ``mitsuba_paths_per_second_<v>``, and ``ratio``, ``cpu_ratio``,
        ``efficiency_ratio``, ``round_ratios``, ``round_efficiency_ratios``, each suffixed ``_<v>``), then a row with
        ``scene`` :data:`GEOMEAN` and ``scenes`` (their count) holding the geometric means of the ratios and each
        round's geometric mean over the scenes.
    """
    strategy = result["config"]["strategies"][0]
    integrator = result["config"].get("integrators", ["wavefront"])[0]
    variants = list(result.get("available_variants", []))
    summary = result["summary"]
    rows = []
    for label in dict.fromkeys(r["configuration"] for r in summary):
        block = []
        for row in summary:
            if (row["configuration"] != label or row["renderer"] != "ours" or row["strategy"] != strategy
                    or row.get("integrator", "wavefront") not in (integrator, None) or row.get("build") != build):
                continue
            out = {"configuration": label, "rr_depth": row["rr_depth"], "scene": row["scene"],
                   "ours_paths_per_second": row["paths_per_second"]}
            for v in variants:
                theirs = [r["paths_per_second"] for r in summary if r["scene"] == row["scene"]
                          and r["configuration"] == label and r["renderer"] == "mitsuba" and r["variant"] == v]
                out[f"mitsuba_paths_per_second_{v}"] = theirs[0] if theirs else None
                out.update({f"{key}_{v}": row.get(f"{key}_{v}") for key in _RATIOS + _ROUNDS})
            block.append(out)
        mean = {"configuration": label, "rr_depth": block[0]["rr_depth"] if block else None, "scene": GEOMEAN,
                "scenes": len(block), "ours_paths_per_second": None}
        for v in variants:
            mean[f"mitsuba_paths_per_second_{v}"] = None
            mean.update({f"{key}_{v}": geometric_mean(r[f"{key}_{v}"] for r in block) for key in _RATIOS})
            mean.update({f"{key}_{v}": round_geometric_means(r[f"{key}_{v}"] for r in block) for key in _ROUNDS})
        rows += block + [mean]
    return {"strategy": strategy, "integrator": integrator, "variants": variants, "rows": rows}
