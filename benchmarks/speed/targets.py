"""The speed targets (issue 44) and their verdicts, judged from a run's own results.

The targets, in one place
-------------------------
:data:`TARGETS`, each a :class:`Target` (what is compared, against what, the ratio to reach):

* render benchmark, each suite scene, in Mitsuba's default configuration (Russian roulette
  from depth 5, :data:`TARGET_RR_DEPTH`): ours (``mis``, the wavefront integrator) at least
  1.5x Mitsuba ``llvm_ad_rgb`` in paths/s (:data:`SCENE_PATHS`) and in efficiency,
  1/(MSE x seconds) against the same reference (:data:`SCENE_EFFICIENCY`);
* the same, as the geometric mean over the whole suite: at least 1.75x
  (:data:`SUITE_PATHS`, :data:`SUITE_EFFICIENCY`);
* ray casting: ours at least 1.2x Embree (Mitsuba's ``ray_intersect_preliminary`` on an
  LLVM variant) on 100k and 1M triangles, primary (camera) and random rays
  (:data:`RAYS`).

How a target is judged
----------------------
From the per-round ratios the benchmarks keep (``round_ratios_<variant>``,
``round_efficiency_ratios_<variant>``, the rays' ``round_ratios``; for the geometric mean,
each round's geometric mean over the suite scenes): the median ratio and a
distribution-free confidence interval for it from order statistics, covering at least
90% (:data:`COVERAGE`; :func:`benchmarks.speed.common.median_order_interval`; with 5
rounds the lowest to the highest round, 93.75%).

* ``met``: the median ratio is at least the threshold; ``not met``: below it.
* ``clearly`` (``met, clearly`` / ``not met, clearly``): the whole interval lies on the
  median's side of the threshold; ``within noise``: the interval straddles it, so more
  rounds (or a quieter machine) could turn the verdict.
* Too few rounds for a 90% interval (fewer than 5): the verdict is the median's alone and
  the line says so.
* ``not judged``: the run did not measure what the target needs (no ``llvm_ad_rgb``, no
  ``rr_depth`` 5, another headline strategy or integrator, ``--max-depth``, part of the
  suite for the geometric mean, a mesh size or ray kind left out, no finite round) and the
  line says why. A target is never passed silently.

A speed target is a measurement, not a correctness verdict: ``rtbench speed`` exits 0
whatever the verdicts, unless ``--require-targets`` is given (then 1 when a judged target
is not met).

Examples
--------
>>> v = judge(SCENE_PATHS, "cornell_box", [1.61, 1.52, 1.70, 1.66, 1.58])
>>> v["line"]
'cornell_box paths/s vs Mitsuba llvm_ad_rgb >= 1.5x: met, clearly (1.61x, 90% interval 1.52-1.70, 5 rounds)'
>>> judge(SCENE_PATHS, "cornell_box", [1.61, 1.45])["line"].split(": ", 1)[1]
'met (1.53x, 2 rounds; too few rounds for a 90% interval: use --repeats 5)'
"""
from __future__ import annotations

import dataclasses
import math

from mitsuba_scenes import list_scenes

from .common import median_order_interval
from .suite import GEOMEAN, round_geometric_means

__all__ = ["Target", "TARGETS", "SCENE_PATHS", "SCENE_EFFICIENCY", "SUITE_PATHS", "SUITE_EFFICIENCY", "RAYS",
           "COVERAGE", "TARGET_VARIANT", "TARGET_RR_DEPTH", "TARGET_STRATEGY", "TARGET_INTEGRATOR",
           "TARGET_TRIANGLES", "TARGET_RAY_KINDS", "STATUSES", "judge", "not_judged", "render_verdicts",
           "ray_verdicts", "speed_verdicts"]

