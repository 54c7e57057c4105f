"""The speed targets (issue 44, :data:`TARGETS`) and their verdicts from a run's own results: the median of the paired
rounds' ratios (the suite's: of each round's geometric mean) with its distribution-free 90% interval, ``met`` or ``not
met``, ``clearly`` or ``within noise``; ``not judged`` with the reason where the run lacks what a target needs. Each
build is judged apart. PERFORMANCE.md, Targets and verdicts."""
from __future__ import annotations

import dataclasses
import math

from mitsuba_scenes import list_scenes

from .common import median_order_interval
from .suite import GEOMEAN, round_geometric_means

__all__ = ["Target", "TARGETS", "SCENE_PATHS", "SCENE_EFFICIENCY", "SUITE_PATHS", "SUITE_EFFICIENCY", "RAYS",
           "judge", "not_judged", "render_verdicts", "ray_verdicts", "speed_verdicts", "verdict_lines"]

COVERAGE = 0.90
#: what the render targets are set on: Mitsuba's variant and default roulette, our headline.
TARGET_VARIANT, TARGET_RR_DEPTH, TARGET_STRATEGY, TARGET_INTEGRATOR = "llvm_ad_rgb", 5, "mis", "wavefront"
#: the ray-casting configurations judged: mesh sizes and ray kinds.
TARGET_TRIANGLES, TARGET_RAY_KINDS = (100_000, 1_000_000), ("primary", "random")


@dataclasses.dataclass(frozen=True)
class Target:
    """One speed target: ours / ``against`` in ``metric`` at least ``threshold``, judged from the ``benchmark``
    (``render`` or ``rays``) on ``scope``."""

    name: str
    benchmark: str
    metric: str
    threshold: float
    against: str
    scope: str

    def __post_init__(self):
        if self.benchmark not in ("render", "rays"):
            raise ValueError(f"benchmark must be 'render' or 'rays', got {self.benchmark!r}")
        if not (isinstance(self.threshold, (int, float)) and math.isfinite(self.threshold) and self.threshold > 0):
            raise ValueError(f"threshold must be a positive number, got {self.threshold!r}")

    def label(self, subject: str) -> str:
        """The start of a verdict line."""
        return f"{subject} {self.metric} vs {self.against} >= {self.threshold:g}x"


_MITSUBA = f"Mitsuba {TARGET_VARIANT}"
SCENE_PATHS = Target("scene paths/s", "render", "paths/s", 1.5, _MITSUBA, "each suite scene")
SCENE_EFFICIENCY = Target("scene efficiency", "render", "efficiency", 1.5, _MITSUBA, "each suite scene")
SUITE_PATHS = Target("suite paths/s", "render", "paths/s", 1.75, _MITSUBA, "suite geometric mean")
SUITE_EFFICIENCY = Target("suite efficiency", "render", "efficiency", 1.75, _MITSUBA, "suite geometric mean")
RAYS = Target("ray casting", "rays", "rays/s", 1.2, "Embree", "100k and 1M triangles, primary and random")
#: every target, in the order verdicts are listed.
TARGETS = (SCENE_PATHS, SCENE_EFFICIENCY, SUITE_PATHS, SUITE_EFFICIENCY, RAYS)

#: the per-round ratio list each render target reads.
_ROUND_KEY = {"paths/s": f"round_ratios_{TARGET_VARIANT}", "efficiency": f"round_efficiency_ratios_{TARGET_VARIANT}"}


def _verdict(target, subject, build, *, line, **fields) -> dict:
    """A verdict with every field (JSON-able)."""
    return {"target": target.name, "benchmark": target.benchmark, "metric": target.metric,
            "threshold": target.threshold, "against": target.against, "subject": subject, "build": build,
            "status": "not judged", "clearly": None, "median": None, "low": None, "high": None, "coverage": None,
            "rounds": 0, "reason": None, **fields, "line": f"{target.label(subject)}: {line}"}


