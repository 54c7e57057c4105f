"""The render benchmark's headline: one strategy against each Mitsuba variant, every scene of the run and the
geometric mean (each scene weighs the same), per Russian-roulette configuration.
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
        ``strategy`` and ``integrator`` (the headline's: the first of each), ``variants``, ``against`` (each
        variant's Mitsuba row the ratios pair with: ``Mitsuba v``, or ``Mitsuba v, <isa> kernels`` for a build of
        another instruction set) and ``rows``: per configuration in run order, a row per scene (``configuration``,
        ``rr_depth``, ``scene``, ``ours_paths_per_second``, and against each variant ``v`` ``against_v``,
        ``mitsuba_paths_per_second_v``, ``ratio_v``,
        ``cpu_ratio_v``, ``efficiency_ratio_v``, ``round_ratios_v``, ``round_efficiency_ratios_v``), then a row of
        ``scene`` :data:`GEOMEAN` holding the geometric means (of each round's too) over its ``scenes``.
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
                against = row.get(f"against_{v}") or f"Mitsuba {v}"   # the Mitsuba row the ratios pair with
                theirs = [r["paths_per_second"] for r in summary if r["scene"] == row["scene"]
                          and r["configuration"] == label and r["renderer"] == "mitsuba" and r["variant"] == v
                          and r.get("label", f"Mitsuba {v}") == against]
                out[f"mitsuba_paths_per_second_{v}"] = theirs[0] if theirs else None
                out[f"against_{v}"] = against
                out.update({f"{key}_{v}": row.get(f"{key}_{v}") for key in _RATIOS + _ROUNDS})
            block.append(out)
        mean = {"configuration": label, "rr_depth": block[0]["rr_depth"] if block else None, "scene": GEOMEAN,
                "scenes": len(block), "ours_paths_per_second": None}
        for v in variants:
            mean[f"mitsuba_paths_per_second_{v}"] = None
            mean.update({f"{key}_{v}": geometric_mean(r[f"{key}_{v}"] for r in block) for key in _RATIOS})
            mean.update({f"{key}_{v}": round_geometric_means(r[f"{key}_{v}"] for r in block) for key in _ROUNDS})
        rows += block + [mean]
    against = {v: next((r[f"against_{v}"] for r in rows if r.get(f"against_{v}")), f"Mitsuba {v}") for v in variants}
    return {"strategy": strategy, "integrator": integrator, "variants": variants, "against": against, "rows": rows}