#: the least coverage of the interval around each median ratio.
COVERAGE = 0.90
#: the Mitsuba variant the render targets are set against.
TARGET_VARIANT = "llvm_ad_rgb"
#: Mitsuba's default Russian roulette (``path`` integrator): the configuration judged.
TARGET_RR_DEPTH = 5
#: our headline strategy and integrator the render targets are set on (matched to
#: Mitsuba's ``path`` integrator; the tracer's default integrator).
TARGET_STRATEGY = "mis"
TARGET_INTEGRATOR = "wavefront"
#: the ray-casting configurations judged: mesh sizes (``--triangles``) and ray kinds.
TARGET_TRIANGLES = (100_000, 1_000_000)
TARGET_RAY_KINDS = ("primary", "random")
#: a verdict's ``status``.
STATUSES = ("met", "not met", "not judged")


@dataclasses.dataclass(frozen=True)
class Target:
    """One speed target: ours / ``against`` in ``metric`` at least ``threshold``.

    Attributes
    ----------
    name : str
        Short identifier, stored with each verdict.
    benchmark : {'render', 'rays'}
        The benchmark whose result it is judged from.
    metric : str
        What the ratio compares (``paths/s``, ``efficiency``, ``rays/s``).
    threshold : float
        The least median ratio that meets it.
    against : str
        What ours is compared with, as printed.
    scope : str
        What it applies to, as printed when it cannot be judged at all.

    Examples
    --------
    >>> SCENE_PATHS.label("cornell_box")
    'cornell_box paths/s vs Mitsuba llvm_ad_rgb >= 1.5x'
    """

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
        """The start of a verdict line: ``'<subject> <metric> vs <against> >= <threshold>x'``."""
        return f"{subject} {self.metric} vs {self.against} >= {self.threshold:g}x"


SCENE_PATHS = Target("scene paths/s", "render", "paths/s", 1.5, f"Mitsuba {TARGET_VARIANT}", "each suite scene")
SCENE_EFFICIENCY = Target("scene efficiency", "render", "efficiency", 1.5, f"Mitsuba {TARGET_VARIANT}",
                          "each suite scene")
SUITE_PATHS = Target("suite paths/s", "render", "paths/s", 1.75, f"Mitsuba {TARGET_VARIANT}",
                     "suite geometric mean")
SUITE_EFFICIENCY = Target("suite efficiency", "render", "efficiency", 1.75, f"Mitsuba {TARGET_VARIANT}",
                          "suite geometric mean")
RAYS = Target("ray casting", "rays", "rays/s", 1.2, "Embree",
              "100k and 1M triangles, primary and random")
#: every target, in the order verdicts are listed.
TARGETS = (SCENE_PATHS, SCENE_EFFICIENCY, SUITE_PATHS, SUITE_EFFICIENCY, RAYS)

#: the per-round ratio list each render target reads (suffixed ``_<variant>``).
_ROUND_KEY = {"paths/s": "round_ratios", "efficiency": "round_efficiency_ratios"}


def _verdict(target, subject, **fields) -> dict:
    """A verdict dict with every field (JSON-able); ``line`` is added by the callers."""
    out = {"target": target.name, "benchmark": target.benchmark, "metric": target.metric,
           "threshold": target.threshold, "against": target.against, "subject": subject, "status": "not judged",
           "clearly": None, "median": None, "low": None, "high": None, "coverage": None, "rounds": 0,
           "reason": None}
    out.update(fields)
    return out


def not_judged(target: Target, subject: str, reason: str) -> dict:
    """The verdict of a target the run could not judge, with the reason.

    Examples
    --------
    >>> not_judged(SUITE_PATHS, "suite geometric mean", "1 of 8 suite scenes in this run")["line"]
    'suite geometric mean paths/s vs Mitsuba llvm_ad_rgb >= 1.75x: not judged: 1 of 8 suite scenes in this run'
    """
    if not reason:
        raise ValueError("a target that is not judged needs its reason")
    out = _verdict(target, subject, reason=reason)
    out["line"] = f"{target.label(subject)}: not judged: {reason}"
    return out