def not_judged(target: Target, subject: str, reason: str, *, build=None) -> dict:
    """The verdict of a target the run could not judge, with the reason.

    >>> not_judged(SUITE_PATHS, "suite geometric mean", "1 of 8 suite scenes in this run")["line"]
    'suite geometric mean paths/s vs Mitsuba llvm_ad_rgb >= 1.75x: not judged: 1 of 8 suite scenes in this run'
    """
    if not reason:
        raise ValueError("a target that is not judged needs its reason")
    return _verdict(target, subject, build, reason=reason, line=f"not judged: {reason}")


def judge(target: Target, subject: str, round_ratios, *, coverage: float = COVERAGE,
          no_rounds: str = "no round gave a finite ratio", build=None) -> dict:
    """The verdict of ``target`` on ``subject`` (of our ``build``, None: the installed core) from its per-round ratios
    (None and non-finite rounds left out): a dict of the target's fields, ``subject``, ``build``, ``status`` (``met``,
    ``not met``, ``not judged``), ``clearly`` (None without an interval), ``median``, ``low``, ``high``, ``coverage``,
    ``rounds``, ``reason`` (why not judged, or why no interval) and ``line``.

    >>> judge(RAYS, "1M triangles, random", [1.1, 1.3, 1.25, 1.15, 1.22])["line"].split(": ", 1)[1]
    'met, within noise (1.22x, 90% interval 1.10-1.30, 5 rounds)'
    """
    iv = median_order_interval(round_ratios or [], coverage=coverage)
    if iv["rounds"] == 0:
        return not_judged(target, subject, no_rounds, build=build)
    m = iv["median"]
    status = "met" if m >= target.threshold else "not met"
    rounds = f"{iv['rounds']} round{'s' if iv['rounds'] != 1 else ''}"
    if iv["low"] is None:
        reason = f"too few rounds for a {100 * coverage:g}% interval: use --repeats {iv['rounds_needed']}"
        return _verdict(target, subject, build, status=status, median=m, rounds=iv["rounds"], reason=reason,
                        line=f"{status} ({m:.2f}x, {rounds}; {reason})")
    clearly = iv["low"] >= target.threshold if status == "met" else iv["high"] < target.threshold
    return _verdict(target, subject, build, status=status, clearly=clearly, median=m, low=iv["low"],
                    high=iv["high"], coverage=iv["coverage"], rounds=iv["rounds"],
                    line=(f"{status}, {'clearly' if clearly else 'within noise'} ({m:.2f}x, {100 * coverage:g}% "
                          f"interval {iv['low']:.2f}-{iv['high']:.2f}, {rounds})"))


def _tag(build) -> str:
    return "" if build is None else f" ({build} build)"