def judge(target: Target, subject: str, round_ratios, *, coverage: float = COVERAGE,
          no_rounds: str = "no round gave a finite ratio") -> dict:
    """The verdict of ``target`` on ``subject`` from its per-round ratios.

    Parameters
    ----------
    target : Target
    subject : str
        What was measured (a scene, ``suite geometric mean``, a mesh size and ray kind).
    round_ratios : sequence of float or None
        Ours / theirs, one per paired round; None and non-finite rounds are left out.
    coverage : float, keyword-only
        Least coverage of the interval (module docstring).
    no_rounds : str, keyword-only
        The reason given when no round is left.

    Returns
    -------
    dict
        ``target``, ``benchmark``, ``metric``, ``threshold``, ``against``, ``subject``,
        ``status`` (:data:`STATUSES`), ``clearly`` (True when the whole interval lies on
        the median's side of the threshold, False when it straddles it, None without an
        interval), ``median``, ``low``, ``high``, ``coverage``, ``rounds`` (finite rounds
        counted), ``reason`` (why not judged, or why there is no interval) and ``line``.

    Examples
    --------
    >>> v = judge(RAYS, "1M triangles, random", [1.1, 1.3, 1.25, 1.15, 1.22])
    >>> v["status"], v["clearly"], v["line"].split(": ", 1)[1]
    ('met', False, 'met, within noise (1.22x, 90% interval 1.10-1.30, 5 rounds)')
    >>> judge(RAYS, "1M triangles, random", [None, float("nan")])["status"]
    'not judged'
    """
    if round_ratios is None:
        return not_judged(target, subject, no_rounds)
    iv = median_order_interval(round_ratios, coverage=coverage)
    if iv["rounds"] == 0:
        return not_judged(target, subject, no_rounds)
    m, thr = iv["median"], target.threshold
    status = "met" if m >= thr else "not met"
    head = f"{iv['median']:.2f}x"
    rounds = f"{iv['rounds']} round{'s' if iv['rounds'] != 1 else ''}"
    if iv["low"] is None:
        reason = (f"too few rounds for a {100 * coverage:g}% interval: use --repeats {iv['rounds_needed']}")
        out = _verdict(target, subject, status=status, median=m, rounds=iv["rounds"], reason=reason)
        out["line"] = f"{target.label(subject)}: {status} ({head}, {rounds}; {reason})"
        return out
    clearly = iv["low"] >= thr if status == "met" else iv["high"] < thr
    out = _verdict(target, subject, status=status, clearly=clearly, median=m, low=iv["low"], high=iv["high"],
                   coverage=iv["coverage"], rounds=iv["rounds"])
    out["line"] = (f"{target.label(subject)}: {status}, {'clearly' if clearly else 'within noise'} "
                   f"({head}, {100 * coverage:g}% interval {iv['low']:.2f}-{iv['high']:.2f}, {rounds})")
    return out


def render_verdicts(result, *, suite_scenes=None) -> list:
    """Verdicts of the render targets on a render-benchmark ``result``.

    Parameters
    ----------
    result : dict
        :func:`benchmarks.speed.render_benchmark`'s output (its ``suite`` headline,
        ``config``, ``available_variants`` and ``skipped_variants`` are read).
    suite_scenes : sequence of str or None, keyword-only
        The suite (default ``mitsuba_scenes.list_scenes()``): per-scene targets apply to
        its scenes, the geometric-mean targets only when the run covered all of them.

    Returns
    -------
    list of dict
        :func:`judge`'s verdicts: per suite scene of the run (in run order) paths/s then
        efficiency, then the geometric mean's two; a scene outside the suite gets one
        ``not judged`` line. When the run cannot judge any (no ``llvm_ad_rgb``, no
        ``rr_depth`` 5, another headline strategy or integrator, ``--max-depth``), one
        ``not judged`` verdict per target, with the reason.

    Examples
    --------
    >>> row = {"scene": "a", "rr_depth": 5, "round_ratios_llvm_ad_rgb": [1.6] * 5,
    ...        "round_efficiency_ratios_llvm_ad_rgb": [2.0] * 5}
    >>> res = {"config": {"variants": ["llvm_ad_rgb"], "max_depth": None},
    ...        "available_variants": ["llvm_ad_rgb"], "skipped_variants": {},
    ...        "suite": {"strategy": "mis", "integrator": "wavefront", "rows": [row]}}
    >>> [v["status"] for v in render_verdicts(res, suite_scenes=["a", "b"])]
    ['met', 'met', 'not judged', 'not judged']
    """
    if suite_scenes is None:
        suite_scenes = list_scenes()
    suite_scenes = list(suite_scenes)
    if not suite_scenes:
        raise ValueError("suite_scenes must name at least one scene")
    render_targets = [t for t in TARGETS if t.benchmark == "render"]
    blocker = _render_blocker(result)
    if blocker:
        return [not_judged(t, t.scope, blocker) for t in render_targets]
    v = TARGET_VARIANT
    rows = [r for r in result["suite"]["rows"] if r["rr_depth"] == TARGET_RR_DEPTH and r["scene"] != GEOMEAN]
    out = []
    for row in rows:
        if row["scene"] not in suite_scenes:
            out.append(not_judged(SCENE_PATHS, row["scene"], "not a suite scene (the targets are set on the suite)"))
            continue
        for target in (SCENE_PATHS, SCENE_EFFICIENCY):
            out.append(judge(target, row["scene"], row.get(f"{_ROUND_KEY[target.metric]}_{v}"),
                             no_rounds=_no_rounds(target)))
    ran = {r["scene"]: r for r in rows if r["scene"] in suite_scenes}
    subject = "suite geometric mean"
    for target in (SUITE_PATHS, SUITE_EFFICIENCY):
        if len(ran) < len(suite_scenes):
            out.append(not_judged(target, subject, f"{len(ran)} of {len(suite_scenes)} suite scenes in this run"))
            continue
        rounds = round_geometric_means(ran[s].get(f"{_ROUND_KEY[target.metric]}_{v}") for s in suite_scenes)
        out.append(judge(target, subject, rounds, no_rounds=_no_rounds(target, suite=True)))
    return out


def _no_rounds(target, *, suite=False) -> str:
    """Why a render target has no round to judge (the reason of its ``not judged`` verdict)."""
    if target.metric == "efficiency":
        return (("no round with a finite efficiency ratio in every suite scene" if suite
                 else "no round with a finite efficiency ratio")
                + " (an MSE at or below the reference's own noise: raise --spp or --reference-spp)")
    return "no per-round ratios in this result"


def _render_blocker(result) -> str | None:
    """Why no render target can be judged on ``result``; None when they can."""
    config, suite = result["config"], result["suite"]
    if TARGET_VARIANT not in result.get("available_variants", []):
        skipped = result.get("skipped_variants", {})
        if TARGET_VARIANT in skipped:
            return f"Mitsuba {TARGET_VARIANT} did not run here ({skipped[TARGET_VARIANT]})"
        return f"Mitsuba {TARGET_VARIANT} not in this run (--variant {','.join(config['variants'])})"
    if not any(r["rr_depth"] == TARGET_RR_DEPTH for r in suite["rows"]):
        depths = ",".join("none" if r is None else str(r) for r in config.get("rr_depths", []))
        return (f"no rr_depth {TARGET_RR_DEPTH} configuration (Mitsuba's default) in this run"
                + (f" (--rr-depth {depths})" if depths else ""))
    if suite["strategy"] != TARGET_STRATEGY:
        return (f"the headline strategy is {suite['strategy']}, the targets are set on {TARGET_STRATEGY} "
                f"(list it first in --strategies)")
    if suite.get("integrator", TARGET_INTEGRATOR) != TARGET_INTEGRATOR:
        return (f"the headline integrator is {suite['integrator']}, the targets are set on {TARGET_INTEGRATOR} "
                f"(list it first in --integrators)")
    if config.get("max_depth") is not None:
        return f"--max-depth {config['max_depth']} overrides the scenes' own depth"
    return None