def render_verdicts(result, *, suite_scenes=None, build=None) -> list:
    """Verdicts of the render targets on a render-benchmark ``result`` for our ``build`` (None: the installed core):
    per suite scene paths/s then efficiency, then the geometric mean's two where the run covered the whole suite
    (``suite_scenes``, default ``mitsuba_scenes.list_scenes()``); one ``not judged`` per target where it can judge
    none.

    >>> row = {"scene": "a", "rr_depth": 5, "round_ratios_llvm_ad_rgb": [1.6] * 5,
    ...        "round_efficiency_ratios_llvm_ad_rgb": [2.0] * 5}
    >>> res = {"config": {"variants": ["llvm_ad_rgb"], "max_depth": None},
    ...        "available_variants": ["llvm_ad_rgb"], "skipped_variants": {},
    ...        "suite": {"strategy": "mis", "integrator": "wavefront", "rows": [row]}}
    >>> [v["status"] for v in render_verdicts(res, suite_scenes=["a", "b"])]
    ['met', 'met', 'not judged', 'not judged']
    """
    suite_scenes = list(list_scenes() if suite_scenes is None else suite_scenes)
    suite = result["suite"] if build is None else result["build_suites"][build]
    blocker = _render_blocker(result, suite)
    if blocker:
        return [not_judged(t, t.scope + _tag(build), blocker, build=build) for t in TARGETS if t.benchmark == "render"]
    rows = [r for r in suite["rows"] if r["rr_depth"] == TARGET_RR_DEPTH and r["scene"] != GEOMEAN]
    # A build for another instruction set is judged against Mitsuba's kernels for that set, where they ran.
    against = suite.get("against", {}).get(TARGET_VARIANT, _MITSUBA)
    scene_paths, scene_eff, suite_paths, suite_eff = (dataclasses.replace(t, against=against) for t in
                                                      (SCENE_PATHS, SCENE_EFFICIENCY, SUITE_PATHS, SUITE_EFFICIENCY))
    out = []
    for row in rows:
        subject = row["scene"] + _tag(build)
        if row["scene"] not in suite_scenes:
            out.append(not_judged(scene_paths, subject, "not a suite scene (the targets are set on the suite)",
                                  build=build))
            continue
        out += [judge(t, subject, row.get(_ROUND_KEY[t.metric]), no_rounds=_no_rounds(t), build=build)
                for t in (scene_paths, scene_eff)]
    ran = {r["scene"]: r for r in rows if r["scene"] in suite_scenes}
    subject = "suite geometric mean" + _tag(build)
    if len(ran) < len(suite_scenes):
        return out + [not_judged(t, subject, f"{len(ran)} of {len(suite_scenes)} suite scenes in this run", build=build)
                      for t in (suite_paths, suite_eff)]
    return out + [judge(t, subject, round_geometric_means(ran[s].get(_ROUND_KEY[t.metric]) for s in suite_scenes),
                        no_rounds=_no_rounds(t, suite=True), build=build) for t in (suite_paths, suite_eff)]


def _no_rounds(target, *, suite=False) -> str:
    """Why a render target has no round to judge."""
    if target.metric == "efficiency":
        return (f"no round with a finite efficiency ratio{' in every suite scene' if suite else ''} (an MSE at or "
                f"below the reference's own noise: raise --spp or --reference-spp)")
    return "no per-round ratios in this result"


def _render_blocker(result, suite) -> str | None:
    """Why no render target can be judged on ``result``'s headline ``suite``; None when they can."""
    config = result["config"]
    if TARGET_VARIANT not in result.get("available_variants", []):
        skipped = result.get("skipped_variants", {})
        if TARGET_VARIANT in skipped:
            return f"Mitsuba {TARGET_VARIANT} did not run here ({skipped[TARGET_VARIANT]})"
        return f"Mitsuba {TARGET_VARIANT} not in this run (--variant {','.join(config['variants'])})"
    if not any(r["rr_depth"] == TARGET_RR_DEPTH for r in suite["rows"]):
        depths = ",".join("none" if r is None else str(r) for r in config.get("rr_depths", []))
        return (f"no rr_depth {TARGET_RR_DEPTH} configuration (Mitsuba's default) in this run"
                + (f" (--rr-depth {depths})" if depths else ""))
    for what, option, want in (("strategy", "strategies", TARGET_STRATEGY),
                               ("integrator", "integrators", TARGET_INTEGRATOR)):
        if suite.get(what, want) != want:
            return (f"the headline {what} is {suite[what]}, the targets are set on {want} "
                    f"(list it first in --{option})")
    if config.get("max_depth") is not None:
        return f"--max-depth {config['max_depth']} overrides the scenes' own depth"
    return None


def _size(n: int) -> str:
    """``100000`` -> ``100k``, ``1000000`` -> ``1M``, ``4000`` -> ``4k``, ``500`` -> ``500``."""
    return next((f"{n // k}{unit}" for unit, k in (("M", 10 ** 6), ("k", 1000)) if n >= k and n % k == 0), str(n))