def _size(n: int) -> str:
    """``100000`` -> ``100k``, ``1000000`` -> ``1M``.

    >>> _size(100_000), _size(1_000_000), _size(4000), _size(500)
    ('100k', '1M', '4k', '500')
    """
    if n >= 1_000_000 and n % 1_000_000 == 0:
        return f"{n // 1_000_000}M"
    if n >= 1000 and n % 1000 == 0:
        return f"{n // 1000}k"
    return str(n)


def ray_verdicts(result) -> list:
    """Verdicts of the ray-casting target on a ray-benchmark ``result``.

    Parameters
    ----------
    result : dict
        :func:`benchmarks.speed.ray_benchmark`'s output (``config``, ``mitsuba``, ``rows``
        with ``requested_triangles``, ``kind`` and ``round_ratios``).

    Returns
    -------
    list of dict
        One verdict per configuration of :data:`TARGET_TRIANGLES` x
        :data:`TARGET_RAY_KINDS` (``not judged`` when the run left it out), or a single
        ``not judged`` verdict when Embree was not timed.

    Examples
    --------
    >>> rows = [{"requested_triangles": 100_000, "kind": "random", "round_ratios": [0.8, 0.9, 0.85]}]
    >>> res = {"config": {"triangles": [100_000], "kinds": ["random"], "variant": "llvm_ad_rgb"},
    ...        "mitsuba": {"variant": "llvm_ad_rgb"}, "rows": rows}
    >>> [(v["subject"], v["status"]) for v in ray_verdicts(res)]  # doctest: +NORMALIZE_WHITESPACE
    [('100k triangles, primary', 'not judged'), ('100k triangles, random', 'not met'),
     ('1M triangles, primary', 'not judged'), ('1M triangles, random', 'not judged')]
    """
    config, mitsuba = result["config"], result.get("mitsuba", {})
    variant = mitsuba.get("variant")
    if not variant:
        if config.get("variant") is None:
            why = f"no Mitsuba JIT variant in this run (Embree is timed through {TARGET_VARIANT})"
        else:
            skipped = mitsuba.get("skipped", {}).get(config["variant"])
            why = f"Mitsuba {config['variant']} did not run here" + (f" ({skipped})" if skipped else "")
        return [not_judged(RAYS, RAYS.scope, why)]
    if not variant.startswith("llvm"):
        return [not_judged(RAYS, RAYS.scope, f"Mitsuba {variant} does not trace with Embree (an llvm variant does)")]
    out = []
    for n in TARGET_TRIANGLES:
        for kind in TARGET_RAY_KINDS:
            subject = f"{_size(n)} triangles, {kind}"
            row = next((r for r in result["rows"] if r.get("requested_triangles") == n and r["kind"] == kind), None)
            if row is None:
                if n not in config["triangles"]:
                    why = f"not in this run (--triangles {','.join(map(str, config['triangles']))})"
                elif kind not in config["kinds"]:
                    why = f"not in this run (ray kinds {','.join(config['kinds'])})"
                else:
                    why = "no row for it in this result"
                out.append(not_judged(RAYS, subject, why))
            else:
                out.append(judge(RAYS, subject, row.get("round_ratios"), no_rounds="no per-round ratios in this row"))
    return out


def speed_verdicts(out) -> list:
    """Every verdict of an ``rtbench speed`` run: ``out`` maps ``render`` / ``rays`` (and
    ``scaling``, which has no target) to the benchmarks' results.

    Examples
    --------
    >>> speed_verdicts({"scaling": {}})
    []
    """
    verdicts = []
    if "render" in out:
        verdicts += render_verdicts(out["render"])
    if "rays" in out:
        verdicts += ray_verdicts(out["rays"])
    return verdicts