def ray_verdicts(result, *, build=None) -> list:
    """Verdicts of the ray-casting target on a ray-benchmark ``result`` for our ``build``: one per mesh size and ray
    kind judged (``not judged`` where the run left it out), or one ``not judged`` where Embree was not timed.

    >>> rows = [{"requested_triangles": 100_000, "kind": "random", "round_ratios": [0.8, 0.9, 0.85]}]
    >>> res = {"config": {"triangles": [100_000], "kinds": ["random"], "variant": "llvm_ad_rgb"},
    ...        "mitsuba": {"variant": "llvm_ad_rgb"}, "rows": rows}
    >>> [v["status"] for v in ray_verdicts(res)]
    ['not judged', 'not met', 'not judged', 'not judged']
    """
    config, mitsuba = result["config"], result.get("mitsuba", {})
    variant = mitsuba.get("variant")
    why = None
    if not variant:
        skipped = mitsuba.get("skipped", {}).get(config.get("variant"))
        why = (f"no Mitsuba JIT variant in this run (Embree is timed through {TARGET_VARIANT})"
               if config.get("variant") is None else
               f"Mitsuba {config['variant']} did not run here" + (f" ({skipped})" if skipped else ""))
    elif not variant.startswith("llvm"):
        why = f"Mitsuba {variant} does not trace with Embree (an llvm variant does)"
    if why:
        return [not_judged(RAYS, RAYS.scope + _tag(build), why, build=build)]
    out = []
    for n in TARGET_TRIANGLES:
        for kind in TARGET_RAY_KINDS:
            subject = f"{_size(n)} triangles, {kind}{_tag(build)}"
            row = next((r for r in result["rows"] if r.get("requested_triangles") == n and r["kind"] == kind
                        and r.get("build") == build), None)
            if row is not None:
                target = RAYS if not row.get("mitsuba_kernels") else dataclasses.replace(
                    RAYS, against=f"{RAYS.against} (Mitsuba's {row['mitsuba_kernels']} kernels)")
                out.append(judge(target, subject, row.get("round_ratios"), no_rounds="no per-round ratios in this row",
                                 build=build))
                continue
            why = (f"not in this run (--triangles {','.join(map(str, config['triangles']))})"
                   if n not in config["triangles"] else f"not in this run (ray kinds {','.join(config['kinds'])})"
                   if kind not in config["kinds"] else "no row for it in this result")
            out.append(not_judged(RAYS, subject, why, build=build))
    return out


def speed_verdicts(out) -> list:
    """Every verdict of an ``rtbench speed`` run (``out``: benchmark name -> result; the scaling sweeps have no
    target): the installed core's, then each build's."""
    verdicts = []
    for key, judge_it in (("render", render_verdicts), ("rays", ray_verdicts)):
        if key in out:
            for build in (None, *out[key]["config"].get("builds", {})):
                verdicts += judge_it(out[key], build=build)
    return verdicts


def verdict_lines(verdicts) -> list:
    """The closing lines of ``rtbench speed``: a heading with the count of each status, then one line per verdict.

    >>> verdict_lines([not_judged(RAYS, "r", "why")])[0].endswith("0 met, 0 not met, 1 not judged")
    True
    """
    if not verdicts:
        return ["speed targets: none applies to --scaling"]
    counts = {s: sum(v["status"] == s for v in verdicts) for s in ("met", "not met", "not judged")}
    renders = f"; renders at rr_depth {TARGET_RR_DEPTH}" if any(v["benchmark"] == "render" for v in verdicts) else ""
    head = (f"speed targets (median of the paired rounds' ratios, its {100 * COVERAGE:g}% interval from order "
            f"statistics{renders}; benchmarks/PERFORMANCE.md, Targets and verdicts): "
            + ", ".join(f"{n} {s}" for s, n in counts.items()))
    return [head] + [f"  {v['line']}" for v in verdicts]
